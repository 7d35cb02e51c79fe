"""Training data streamed through the fitted layers of a hierarchical SFA network.

A *source* hands the network its training items chunk by chunk: frames in time order
(:class:`ViewSource`: real views, or rotated views materialised on the fly) or panoramas whose
every rotated view is covered at once on the dense periodic grid (the rotation shortcut:
:class:`~sfa_gym.sfa._rotation_source.DenseRotationSource`, in a module of its own). For the
layer being trained, a source runs the layers fitted so far on each chunk, forms the node
inputs, and adds their statistics (samples, time differences) to a
:class:`~sfa_gym.sfa._moments.Moments`. Chunks run ``workers`` at a time; each chunk's
statistics are kept apart and merged in chunk order, so the sums do not depend on the number of
threads. This module holds what every source shares (:class:`Source`, :class:`Pass`, the
layouts of the features) and :class:`ViewSource`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray
from tqdm.auto import tqdm

from sfa_gym.sfa._layers import Affine, LayerParams, layer_patches
from sfa_gym.sfa._moments import Moments, sequence_block
from sfa_gym.sfa._parallel import ordered_map
from sfa_gym.sfa.expansion import n_quadratic_features, quadratic_expand
from sfa_gym.sfa.spec import LayerSpec

__all__ = [
    "Featurize",
    "Pass",
    "Source",
    "ViewSource",
    "features_first",
    "groups",
    "reduce_and_expand",
]

Featurize = Callable[..., NDArray[np.floating]]
"""Node inputs ``(n, R, C, F)`` -> the features whose statistics are gathered ``(E, n, R, C)``;
``sharing=`` (the rotation source) lays them out so that :func:`groups` need not copy them.

Layouts and bits: a product's round-off depends on the layout its operand has (BLAS sums a
transposed operand in another order), so features are formed in :data:`GROUP_ORDER` only where
:func:`groups` would otherwise copy them into that very layout: the statistics are the same to
the bit, without the copies of the features and of their differences."""

GROUP_ORDER = {"layer": (0, 1, 2, 3), "rows": (2, 0, 1, 3)}
"""Per weight sharing, the memory order of the axes of features ``(F, n, R, C)`` in which
:func:`groups` is a view with the samples of each group contiguous (C order)."""


PARTIAL_BYTES = 256 << 20
"""Largest statistics (all groups) copied per chunk so that chunks run in parallel."""


def grouped_empty(
    shape: tuple[int, int, int, int], dtype: type[np.floating], sharing: str
) -> NDArray[np.floating]:
    """An uninitialised array of features ``(F, n, R, C)`` laid out in :data:`GROUP_ORDER`."""
    order = GROUP_ORDER[sharing]
    return np.empty([shape[i] for i in order], dtype=dtype).transpose(np.argsort(order))


def in_group_order(x: NDArray[np.floating], sharing: str) -> bool:
    """Whether features ``x`` ``(F, n, R, C)`` are laid out in :data:`GROUP_ORDER`."""
    return x.transpose(GROUP_ORDER[sharing]).flags.c_contiguous


def groups_copy(x: NDArray[np.floating], sharing: str) -> bool:
    """Whether :func:`groups` has to copy ``x``: its sample axes do not merge in place."""
    axes = (1, 2, 3) if sharing == "layer" else (1, 3)
    dims = [(x.shape[i], x.strides[i]) for i in axes if x.shape[i] != 1]
    return any(outer != n * inner for (_, outer), (n, inner) in zip(dims, dims[1:], strict=False))


def features_first(x: NDArray[np.floating], sharing: str | None = None) -> NDArray[np.floating]:
    """Node inputs ``(n, R, C, F)`` as features ``(F, n, R, C)``: a view, or with ``sharing``,
    where :func:`groups` would copy that view, a copy in :data:`GROUP_ORDER`."""
    features = np.moveaxis(x, -1, 0)
    if sharing is None or not groups_copy(features, sharing):
        return features
    out = grouped_empty(features.shape, x.dtype, sharing)
    np.copyto(out, features)
    return out


def reduce_and_expand(
    reduce: Affine, x: NDArray[np.floating], sharing: str | None = None
) -> NDArray[np.floating]:
    """Expanded linear-SFA outputs of node inputs ``(n, R, C, F)``: ``(E, n, R, C)``, with
    ``sharing`` in :data:`GROUP_ORDER` (C order for one node per layer)."""
    y = reduce.apply(x)
    shape = (n_quadratic_features(y.shape[0]), *y.shape[1:])
    out = None if sharing is None else grouped_empty(shape, y.dtype, sharing)
    return quadratic_expand(y, out=out, axis=0)


def groups(x: NDArray[np.floating], sharing: str) -> NDArray[np.floating]:
    """``(F, n, R, C)`` -> ``(1, F, n*R*C)`` (one node per layer), ``(R, F, n*C)`` (one per
    row) or ``(R*C, F, n)`` (one per position), samples of a group in (n, C) order."""
    f, n, r, c = x.shape
    if sharing == "layer":
        return x.reshape(1, f, n * r * c)
    if sharing == "rows":
        return x.transpose(2, 0, 1, 3).reshape(r, f, n * c)
    return x.reshape(f, n, r * c).transpose(2, 0, 1)


@dataclass(frozen=True)
class Pass:
    """What one pass over the training data needs to know.

    The input of the layer being trained is the output of ``params`` (the fitted layers below)
    applied to the raw data; the first ``cache_level`` of them may already have been applied
    and stored in ``cache`` (one entry per frame or location).
    """

    params: list[LayerParams]
    clips: list[float | None]
    sharing: str  # "layer", "rows" or "none"
    dtype: type[np.floating]
    batch: int
    workers: int = 1
    cache: NDArray[np.floating] | None = None
    cache_level: int = 0


class Source:
    """Streams training data through the fitted layers, chunk by chunk."""

    n_items: int
    dense_cols: int | None = None
    item_group: int = 1  # chunks hold whole runs of this many items

    def chunk_size(self, batch: int) -> int:
        """Items per chunk: ``batch`` rounded up to whole groups of items."""
        return -(-batch // self.item_group) * self.item_group

    def n_blocks(self, batch: int) -> int:
        return -(-self.n_items // self.chunk_size(batch))

    def raw(self, i0: int, i1: int, dtype: type[np.floating]) -> NDArray[np.floating]:
        """Layer-1 input of items ``i0:i1`` as floats ``(n, H, W, 3)``."""
        raise NotImplementedError

    def run_layer(
        self, index: int, p: LayerParams, clip: float | None, a: NDArray[np.floating]
    ) -> NDArray[np.floating]:
        """Output of layer ``index`` on this source's grid."""
        return p.forward(a, clip)

    def node_inputs(
        self, index: int, spec: LayerSpec, grid: tuple[int, int], a: NDArray[np.floating]
    ) -> NDArray[np.floating]:
        """Node input vectors ``(n, R, C, F)`` of layer ``index`` for its input ``a``."""
        return layer_patches(spec, grid, a)

    def layer_input(self, job: Pass, i0: int, i1: int) -> NDArray[np.floating]:
        """Input of the layer above ``job.params`` for items ``i0:i1``."""
        if job.cache is not None:
            a = job.cache[i0:i1]
        else:
            a = self.raw(i0, i1, job.dtype)
        for i in range(job.cache_level if job.cache is not None else 0, len(job.params)):
            a = self.run_layer(i, job.params[i], job.clips[i], a)
        return a

    def chunks(self, batch: int) -> list[tuple[int, int]]:
        """``[(i0, i1)]`` item ranges of :meth:`chunk_size` items (fewer in the last), in
        order."""
        size = self.chunk_size(batch)
        return [(i0, min(i0 + size, self.n_items)) for i0 in range(0, self.n_items, size)]

    def outputs(self, job: Pass, bar: tqdm) -> NDArray[np.floating]:
        """The input of the next layer for every item, stacked (to cache it)."""
        chunks = self.chunks(job.batch)
        first = self.layer_input(job, *chunks[0])
        out = np.empty((self.n_items, *first.shape[1:]), dtype=first.dtype)
        out[: len(first)] = first
        bar.update()

        def fill(chunk: tuple[int, int]) -> None:  # chunks write disjoint slices
            out[chunk[0] : chunk[1]] = self.layer_input(job, *chunk)

        for _ in ordered_map(fill, chunks[1:], job.workers):
            bar.update()
        return out

    def _accumulate_chunks(
        self,
        job: Pass,
        moments: Moments,
        work: Callable[[tuple[int, int], Moments], tuple[Moments, Any, Any]],
        continues: Callable[[int], bool],
        bar: tqdm,
    ) -> None:
        """Run ``work(chunk, into)`` over all chunks and add the boundary differences.

        ``work`` adds a chunk's samples and inner differences to ``into`` and returns
        ``(into, head, tail)``: the features ``(F, 1, R, C)`` of its first and last item (the
        last view of a location for the rotation source). Unless the origin of ``moments`` is
        set already, the first chunk goes straight into ``moments`` (and sets it); the chunks
        run ``job.workers`` at a time on empty copies that are merged in chunk order, so the
        sums do not depend on the number of workers. The difference from one chunk's tail to
        the next chunk's head is added after the merge if ``continues(i0)`` (the next chunk
        continues the sequence; a ``work`` that adds that difference itself returns None for
        head and tail and passes a ``continues`` that is always False).
        """
        chunks = self.chunks(job.batch)
        if moments.shift is None:
            _, _, tail = work(chunks[0], moments)
            bar.update()
            chunks = chunks[1:]
        # statistics of many nodes (e.g. no weight sharing) are too large to copy per chunk:
        # those go straight into ``moments``, one chunk at a time
        separate = moments.n_groups * moments.n_features**2 * 16 <= PARTIAL_BYTES
        workers = job.workers if separate else 1

        def task(chunk: tuple[int, int]) -> tuple[Moments, Any, Any]:
            return work(chunk, moments.partial() if separate else moments)

        for chunk, (part, head, new_tail) in zip(
            chunks, ordered_map(task, chunks, workers), strict=True
        ):
            if part is not moments:
                moments.merge(part)
            if continues(chunk[0]):
                moments.add_differences(groups(head - tail, job.sharing))
            tail = new_tail
            bar.update()

    def accumulate(
        self,
        job: Pass,
        spec: LayerSpec,
        grid: tuple[int, int],
        featurize: Featurize,
        moments: Moments,
        bar: tqdm,
    ) -> None:
        """Add the statistics of ``featurize(node inputs)`` of the layer above ``job.params``."""
        raise NotImplementedError


class ViewSource(Source):
    """Frames in time order (real or materialised rotated views), split into sequences.

    Args:
        get: ``get(i0, i1)`` returns frames ``i0:i1`` ``(n, H, W, 3)``.
        n: number of frames.
        starts: ``(n,)`` bool, True where a sequence starts (no time difference into it).
    """

    def __init__(
        self, get: Callable[[int, int], NDArray[np.uint8]], n: int, starts: NDArray[np.bool_]
    ) -> None:
        self.get, self.n_items, self.starts = get, n, starts

    def raw(self, i0: int, i1: int, dtype: type[np.floating]) -> NDArray[np.floating]:
        return np.asarray(self.get(i0, i1)).astype(dtype)

    def accumulate(self, job, spec, grid, featurize, moments, bar) -> None:
        sharing = job.sharing
        li = len(job.params)

        def features(i0: int, i1: int) -> tuple[NDArray[np.floating], NDArray[np.floating]]:
            a = self.layer_input(job, i0, i1)
            return a, featurize(self.node_inputs(li, spec, grid, a))

        def work(chunk: tuple[int, int], into: Moments) -> tuple[Moments, Any, Any]:
            i0, i1 = chunk
            # the difference into this chunk from the frame before it is formed here, by the
            # worker, rather than after the merge (a serial step)
            before = features(i0 - 1, i0)[1].copy() if i0 and not self.starts[i0] else None
            a, x = features(i0, i1)
            f, n, r, c = x.shape
            if before is not None:
                into.add_differences(groups(x[:, :1] - before, sharing))
            if into.n_groups == 1 and into.quadratic is None and sequence_block(n, r * c) > 1:
                # samples and differences of each run of one sequence from shared products
                samples_first = np.moveaxis(x, 0, -1).flags.c_contiguous
                if not (samples_first or x.flags.c_contiguous):
                    x = np.moveaxis(np.ascontiguousarray(np.moveaxis(x, 0, -1)), -1, 0)
                    samples_first = True
                own = not np.may_share_memory(x, a)  # a fresh array, not the cached input
                cuts = [0, *(np.flatnonzero(self.starts[i0 + 1 : i1]) + 1), n]
                for s0, s1 in zip(cuts[:-1], cuts[1:], strict=True):
                    if samples_first:
                        run = np.moveaxis(x[:, s0:s1], 0, -1).reshape(s1 - s0, r * c, f)
                    else:
                        run = x[:, s0:s1].reshape(f, s1 - s0, r * c)
                    into.add_sequence(run, float(i0 + s0), samples_first, overwrite=own)
                return into, None, None
            t = np.arange(i0, i1, dtype=np.float64)
            # every group takes the same number of samples from each frame
            into.add_samples(groups(x, sharing), np.repeat(t, r * c // into.n_groups))
            inner = ~self.starts[i0 + 1 : i1]
            if inner.all():
                into.add_differences(groups(x[:, 1:] - x[:, :-1], sharing))
            elif inner.any():
                into.add_differences(groups(x[:, 1:][:, inner] - x[:, :-1][:, inner], sharing))
            return into, None, None

        # the origin from the first chunk up front, so that it too runs in parallel
        i0, i1 = self.chunks(job.batch)[0]
        x = groups(features(i0, i1)[1], sharing) if moments.center else None
        per_frame = int(np.prod(grid)) // moments.n_groups  # samples of a group per frame
        moments.set_origin(x, np.repeat(np.arange(i0, i1, dtype=np.float64), per_frame))
        del x
        self._accumulate_chunks(job, moments, work, lambda i0: False, bar)
