"""The rotation shortcut's training source: every rotated view of each panorama at once, on the
dense periodic grid (:class:`DenseRotationSource`; the other sources and their machinery are in
:mod:`sfa_gym.sfa._sources`).

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

from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from sfa_gym.rotation import check_step, check_window, rotation_columns, rotation_sequence
from sfa_gym.sfa._layers import LayerParams, layer_patches
from sfa_gym.sfa._moments import Moments
from sfa_gym.sfa._parallel import ordered_map
from sfa_gym.sfa._periodic import plan_weighted_gram
from sfa_gym.sfa._sources import (
    Pass,
    Source,
    features_first,
    grouped_empty,
    groups,
    in_group_order,
)
from sfa_gym.sfa._weights import check_weight_sharing
from sfa_gym.sfa.spec import LayerSpec

__all__ = ["DenseRotationSource", "shortcut_applies", "shortcut_obstacle", "take_cols"]


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
