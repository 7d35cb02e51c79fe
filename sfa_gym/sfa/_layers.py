"""Batched execution of one layer of nodes: patch extraction and node functions.

A layer's data is a 4-d array ``(N, R, C, D)``: N frames (or locations), an ``R x C`` grid of
positions, D channels. Patches are cut with ``as_strided`` (no index arrays), columns wrapping
around by padding with the first columns; all nodes of a layer are then applied with one matrix
product (weight sharing) or one batched product over nodes (individual nodes).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.lib.stride_tricks import as_strided
from numpy.typing import NDArray

from sfa_gym.sfa.expansion import n_quadratic_features, quadratic_expand
from sfa_gym.sfa.linear import SFASolution
from sfa_gym.sfa.spec import LayerSpec

_BLOCK_BYTES = 1 << 20
"""Size of the expansion block in :meth:`LayerParams.nodes` (about half the L2 cache)."""


def extract_patches(
    a: NDArray[np.floating],
    field: tuple[int, int],
    stride: tuple[int, int],
    n_cols: int,
    col_dilation: int = 1,
    copy: bool = True,
) -> NDArray[np.floating]:
    """Node input vectors of a layer.

    Args:
        a: ``(N, R_in, C_in, D)`` layer input.
        field, stride: node receptive field and step ``(rows, cols)``.
        n_cols: number of node columns; node ``j`` reads input columns
            ``(j * stride[1] + c * col_dilation) mod C_in`` for ``c < field[1]``. Columns beyond
            the input wrap around (a non-wrapping layer never reaches them).
        col_dilation: spacing of the field's columns (1 for a normal layer; the dense
            rotation grid uses the stride product of the layers below).
        copy: False: the read-only strided view ``(N, R, n_cols, fr, fc, D)`` of ``a`` (or of
            its wrapped copy) instead, for a caller that copies parts of it.

    Returns:
        ``(N, R, n_cols, fr * fc * D)`` C-contiguous, features in (row, col, channel) order.
    """
    n, r_in, c_in, d = a.shape
    fr, fc = field
    sr, sc = stride
    rows = (r_in - fr) // sr + 1
    need = (n_cols - 1) * sc + (fc - 1) * col_dilation + 1
    if need > c_in:
        idx = np.arange(need) % c_in
        a = np.concatenate([a, a[:, :, idx[c_in:]]], axis=2)
    a = np.ascontiguousarray(a)
    s_n, s_r, s_c, s_d = a.strides
    view = as_strided(
        a,
        shape=(n, rows, n_cols, fr, fc, d),
        strides=(s_n, sr * s_r, sc * s_c, s_r, col_dilation * s_c, s_d),
        writeable=False,
    )
    return node_inputs(view) if copy else view


def node_inputs(view: NDArray[np.floating]) -> NDArray[np.floating]:
    """A patch view ``(N, R, C, fr, fc, D)`` as C-contiguous node inputs ``(N, R, C, F)``."""
    return np.ascontiguousarray(view).reshape(*view.shape[:3], -1)


@dataclass
class Affine:
    """``y = x @ weight + bias`` per node, with the SFA delta values of its outputs.

    Shapes: shared ``weight (F, k)``, ``bias (k,)``, ``delta (k,)``; individual nodes have
    leading ``(R, C)`` axes on all three, nodes shared along each row ``(R, 1)``.
    """

    weight: NDArray[np.float64]
    bias: NDArray[np.float64]
    delta: NDArray[np.float64]
    _casts: dict[str, tuple[NDArray[np.floating], NDArray[np.floating]]] = field(
        default_factory=dict, init=False, repr=False, compare=False
    )

    def cast(self, dtype: np.dtype[Any] | type[np.floating]) -> tuple[NDArray[Any], NDArray[Any]]:
        """``(weight, bias)`` in ``dtype``, converted once and kept (inference calls this per
        batch; converting 18 000 weights each time cost more than a small batch's product)."""
        key = np.dtype(dtype).str
        got = self._casts.get(key)
        if got is None:
            got = (
                np.ascontiguousarray(self.weight, dtype=dtype),
                np.ascontiguousarray(self.bias, dtype=dtype),
            )
            self._casts[key] = got
        return got

    @classmethod
    def from_solutions(cls, solutions: list[SFASolution], k: int, grid: tuple[int, int] | None):
        """One affine map from one solution (``grid=None``) or one per node of ``grid``."""
        ws = [s.projection[:, :k] for s in solutions]
        bs = [-(s.mean @ w) for s, w in zip(solutions, ws, strict=True)]
        ds = [s.delta[:k] for s in solutions]
        if grid is None:
            return cls(ws[0], bs[0], ds[0])
        r, c = grid
        return cls(
            np.stack(ws).reshape(r, c, *ws[0].shape),
            np.stack(bs).reshape(r, c, k),
            np.stack(ds).reshape(r, c, k),
        )

    @property
    def shared(self) -> bool:
        return self.weight.ndim == 2

    @property
    def row_shared(self) -> bool:
        return self.weight.ndim == 4 and self.weight.shape[1] == 1

    @property
    def out_dim(self) -> int:
        return int(self.weight.shape[-1])

    def apply(self, x: NDArray[np.floating], features_first: bool = False) -> NDArray[np.floating]:
        """Apply to node inputs; the result is feature-major ``(k, N, R, C)``, ``x``'s dtype.

        Args:
            x: ``(N, R, C, F)``, or ``(F, N, R, C)`` with ``features_first``.
        """
        w, b = self.cast(x.dtype)
        if features_first:
            f, n, r, c = x.shape
        else:
            n, r, c, f = x.shape
        if self.shared:
            # the transposed operand is passed to BLAS as is (no copy)
            rows = x.reshape(f, -1) if features_first else x.reshape(-1, f).T
            y = w.T @ rows
            y += b[:, None]
            return y.reshape(-1, n, r, c)
        # one batched product over nodes: (R, C, k, F) @ (R, C, F, N) -> (R, C, k, N)
        xs = x.transpose(2, 3, 0, 1) if features_first else x.transpose(1, 2, 3, 0)
        y = np.matmul(w.transpose(0, 1, 3, 2), xs)
        y += b[:, :, :, None]
        return np.ascontiguousarray(y.transpose(2, 3, 0, 1))


@dataclass
class LayerParams:
    """A fitted layer: its spec, grid, and node maps (``expand`` is None without expansion)."""

    spec: LayerSpec
    grid: tuple[int, int]
    reduce: Affine
    expand: Affine | None

    @property
    def out_dim(self) -> int:
        return (self.expand or self.reduce).out_dim

    def nodes(self, x: NDArray[np.floating], clip: float | None) -> NDArray[np.floating]:
        """Node outputs for node inputs ``x`` ``(N, R, C, F)``, or their patch view ``(N, R, C,
        fr, fc, D)`` (:func:`extract_patches` with ``copy=False``), -> ``(N, R, C, out_dim)``."""
        if self.reduce.row_shared:
            # each row's node inputs contiguous; from a patch view they are copied only once
            rows = [self._shared_nodes(node_inputs(x[:, r : r + 1]), clip, r) for r in
                    range(x.shape[1])]  # fmt: skip
            return np.concatenate(rows, axis=1)
        if x.ndim == 6:
            x = node_inputs(x)
        if self.reduce.shared and x.flags.c_contiguous:
            return self._shared_nodes(x, clip)
        y = self.reduce.apply(x)
        if self.expand is not None:
            y = self.expand.apply(quadratic_expand(y, axis=0), features_first=True)
        if clip is not None:
            np.clip(y, -clip, clip, out=y)
        return np.ascontiguousarray(np.moveaxis(y, 0, -1))

    def _shared_nodes(
        self, x: NDArray[np.floating], clip: float | None, row: int | None = None
    ) -> NDArray[np.floating]:
        """:meth:`nodes` with weight sharing (the node of grid row ``row`` for nodes shared
        along rows), in blocks of node inputs that stay in cache.

        Per block: reduced outputs ``(k, B)``, their expansion ``(E, B)`` and the block's node
        outputs are computed while the block is in the CPU cache (about 1 MB of expansion),
        instead of writing and re-reading the whole expansion through main memory.
        """
        n, r, c, f = x.shape
        rows = x.reshape(-1, f)
        m = rows.shape[0]
        wr, br = _node(self.reduce.cast(x.dtype), row)
        if self.expand is None:
            out = rows @ wr
            out += br
        else:
            we, be = _node(self.expand.cast(x.dtype), row)
            k, o = wr.shape[1], we.shape[1]
            e = n_quadratic_features(k)
            block = max(1, min(m, _BLOCK_BYTES // (e * x.itemsize)))
            yt = np.empty((block, k), dtype=x.dtype)
            y = np.empty((k, block), dtype=x.dtype)
            q = np.empty((e, block), dtype=x.dtype)
            out = np.empty((m, o), dtype=x.dtype)
            for b0 in range(0, m, block):
                nb = min(block, m - b0)
                # (B, F) @ (F, k) runs faster than the transposed product (measured); the
                # expansion wants rows of features, hence the small transposed copy
                np.matmul(rows[b0 : b0 + nb], wr, out=yt[:nb])
                yt[:nb] += br
                yb = y[:, :nb]
                yb[...] = yt[:nb].T
                qb = quadratic_expand(yb, out=q[:, :nb], axis=0)
                np.matmul(qb.T, we, out=out[b0 : b0 + nb])
            out += be
        if clip is not None:
            np.clip(out, -clip, clip, out=out)
        return out.reshape(n, r, c, -1)

    def forward(
        self,
        a: NDArray[np.floating],
        clip: float | None,
        n_cols: int | None = None,
        col_stride: int | None = None,
        col_dilation: int = 1,
    ) -> NDArray[np.floating]:
        """Layer output for layer input ``a`` ``(N, R_in, C_in, D)`` -> ``(N, R, n_cols, out)``.

        By default the layer's own grid. The rotation shortcut runs a layer on a dense periodic
        grid instead (``n_cols`` nodes, ``col_stride`` and ``col_dilation`` in input columns).
        """
        patches = layer_patches(self.spec, self.grid, a, n_cols, col_stride, col_dilation, False)
        return self.nodes(patches, clip)


def _node(
    weights: tuple[NDArray[np.floating], NDArray[np.floating]], row: int | None
) -> tuple[NDArray[np.floating], NDArray[np.floating]]:
    """``(weight, bias)`` of a shared node, or of row ``row``'s node (``(R, 1, ...)`` arrays)."""
    w, b = weights
    return (w, b) if row is None else (w[row, 0], b[row, 0])


def layer_patches(
    spec: LayerSpec,
    grid: tuple[int, int],
    a: NDArray[np.floating],
    n_cols: int | None = None,
    col_stride: int | None = None,
    col_dilation: int = 1,
    copy: bool = True,
) -> NDArray[np.floating]:
    """Node inputs ``(N, R, n_cols, F)`` of a layer with spec ``spec`` and view grid ``grid``
    (see :meth:`LayerParams.forward` for the arguments; ``copy``: :func:`extract_patches`)."""
    return extract_patches(
        a,
        spec.field,
        (spec.stride[0], spec.stride[1] if col_stride is None else col_stride),
        grid[1] if n_cols is None else n_cols,
        col_dilation,
        copy,
    )
