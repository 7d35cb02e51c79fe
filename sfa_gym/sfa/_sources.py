"""Training data streamed through the fitted layers of a hierarchical SFA network.

A *source* hands the network its training items chunk by chunk: frames in time order
(:class:`ViewSource`: real views, or rotated views materialised on the fly) or panoramas whose
every rotated view is covered at once on the dense periodic grid (:class:`DenseRotationSource`,
the rotation shortcut; see :mod:`sfa_gym.sfa.network`). For the layer being trained, a source
runs the layers fitted so far on each chunk, forms the node inputs, and adds their statistics
(samples, time differences) to a :class:`~sfa_gym.sfa._moments.Moments`. Chunks run
``workers`` at a time; each chunk's statistics are kept apart and merged in chunk order, so the
sums do not depend on the number of threads.

Rotation shortcut (``HierarchicalSFA.fit_rotations``, :func:`shortcut_applies`): with weight
sharing (per layer or per row) and a rotation step that is a multiple of layer 1's column
stride ``s1``, rotating a panorama by one step moves every layer-1 patch onto another layer-1
patch. Run on the *dense* periodic grid (all ``n1 = W / s1`` column offsets, layer ``l`` reading
layer ``l-1`` at column spacing ``P_{l-1}`` = product of the column strides of layers 2..l-1),
each layer is executed once per location, and node ``j`` of layer ``l`` in view ``k`` is dense
column ``(j P_l + k m) mod n1`` (``m = step / s1``): the rotated columns of the dense grid
(:func:`sfa_gym.rotation.rotation_columns` with width ``n1`` and step ``m``). The statistics
over all views are then weighted statistics over the dense grid (the weight of a column = how
many (view, node) pairs land on it), plus the differences between consecutive views (columns
``o -> o + m``) and across locations. This gives the same model as training on every rotated
view (tested), at a fraction of the cost. On the dense grid the inputs of neighbouring nodes of
layers 2, 3, ... overlap, and the second moments of their linear SFA are assembled from
cross-correlations of the layer input, each product of two input values formed once
(:mod:`sfa_gym.sfa._periodic`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray
from tqdm.auto import tqdm

from sfa_gym.rotation import check_step, check_window, rotation_columns, rotation_sequence
from sfa_gym.sfa._layers import Affine, LayerParams, layer_patches
from sfa_gym.sfa._moments import Moments, sequence_block
from sfa_gym.sfa._parallel import ordered_map
from sfa_gym.sfa._periodic import plan_weighted_gram
from sfa_gym.sfa._weights import check_weight_sharing
from sfa_gym.sfa.expansion import n_quadratic_features, quadratic_expand
from sfa_gym.sfa.spec import LayerSpec

__all__ = [
    "DenseRotationSource",
    "Featurize",
    "Pass",
    "Source",
    "ViewSource",
    "features_first",
    "groups",
    "reduce_and_expand",
    "shortcut_applies",
    "shortcut_obstacle",
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


class DenseRotationSource(Source):
    """All rotated views of each panorama via the dense periodic grid.

    Layer 1 runs at every column offset of its stride ``s1`` (``n1 = W / s1`` dense columns);
    rotating a panorama by ``step`` columns moves the dense grid by ``m = step / s1`` columns,
    so the node columns of every rotated view are :func:`~sfa_gym.rotation.rotation_columns`
    of the dense grid (see :mod:`sfa_gym.sfa.network`).

    With several appearances of each location (runs of ``A`` consecutive panoramas), the
    views of a location follow :func:`~sfa_gym.rotation.rotation_sequence`: every (rotation,
    node) pair is a sample of each of the ``A`` panoramas, as with one appearance; the time
    differences are those between appearances at the same dense column, and the rotation steps
    taken in the appearance the snake ends each rotation on.

    Args:
        panoramas: ``(L * A, H, W, 3)`` uint8.
        step: rotation step in columns, a multiple of layer 1's column stride dividing ``W``.
        layers: the architecture.
        appearances: ``A``, the panoramas of one location (consecutive).
    """

    def __init__(
        self,
        panoramas: NDArray[np.uint8],
        step: int,
        layers: Sequence[LayerSpec],
        appearances: int = 1,
    ):
        w = panoramas.shape[2]
        s1 = layers[0].stride[1]
        self.panoramas = panoramas
        self.n_items = panoramas.shape[0]
        self.item_group = appearances
        self.n1 = w // s1
        self.m = step // s1
        self.n_rot = w // step
        self.dense_cols = self.n1
        # column spacing, in layer-1 units, of neighbouring nodes of each layer
        self.unit = [int(u) for u in np.cumprod([1] + [s.stride[1] for s in layers[1:]])]

    def node_columns(self, index: int, n_nodes: int) -> NDArray[np.intp]:
        """``(K, n_nodes)``: the dense column of node ``j`` of layer ``index`` in view ``k``,
        ``(j * unit + k * m) mod n1``."""
        unit = self.unit[index]
        return rotation_columns(self.n1, self.m, (n_nodes - 1) * unit + 1)[:, ::unit]

    def next_view_columns(self) -> NDArray[np.intp]:
        """``(n1,)``: the dense column that column ``o`` moves to in the next view."""
        return rotation_columns(self.n1, self.m, indices=[1])[0]

    def raw(self, i0: int, i1: int, dtype: type[np.floating]) -> NDArray[np.floating]:
        return self.panoramas[i0:i1].astype(dtype)

    def top_outputs(self, job: Pass, top: LayerParams, out: NDArray[np.float64]) -> None:
        """Fill ``out`` ``(L, K, k)`` with the first ``k`` outputs of the top layer ``top`` for
        every rotated view, the layers ``job.params`` below it run once per panorama."""
        index = len(job.params)
        cols = self.node_columns(index, 1)[:, 0]  # dense column of the top node in view k
        batch = max(min(job.batch, -(-self.n_items // 2)), 1)
        k = out.shape[2]

        def run(chunk: tuple[int, int]) -> None:
            l0, l1 = chunk
            a = self.layer_input(job, l0, l1)
            x = self.node_inputs(index, top.spec, top.grid, a)[:, :, cols]
            out[l0:l1] = top.nodes(x, None)[:, 0, :, :k]

        for _ in ordered_map(run, self.chunks(batch), job.workers):
            pass

    def _geometry(self, index: int) -> dict[str, int]:
        if index == 0:
            return {"n_cols": self.n1}
        return {"n_cols": self.n1, "col_stride": 1, "col_dilation": self.unit[index - 1]}

    def run_layer(self, index, p, clip, a):
        return p.forward(a, clip, **self._geometry(index))

    def node_inputs(self, index, spec, grid, a):
        return layer_patches(spec, grid, a, **self._geometry(index))

    def accumulate(self, job, spec, grid, featurize, moments, bar) -> None:
        li = len(job.params)
        n1, m, n_rot, n_app = self.n1, self.m, self.n_rot, self.item_group
        cols = self.node_columns(li, grid[1])  # (K, C): view k, node j
        order_k, order_a = rotation_sequence(n_rot, n_app)
        # time of rotation k under appearance a within its location's sequence
        position = np.empty((n_rot, n_app), dtype=np.float64)
        position[order_k, order_a] = np.arange(n_rot * n_app)
        w = np.bincount(cols.ravel(), minlength=n1).astype(np.float64)
        tk = np.empty((n_app, n1))
        tk2 = np.empty((n_app, n1))
        for a in range(n_app):
            t = np.broadcast_to(position[:, a : a + 1], cols.shape).ravel()
            tk[a] = np.bincount(cols.ravel(), weights=t, minlength=n1)
            tk2[a] = np.bincount(cols.ravel(), weights=t**2, minlength=n1)
        # rotation k -> k + 1 is taken in the appearance rotation k ends on
        ends = order_a[n_app - 1 :: n_app][:-1]
        pairs = {
            int(a): np.bincount(cols[:-1][ends == a].ravel(), minlength=n1).astype(np.float64)
            for a in np.unique(ends)
        }
        first, last = cols[0], cols[-1]
        first_app, last_app = int(order_a[0]), int(order_a[-1])
        # linear SFA of layers 2, 3, ...: products from cross-correlations of the layer input
        # (for one appearance: the rotation steps of several are weighted unevenly over the
        # dense columns, which such a plan rarely fits)
        sharing = job.sharing
        plans = None
        if featurize is features_first and li > 0 and sharing == "layer" and n_app == 1:
            geometry = {
                "rows_in": job.params[-1].grid[0],
                "channels": job.params[-1].out_dim,
                "field": spec.field,
                "row_stride": spec.stride[0],
                "n_rows": grid[0],
                "dilation": self.unit[li - 1],
            }
            plans = {"samples": plan_weighted_gram(w, **geometry)}
            plans.update({a: plan_weighted_gram(p, **geometry) for a, p in pairs.items()})
            if None in plans.values():
                plans = None
        following = self.next_view_columns()

        def add_rotation_steps(into: Moments, x, a_in, weights, plan) -> None:
            """Consecutive views of the panoramas ``x`` ``(F, n, R, n1)``: dense column
            ``o -> following[o]``, weighted by how many node pairs."""
            n_l, r = x.shape[1], x.shape[2]
            if plan is None:
                # ``x[..., following] - x`` formed from two slices (a gather is slower)
                d = np.empty_like(x)  # x's layout: groups(d) is a view too
                np.subtract(x[..., m:], x[..., : n1 - m], out=d[..., : n1 - m])
                np.subtract(x[..., :m], x[..., n1 - m :], out=d[..., n1 - m :])
                shape = (n_l, r // into.n_groups, n1)
                into.add_differences(groups(d, sharing), np.broadcast_to(weights, shape).ravel())
                return
            # the node inputs of the difference field are the differences of node inputs
            da = np.take(a_in, following, axis=2) - a_in
            outer = plan.gram(da, lambda c: x[..., following[c]] - x[..., c])
            into.add_difference_moments(outer[None], n_l * r * float(weights.sum()))

        def add_appearance_steps(into: Moments, x) -> None:
            """Consecutive views of one location under appearances ``b`` and ``b + 1``, at the
            same rotation: the same dense column, every (rotation, node) pair once."""
            for b in range(n_app - 1):
                d = x[:, b + 1 :: n_app] - x[:, b::n_app]
                shape = (d.shape[1], d.shape[2] // into.n_groups, n1)
                into.add_differences(groups(d, sharing), np.broadcast_to(w, shape).ravel())

        def work(chunk: tuple[int, int], into: Moments) -> tuple[Moments, Any, Any]:
            l0, l1 = chunk
            a_in = self.layer_input(job, l0, l1)
            x = featurize(self.node_inputs(li, spec, grid, a_in), sharing=sharing)
            f, n_l, r, _ = x.shape  # (F, L, R, n1)
            # view (location, position) has time index location * K * A + position
            item = np.arange(l0, l1)
            base = ((item // n_app) * (n_rot * n_app)).astype(np.float64)[:, None, None]
            app = item % n_app
            shape = (n_l, r // into.n_groups, n1)  # the samples of one group
            into.add_samples(
                groups(x, sharing),
                times=np.broadcast_to(base * w + tk[app][:, None], shape).ravel(),
                weights=np.broadcast_to(w, shape).ravel(),
                times_sq=np.broadcast_to(
                    base**2 * w + 2 * base * tk[app][:, None] + tk2[app][:, None], shape
                ).ravel(),
                outer=None
                if plans is None
                else plans["samples"].gram(a_in, lambda c: x[..., c])[None],
            )
            for a, weights in pairs.items():
                add_rotation_steps(
                    into,
                    x[:, a::n_app],
                    a_in[a::n_app],
                    weights,
                    None if plans is None else plans[a],
                )
            add_appearance_steps(into, x)
            # from the last view of one location to the first view of the next
            if n_l > n_app:
                heads = x[:, n_app + first_app :: n_app]
                tails = x[:, last_app : n_l - n_app : n_app]
                pair = take_cols(heads, first), take_cols(tails, last)
                if in_group_order(x, sharing):
                    d = grouped_empty(pair[0].shape, x.dtype, sharing)
                    np.subtract(*pair, out=d)
                else:
                    d = pair[0] - pair[1]
                into.add_differences(groups(d, sharing))
            # copies: a view would keep the whole chunk alive until it is merged
            tail = n_l - n_app + last_app
            return (
                into,
                take_cols(x[:, first_app : first_app + 1], first).copy(),
                take_cols(x[:, tail : tail + 1], last).copy(),
            )

        self._accumulate_chunks(job, moments, work, lambda i0: True, bar)


def take_cols(x: NDArray[np.floating], idx: NDArray[np.intp]) -> NDArray[np.floating]:
    """``x[..., idx]`` for ``idx`` made of a few increasing arithmetic runs, via slices
    (gathering element by element along the contiguous last axis is several times slower)."""
    parts: list[NDArray[np.floating]] = []
    i, n = 0, len(idx)
    while i < n:
        j = i + 1
        step = int(idx[j] - idx[i]) if j < n else 1
        if step <= 0:
            step, j = 1, i + 1  # a run of one
        else:
            while j < n and idx[j] - idx[j - 1] == step:
                j += 1
        parts.append(x[..., idx[i] : idx[j - 1] + 1 : step])
        if len(parts) > 4:
            return x[..., idx]
        i = j
    return parts[0] if len(parts) == 1 else np.concatenate(parts, axis=-1)


def shortcut_obstacle(
    layers: Sequence[LayerSpec], width: int, step: int, window: int, weight_sharing: str
) -> str:
    """Why the rotation shortcut cannot be used ('' if it can)."""
    s1 = layers[0].stride[1]
    if weight_sharing == "none":
        return "it needs weight sharing (individual nodes differ between grid positions)"
    if width % s1:
        return f"the panorama width {width} is not a multiple of layer 1's column stride {s1}"
    if step % s1:
        return f"the rotation step {step} is not a multiple of layer 1's column stride {s1}"
    if window < width and any(s.wrap for s in layers):
        return (
            f"the views are cropped to {window} of {width} columns but a layer wraps around "
            "(wrap=True): a cropped window is not periodic"
        )
    return ""


def shortcut_applies(
    layers: Sequence[LayerSpec],
    width: int,
    step: int = 5,
    window: int | None = None,
    weight_sharing: str = "layer",
) -> bool:
    """Whether :meth:`HierarchicalSFA.fit_rotations` can use the dense rotation shortcut."""
    step = check_step(width, step)
    window = check_window(width, window)
    return not shortcut_obstacle(layers, width, step, window, check_weight_sharing(weight_sharing))
