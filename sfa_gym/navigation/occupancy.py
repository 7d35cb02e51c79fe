"""Where the rover can be, and how far it has to drive: an occupancy grid of a world and its
geodesic (shortest-path) distances.

The grid covers the drivable area of the rover's centre (``layout.bounds``: the arena's margin
already keeps the rover off the arena walls); a cell is free when its centre lies farther than
the rover's footprint radius from every obstacle inside the arena (``layout.obstacles``:
bounding circles). Numpy and scipy only.

Geodesic distance. Shortest paths among obstacles run straight between corners of the obstacles,
so the distance is computed on a *visibility graph*: its nodes are the convex corners of the
free space on the grid (a free cell diagonal to a blocked one whose two shared neighbours are
free), its edges join nodes that see each other (the segment stays in free space), and all-pairs
shortest paths are computed once per grid (:func:`scipy.sparse.csgraph.shortest_path`). Then

- the distance from ``p`` to a goal ``g`` is ``|p - g|`` when ``p`` sees ``g``: exactly the
  straight line wherever it is free, so in the open arena every distance is the straight line;
- otherwise it is ``min_a |p - a| + D_g(a)`` over the nodes ``a`` that ``p`` sees, where
  ``D_g(a) = min_b D(a, b) + |b - g|`` over the nodes ``b`` that see ``g`` (computed once per
  goal): the any-angle shortest path around the corners of the grid's obstacles, which is the
  true shortest path to within about a cell.

Unreachable points have an infinite distance.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["GeodesicField", "OccupancyGrid"]


def _points(points: ArrayLike, name: str = "points") -> NDArray[np.float64]:
    p = np.asarray(points, dtype=np.float64)
    if p.ndim == 1 and p.shape == (2,):
        p = p[None]
    if p.ndim != 2 or p.shape[1] != 2:
        raise ValueError(f"{name} must be (n, 2) positions (m), got shape {p.shape}")
    return p


@dataclass(frozen=True, eq=False)
class OccupancyGrid:
    """Free space of the rover's centre on a grid.

    Attributes:
        bounds: ``(xmin, xmax, ymin, ymax)`` the grid covers (m): the drivable area.
        resolution: cell size (m); cell ``(j, i)`` is centred at ``(xs[i], ys[j])``.
        free: ``(ny, nx)`` bool.
        xs, ys: cell centres (m).
    """

    bounds: tuple[float, float, float, float]
    resolution: float
    free: NDArray[np.bool_]
    xs: NDArray[np.float64]
    ys: NDArray[np.float64]
    _nodes: NDArray[np.float64] = field(init=False, repr=False)
    _node_distances: NDArray[np.float64] = field(init=False, repr=False)
    _predecessors: NDArray[np.int32] = field(init=False, repr=False)
    _clearance: NDArray[np.float64] = field(init=False, repr=False)
    _nearest_free: NDArray[np.intp] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        from scipy.ndimage import distance_transform_edt
        from scipy.sparse.csgraph import shortest_path

        nodes = self._corner_nodes()
        n = len(nodes)
        graph = np.zeros((n, n))
        for a in range(n):
            if a + 1 < n:
                seen = self.line_of_sight(nodes[a], nodes[a + 1 :])
                lengths = np.linalg.norm(nodes[a + 1 :] - nodes[a], axis=1)
                graph[a, a + 1 :] = np.where(seen, lengths, 0.0)
        graph = graph + graph.T
        if n:
            dist, pred = shortest_path(graph, method="D", directed=False, return_predecessors=True)
        else:
            dist, pred = np.zeros((0, 0)), np.zeros((0, 0), dtype=np.int32)
        object.__setattr__(self, "_nodes", nodes)
        object.__setattr__(self, "_node_distances", dist)
        object.__setattr__(self, "_predecessors", pred)
        # the nearest free cell of every cell: a rover that grazes an obstacle (its centre in the
        # grown margin) is measured from there
        _, (near_j, near_i) = distance_transform_edt(~self.free, return_indices=True)
        object.__setattr__(self, "_nearest_free", np.stack([near_j, near_i], axis=-1))
        # distance (m) from each free cell to the nearest blocked cell or the grid's edge
        padded = np.pad(self.free, 1, constant_values=False)
        object.__setattr__(
            self,
            "_clearance",
            distance_transform_edt(padded)[1:-1, 1:-1] * self.resolution - self.resolution / 2,
        )

    @classmethod
    def from_layout(
        cls, layout: Any, rover_radius: float, resolution: float = 0.05
    ) -> OccupancyGrid:
        """The grid of a generated world (:class:`~sfa_gym.sim.worlds.WorldLayout`) for a rover
        of footprint radius ``rover_radius`` (m)."""
        if not (rover_radius >= 0 and math.isfinite(rover_radius)):
            raise ValueError(f"rover_radius must be >= 0 (m), got {rover_radius!r}")
        xmin, xmax, ymin, ymax = (float(b) for b in layout.bounds)
        if not (resolution > 0 and resolution < min(xmax - xmin, ymax - ymin)):
            raise ValueError(
                f"resolution must be positive and below the drivable area's sides, got {resolution}"
            )
        xs = np.linspace(xmin, xmax, round((xmax - xmin) / resolution) + 1)
        ys = np.linspace(ymin, ymax, round((ymax - ymin) / resolution) + 1)
        gx, gy = np.meshgrid(xs, ys)
        centres = np.stack([gx.ravel(), gy.ravel()], axis=1)
        free = _obstacle_clearance(layout, centres) > rover_radius
        return cls((xmin, xmax, ymin, ymax), float(resolution), free.reshape(gx.shape), xs, ys)

    # -- queries --------------------------------------------------------------------------------

    def _cells(self, p: NDArray[np.float64]) -> tuple[NDArray[np.intp], NDArray[np.intp], NDArray]:
        """Nearest cell indices and whether the points lie on the grid."""
        xmin, xmax, ymin, ymax = self.bounds
        half = self.resolution / 2
        inside = (
            (p[:, 0] >= xmin - half)
            & (p[:, 0] <= xmax + half)
            & (p[:, 1] >= ymin - half)
            & (p[:, 1] <= ymax + half)
        )
        dx = (xmax - xmin) / (len(self.xs) - 1)
        dy = (ymax - ymin) / (len(self.ys) - 1)
        i = np.clip(np.rint((p[:, 0] - xmin) / dx), 0, len(self.xs) - 1)
        j = np.clip(np.rint((p[:, 1] - ymin) / dy), 0, len(self.ys) - 1)
        return j.astype(np.intp), i.astype(np.intp), inside

    def is_free(self, points: ArrayLike) -> NDArray[np.bool_]:
        """``(n,)`` whether the rover's centre may be at each of ``points (n, 2)`` (m)."""
        p = _points(points)
        j, i, inside = self._cells(p)
        return inside & self.free[j, i]

    def clearance(self, points: ArrayLike) -> NDArray[np.float64]:
        """``(n,)`` distance (m) from each point to the nearest place the rover's centre may not
        go (the drivable area's edge, or an obstacle grown by the rover's radius); 0 outside."""
        p = _points(points)
        j, i, inside = self._cells(p)
        return np.where(inside & self.free[j, i], np.maximum(self._clearance[j, i], 0.0), 0.0)

    def line_of_sight(self, a: ArrayLike, b: ArrayLike) -> NDArray[np.bool_]:
        """``(n,)`` whether the segment from ``a (2,)`` to each of ``b (n, 2)`` stays free
        (sampled every quarter cell)."""
        a = np.asarray(a, dtype=np.float64).reshape(2)
        b = _points(b, "b")
        if len(b) == 0:
            return np.zeros(0, dtype=bool)
        length = np.linalg.norm(b - a, axis=1)
        n = max(2, int(np.ceil(length.max() / (self.resolution / 4))) + 1)
        t = np.linspace(0.0, 1.0, n)
        samples = a + (b - a)[:, None, :] * t[None, :, None]  # (m, n, 2)
        return self.is_free(samples.reshape(-1, 2)).reshape(len(b), n).all(axis=1)

    def sample_free(self, rng: np.random.Generator, n: int) -> NDArray[np.float64]:
        """``(n, 2)`` positions drawn uniformly over the free cells (uniform within a cell)."""
        j, i = np.nonzero(self.free)
        if len(j) == 0:
            raise ValueError("the occupancy grid has no free cell")
        pick = rng.integers(len(j), size=n)
        jitter = rng.uniform(-0.5, 0.5, size=(n, 2)) * self.resolution
        p = np.stack([self.xs[i[pick]], self.ys[j[pick]]], axis=1) + jitter
        xmin, xmax, ymin, ymax = self.bounds
        return np.clip(p, (xmin, ymin), (xmax, ymax))

    def geodesic(self, goal: ArrayLike) -> GeodesicField:
        """Geodesic distances to ``goal (2,)`` (see the module docstring)."""
        g = np.asarray(goal, dtype=np.float64).reshape(2)
        return GeodesicField(self, g)

    def shortest_path_length(self, start: ArrayLike, goal: ArrayLike) -> float:
        """Geodesic distance (m) from ``start (2,)`` to ``goal (2,)``; inf if unreachable."""
        return float(self.geodesic(goal).distance(np.asarray(start, dtype=np.float64)[None])[0])

    # -- visibility graph -----------------------------------------------------------------------

    def _corner_nodes(self) -> NDArray[np.float64]:
        """Free cells at the convex corners of blocked regions (see the module docstring)."""
        padded = np.pad(self.free, 1, constant_values=True)  # the grid's edge is no corner
        ny, nx = self.free.shape
        corner = np.zeros((ny, nx), dtype=bool)
        centre = padded[1:-1, 1:-1]
        for dy in (-1, 1):
            for dx in (-1, 1):
                diagonal = padded[1 + dy : 1 + dy + ny, 1 + dx : 1 + dx + nx]
                side_y = padded[1 + dy : 1 + dy + ny, 1 : 1 + nx]
                side_x = padded[1 : 1 + ny, 1 + dx : 1 + dx + nx]
                corner |= centre & ~diagonal & side_y & side_x
        j, i = np.nonzero(corner)
        return np.stack([self.xs[i], self.ys[j]], axis=1)


def _obstacle_clearance(layout: Any, points: NDArray[np.float64]) -> NDArray[np.float64]:
    """Distance from each point to the nearest obstacle surface (inf without obstacles); uses
    ``layout.clearance`` when the layout has it (interior walls), else the obstacle circles."""
    if hasattr(layout, "clearance"):
        return np.asarray(layout.clearance(points), dtype=np.float64)
    out = np.full(len(points), np.inf)
    for x, y, r in layout.obstacles:
        out = np.minimum(out, np.hypot(points[:, 0] - x, points[:, 1] - y) - r)
    return out


class GeodesicField:
    """Geodesic distances to one goal on an :class:`OccupancyGrid` (module docstring)."""

    def __init__(self, grid: OccupancyGrid, goal: NDArray[np.float64]) -> None:
        self.grid = grid
        self.goal = goal
        nodes = grid._nodes
        if len(nodes):
            sees_goal = grid.line_of_sight(goal, nodes)
            legs = np.where(sees_goal, np.linalg.norm(nodes - goal, axis=1), np.inf)
            via = grid._node_distances + legs[None, :]  # (a, b): a -> b -> goal
            self._exit = np.argmin(via, axis=1)
            self._to_goal = via[np.arange(len(nodes)), self._exit]
        else:
            self._exit = np.zeros(0, dtype=np.intp)
            self._to_goal = np.zeros(0)

    def distance(self, points: ArrayLike) -> NDArray[np.float64]:
        """``(n,)`` geodesic distance (m) from each point to the goal; inf where unreachable. A
        point in the margin around an obstacle or just off the grid (a rover grazing an obstacle
        or a wall) is measured via the nearest free cell."""
        p = _points(points)
        out = np.full(len(p), np.inf)
        for k, q in enumerate(p):
            out[k] = self._distance_one(q)[0]
        return out

    def _distance_one(self, q: NDArray[np.float64]) -> tuple[float, int]:
        grid = self.grid
        j, i, _ = grid._cells(q[None])  # off the grid: from its nearest cell
        if not grid.free[j[0], i[0]] or not grid.is_free(q[None])[0]:
            if not grid.free.any():
                return math.inf, -1
            nj, ni = grid._nearest_free[j[0], i[0]]
            snapped = np.array([grid.xs[ni], grid.ys[nj]])
            rest, first = self._distance_one(snapped)
            return float(np.linalg.norm(q - snapped)) + rest, first
        if grid.line_of_sight(q, self.goal[None])[0]:
            return float(np.linalg.norm(q - self.goal)), -1
        if not len(self._to_goal):
            return math.inf, -1
        finite = np.flatnonzero(np.isfinite(self._to_goal))
        seen = finite[grid.line_of_sight(q, grid._nodes[finite])]
        if not seen.size:
            return math.inf, -1
        total = np.linalg.norm(grid._nodes[seen] - q, axis=1) + self._to_goal[seen]
        best = int(np.argmin(total))
        return float(total[best]), int(seen[best])

    def path(self, start: ArrayLike) -> NDArray[np.float64]:
        """``(m, 2)`` polyline of the shortest path from ``start`` to the goal (just the two end
        points when the straight line is free); raises ValueError when unreachable."""
        s = np.asarray(start, dtype=np.float64).reshape(2)
        length, first = self._distance_one(s)
        if not math.isfinite(length):
            raise ValueError(f"the goal {self.goal.tolist()} cannot be reached from {s.tolist()}")
        points = [s]
        if first >= 0:
            last = int(self._exit[first])
            chain = [last]
            pred = self.grid._predecessors
            while chain[-1] != first:
                chain.append(int(pred[first, chain[-1]]))
            points += [self.grid._nodes[a] for a in reversed(chain)]
        points.append(self.goal)
        return np.array(points)
