"""Orders in which a training set visits discrete positions.

The movement statistics shape the slow features: a serpentine sweep over a grid makes the
coordinate along the sweep much faster than the other, whereas a Hilbert curve changes both
coordinates equally slowly and yields two outputs that code the two axes.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray


def hilbert_index(i: NDArray[np.integer], j: NDArray[np.integer], order: int) -> NDArray[np.int64]:
    """Distance along the Hilbert curve filling a ``2**order`` square of cells ``(i, j)``."""
    i = np.asarray(i, dtype=np.int64).copy()
    j = np.asarray(j, dtype=np.int64).copy()
    if order < 1:
        raise ValueError(f"order must be >= 1, got {order}")
    n = 1 << order
    if i.shape != j.shape or np.any((i < 0) | (i >= n) | (j < 0) | (j >= n)):
        raise ValueError(f"cell indices must lie in [0, {n}) and have the same shape")
    d = np.zeros_like(i)
    s = n >> 1
    while s > 0:
        ri = (i & s) > 0
        rj = (j & s) > 0
        d += s * s * ((3 * ri) ^ rj)
        # rotate the quadrant so that the curve inside it has the canonical orientation
        flip = ~rj
        swap_i = np.where(flip & ri, s - 1 - i, i)
        swap_j = np.where(flip & ri, s - 1 - j, j)
        i, j = np.where(flip, swap_j, swap_i), np.where(flip, swap_i, swap_j)
        i &= s - 1
        j &= s - 1
        s >>= 1
    return d


def grid_order(cells: NDArray[np.integer], kind: str = "hilbert") -> NDArray[np.int64]:
    """Permutation that visits grid cells ``(N, 2)`` (integer row/column) in the given order.

    Args:
        cells: integer grid indices, one row per position.
        kind: ``"hilbert"`` (both axes equally slow) or ``"serpentine"`` (row by row,
            alternating direction).
    """
    cells = np.asarray(cells)
    if cells.ndim != 2 or cells.shape[1] != 2 or not np.issubdtype(cells.dtype, np.integer):
        raise ValueError(f"cells must be an integer array of shape (N, 2), got {cells.shape}")
    if kind == "hilbert":
        order = max(1, int(np.ceil(np.log2(max(int(cells.max()) + 1, 2)))))
        key = hilbert_index(cells[:, 0], cells[:, 1], order)
    elif kind == "serpentine":
        row, col = cells[:, 0].astype(np.int64), cells[:, 1].astype(np.int64)
        span = int(col.max()) + 1
        key = row * span + np.where(row % 2 == 0, col, span - 1 - col)
    else:
        raise ValueError(f"kind must be 'hilbert' or 'serpentine', got {kind!r}")
    return np.argsort(key, kind="stable")
