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


def edge_walk(
    cells: NDArray[np.integer], passable: NDArray[np.bool_] | None = None
) -> NDArray[np.int64]:
    """A walk over grid cells ``(N, 2)`` that steps along every edge between 4-neighbouring
    cells exactly once in each direction (an Euler circuit of the doubled grid graph).

    Its consecutive pairs are exactly the grid graph's edges, and a cell appears as often as it
    has neighbours: the transition statistics of a long random walk confined to the cells, without
    its sampling noise, at about four visits per cell. A Hilbert curve through cells with holes
    jumps across them; this walk steps only between neighbours, so slow features learned from
    it see obstacles and walls as a random walk confined to the free cells does (they approximate
    the slowest eigenfunctions of that graph's Laplacian, whose gradients run along walls, not
    into them).

    Args:
        cells: distinct integer grid indices, one row per cell.
        passable: optional ``(N, 4)`` bool: whether the step from cell ``n`` to its neighbour at
            ``+i``, ``-i``, ``+j``, ``-j`` may be taken (e.g. not through a thin wall between
            two free cells); an edge is used when both of its cells allow it.

    Returns:
        Indices into ``cells``, ``2 E + 1`` of them, starting and ending at the first cell of the
        largest connected component (cells in other components are not visited).
    """
    cells = np.asarray(cells)
    if cells.ndim != 2 or cells.shape[1] != 2 or not np.issubdtype(cells.dtype, np.integer):
        raise ValueError(f"cells must be an integer array of shape (N, 2), got {cells.shape}")
    n = len(cells)
    index = {(int(i), int(j)): k for k, (i, j) in enumerate(cells)}
    if len(index) != n:
        raise ValueError("cells must be distinct")
    if passable is None:
        passable = np.ones((n, 4), dtype=bool)
    passable = np.asarray(passable, dtype=bool)
    if passable.shape != (n, 4):
        raise ValueError(f"passable must have shape ({n}, 4), got {passable.shape}")
    moves = ((1, 0), (-1, 0), (0, 1), (0, -1))
    back = (1, 0, 3, 2)  # the move that undoes each move
    neighbours: list[list[int]] = [[] for _ in range(n)]
    for k, (i, j) in enumerate(cells):
        for m, (di, dj) in enumerate(moves):
            other = index.get((int(i) + di, int(j) + dj))
            if other is not None and passable[k, m] and passable[other, back[m]]:
                neighbours[k].append(other)

    start = _largest_component_first(neighbours)
    if not neighbours[start]:
        raise ValueError("no two cells are neighbours: there is no edge to walk")
    # Hierholzer's algorithm on the doubled graph: every neighbour list is an out-arc list, and
    # in-degree equals out-degree everywhere, so one circuit uses every arc once
    used = [0] * n
    stack, circuit = [start], []
    while stack:
        v = stack[-1]
        if used[v] < len(neighbours[v]):
            stack.append(neighbours[v][used[v]])
            used[v] += 1
        else:
            circuit.append(stack.pop())
    return np.array(circuit[::-1], dtype=np.int64)


def _largest_component_first(neighbours: list[list[int]]) -> int:
    """The lowest-numbered cell of the largest connected component."""
    component = [-1] * len(neighbours)
    best, best_size = 0, 0
    for seed in range(len(neighbours)):
        if component[seed] >= 0:
            continue
        component[seed], frontier, size = seed, [seed], 0
        while frontier:
            v = frontier.pop()
            size += 1
            for u in neighbours[v]:
                if component[u] < 0:
                    component[u] = seed
                    frontier.append(u)
        if size > best_size:
            best, best_size = seed, size
    return best
