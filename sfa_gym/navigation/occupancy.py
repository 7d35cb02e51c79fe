"""Where the rover's centre can be, and how far it has to drive: an occupancy grid of a world and
geodesic (shortest-path) distances on it. Numpy and scipy only.

Free space. The grid covers the drivable area ``layout.bounds`` with square cells of side
``resolution``. A cell is free when its centre lies in the drivable area (whose margin already
keeps the rover off the arena walls) and farther than ``rover_radius`` from every obstacle and
interior wall (:meth:`sfa_gym.sim.worlds.WorldLayout.clearance`). The free space F is the union of
the free cells as closed squares: a point on a cell edge is free when a cell on either side is (a
path may run along an inflated wall's face), but a grid vertex where only two diagonally opposite
cells are free is not (a pinch of zero width). Everything here -- :meth:`OccupancyGrid.is_free`,
:meth:`OccupancyGrid.line_of_sight`, the geodesic, :meth:`OccupancyGrid.sample_free`, the
components -- refers to that one set: a sampled point is free, and a goal in its component is at
a finite distance. F differs from the rover's true free space by at most half a cell diagonal.

Line of sight is exact for F. The blocked cells are merged into rectangles (maximal runs of a
row, stacked with identical runs of the rows above), and a segment is blocked when it passes
through the interior of one (a slab test, vectorised over segments and rectangles) or through a
pinch; touching a corner or running along a face is free. The few segments that run exactly
along a grid line, where two stacked rectangles meet, are probed cell by cell instead.

Geodesic. A shortest path in a polygonal domain is a polyline that bends only at reflex vertices
of the domain, where it wraps around an obstacle corner; in F these are the grid vertices with
exactly one blocked cell among their four (cells outside the grid count as blocked). Once per
grid (on the first :meth:`OccupancyGrid.geodesic`) the grid finds these corners, the visibility
graph between them, and all its shortest path lengths (``scipy.sparse.csgraph``, Dijkstra from
every corner). Only bitangent edges enter the graph -- the line through each end keeps that
corner's blocked cell on one side; a shortest path uses no other edge -- which also leaves a
quarter of the pairs to check. A goal ``g`` then costs one visibility check from ``g`` to each
corner ``b``; every corner ``a`` gets ``D(a) = min_b d(a, b) + |b - g|`` over the corners ``b``
that ``g`` sees. A query ``p`` returns ``|p - g|`` when ``p`` sees ``g`` -- so the geodesic
*equals* the straight-line distance whenever that segment is free -- and otherwise
``min |p - a| + D(a)`` over the corners ``a`` that ``p`` sees (and is tangent at). The candidates
are checked in increasing order of ``|p - a| + D(a)``, a few at a time; the first visible one is
the answer, so a query checks a handful of segments. The result is the exact shortest path
length in F: any-angle, without the detours of a 4- or 8-connected grid path.

A point outside F (the rover's centre comes closer to a wall than the footprint radius when the
rover drives straight at it) is first moved to the nearest free cell centre; that leg counts, so
the distance stays finite and continuous enough for a progress reward.

Speed (6 x 6 m at 0.05 m, a loaded 2-core machine; ``tests/test_occupancy.py`` checks generous
limits): the corner graph, once per grid, ~5 ms for ``paper_sim_maze`` (40 corners) and ~40 ms
for ``paper_sim_obstacles`` (~180); a goal 0.1-0.4 ms; one query 0.07-0.11 ms in the median,
under 0.5 ms at most; queries of many points at once cost about as much per point.

(Longer than 550 lines on purpose: the free set, its exact line of sight and the geodesic on it
are one definition, read together when judging whether a distance is right.)
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import ndimage, sparse
from scipy.sparse import csgraph

from sfa_gym._checks import check_finite, check_positive
from sfa_gym.sim.worlds.layout import WorldLayout

__all__ = ["GeodesicField", "OccupancyGrid"]

# Tolerance (cells) for a point on a grid line, and (segment fractions) for touching a corner.
_ON_LINE = 1e-9
# How far (cells) past a grid-line crossing the cell-by-cell probe looks.
_PROBE = 1e-6
# Segments x rectangles per slab-test batch, to bound memory.
_BATCH = 1 << 18


def _points(points: ArrayLike, name: str = "points") -> NDArray[np.float64]:
    p = np.asarray(points, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 2:
        raise ValueError(f"{name} must have shape (n, 2), got {p.shape}")
    if not np.isfinite(p).all():
        raise ValueError(f"{name} must be finite, got {p[~np.isfinite(p).all(axis=1)][:3]!r}")
    return p


def _point(point: ArrayLike, name: str) -> NDArray[np.float64]:
    p = np.asarray(point, dtype=np.float64)
    if p.shape != (2,) or not np.isfinite(p).all():
        raise ValueError(f"{name} must be a finite (x, y) pair, got {point!r}")
    return p


def _tangent(blocked: NDArray[np.float64], d: NDArray[np.float64]) -> NDArray[np.bool_]:
    """Whether lines through corners in directions ``d`` keep each corner's blocked cell on one
    side: its two edges at the corner, along ``(sx, 0)`` and ``(0, sy)``, lie on the same side."""
    return d[..., 0] * d[..., 1] * blocked[..., 0] * blocked[..., 1] <= 0


def _slab_visible(
    a: NDArray[np.float64], d: NDArray[np.float64], rects: NDArray[np.float64]
) -> NDArray[np.bool_]:
    """Whether segments ``a + t d``, ``t`` in [0, 1], miss all ``rects`` ``(x0, x1, y0, y1)``
    (open: touching one is missing it)."""
    if len(rects) == 0:
        return np.ones(len(a), dtype=bool)
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / d
        # parallel to a slab: +-inf inside or outside it, nan on its face (fmin/fmax drop nan,
        # which leaves the segment outside)
        tx0 = (rects[:, 0] - a[:, :1]) * inv[:, :1]
        tx1 = (rects[:, 1] - a[:, :1]) * inv[:, :1]
        ty0 = (rects[:, 2] - a[:, 1:]) * inv[:, 1:]
        ty1 = (rects[:, 3] - a[:, 1:]) * inv[:, 1:]
    enter = np.fmax(np.fmax(np.fmin(tx0, tx1), np.fmin(ty0, ty1)), 0.0)
    leave = np.fmin(np.fmin(np.fmax(tx0, tx1), np.fmax(ty0, ty1)), 1.0)
    return ~(enter < leave).any(axis=1)


def _through(
    a: NDArray[np.float64], d: NDArray[np.float64], points: NDArray[np.float64]
) -> NDArray[np.bool_]:
    """Whether segments ``a + t d`` pass through one of ``points`` strictly between their ends."""
    rel = points[None] - a[:, None]  # (m, q, 2)
    cross = d[:, None, 0] * rel[..., 1] - d[:, None, 1] * rel[..., 0]
    length2 = np.maximum((d**2).sum(axis=1), 1e-300)[:, None]
    t = (rel * d[:, None]).sum(axis=2) / length2
    return ((np.abs(cross) <= _ON_LINE * np.sqrt(length2)) & (t > 0) & (t < 1)).any(axis=1)


@dataclass(frozen=True)
class _Graph:
    """The visibility graph of a grid's reflex corners, in cell units."""

    corners: NDArray[np.float64]  # (K, 2) grid vertices (i, j)
    blocked: NDArray[np.float64]  # (K, 2) signs (sx, sy) pointing to each corner's blocked cell
    distance: NDArray[np.float64]  # (K, K) shortest path lengths, inf between components
    predecessor: NDArray[np.int32]  # (K, K) scipy's predecessors: [i, j] precedes j from i


@dataclass(frozen=True, eq=False)
class OccupancyGrid:
    """The cells where the rover's centre may be (see the module docstring).

    Build one with :meth:`from_layout`. Lengths in metres, world frame; point arrays are
    ``(n, 2)`` rows ``(x, y)``.

    Attributes:
        free: ``(ny, nx)`` bool, read-only; ``free[j, i]`` is the cell centred on
            ``(xs[i], ys[j])`` (plot with ``imshow(free, origin="lower", extent=bounds)``).
        origin: ``(x, y)`` of the grid's lower-left corner.
        resolution: side of a cell.
        drivable: the drivable area ``(xmin, xmax, ymin, ymax)`` of the layout.
        rover_radius: how far the rover's centre keeps from obstacles and walls.
        layout: the world layout the grid was built from.
    """

    free: NDArray[np.bool_]
    origin: tuple[float, float]
    resolution: float
    drivable: tuple[float, float, float, float]
    rover_radius: float
    layout: WorldLayout

    @classmethod
    def from_layout(
        cls, layout: WorldLayout | Any, rover_radius: float, resolution: float = 0.05
    ) -> OccupancyGrid:
        """The grid of a world for a rover of ``rover_radius`` (m; e.g.
        :attr:`sfa_gym.sim.rover.RoverSpec.footprint_radius`) with cells of ``resolution`` (m).

        ``layout`` is a :class:`~sfa_gym.sim.worlds.WorldLayout`, or anything with its
        ``bounds``, ``obstacles`` and optionally ``walls`` and ``blocks``.
        """
        if not isinstance(layout, WorldLayout):
            layout = WorldLayout(
                bounds=tuple(layout.bounds),
                obstacles=tuple(tuple(o) for o in layout.obstacles),
                landmarks=(),
                walls=tuple(tuple(w) for w in getattr(layout, "walls", ())),
                blocks=tuple(tuple(k) for k in getattr(layout, "blocks", ())),
            )
        resolution = check_positive("resolution", resolution)
        rover_radius = check_finite("rover_radius", rover_radius, low=0.0)
        xmin, xmax, ymin, ymax = (float(v) for v in layout.bounds)
        if not (xmin < xmax and ymin < ymax):
            raise ValueError(f"layout bounds must be (xmin, xmax, ymin, ymax), got {layout.bounds}")
        nx = max(1, math.ceil((xmax - xmin) / resolution - 1e-9))
        ny = max(1, math.ceil((ymax - ymin) / resolution - 1e-9))
        cx, cy = np.meshgrid(
            xmin + (np.arange(nx) + 0.5) * resolution, ymin + (np.arange(ny) + 0.5) * resolution
        )
        clear = layout.clearance(np.column_stack([cx.ravel(), cy.ravel()])).reshape(ny, nx)
        # the last row or column may overhang the drivable area when the resolution does not
        # divide it
        free = (cx <= xmax) & (cy <= ymax) & (clear > rover_radius)
        free.setflags(write=False)
        return cls(free, (xmin, ymin), resolution, (xmin, xmax, ymin, ymax), rover_radius, layout)

    # -- geometry ------------------------------------------------------------------------------

    @property
    def shape(self) -> tuple[int, int]:
        """``(ny, nx)``: cells along y and along x."""
        ny, nx = self.free.shape
        return ny, nx

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        """``(xmin, xmax, ymin, ymax)`` covered by the grid: the drivable area, rounded up to
        whole cells."""
        ny, nx = self.shape
        x0, y0 = self.origin
        return (x0, x0 + nx * self.resolution, y0, y0 + ny * self.resolution)

    @property
    def xs(self) -> NDArray[np.float64]:
        """``(nx,)`` x of the cell centres."""
        return self.origin[0] + (np.arange(self.shape[1]) + 0.5) * self.resolution

    @property
    def ys(self) -> NDArray[np.float64]:
        """``(ny,)`` y of the cell centres."""
        return self.origin[1] + (np.arange(self.shape[0]) + 0.5) * self.resolution

    def _units(self, points: NDArray[np.float64]) -> NDArray[np.float64]:
        return (points - np.asarray(self.origin)) / self.resolution

    def _metres(self, units: NDArray[np.float64]) -> NDArray[np.float64]:
        return units * self.resolution + np.asarray(self.origin)

    @cached_property
    def _padded(self) -> NDArray[np.bool_]:
        # a blocked border makes every lookup outside the grid blocked
        return np.pad(self.free, 1, constant_values=False)

    def _around(self, u: NDArray[np.float64], cells: NDArray[Any]) -> list[NDArray[Any]]:
        """``cells`` padded by one, at the (up to four) cells whose closure holds each point
        ``(n, 2)`` (cell units): ``[lower-left, lower-right, upper-left, upper-right]``."""
        limit = np.array([self.shape[1], self.shape[0]])
        lo = np.minimum(np.maximum(np.floor(u - _ON_LINE), -1), limit).astype(np.intp) + 1
        hi = np.minimum(np.maximum(np.floor(u + _ON_LINE), -1), limit).astype(np.intp) + 1
        return [cells[y[:, 1], x[:, 0]] for y in (lo, hi) for x in (lo, hi)]

    def _free_units(self, u: NDArray[np.float64]) -> NDArray[np.bool_]:
        """Whether points ``(n, 2)`` in cell units lie in F."""
        f00, f01, f10, f11 = self._around(u, self._padded)
        pinch = (f00 & f11 & ~f01 & ~f10) | (f01 & f10 & ~f00 & ~f11)
        return (f00 | f01 | f10 | f11) & ~pinch

    @cached_property
    def _rects(self) -> NDArray[np.float64]:
        """``(R, 4)`` the blocked cells as rectangles ``(x0, x1, y0, y1)`` in cell units."""
        step = np.diff(np.pad(~self.free, ((0, 0), (1, 1))).astype(np.int8), axis=1)
        row, x0 = np.nonzero(step == 1)
        _, x1 = np.nonzero(step == -1)  # row-major order pairs each run's start with its end
        order = np.lexsort((row, x1, x0))
        row, x0, x1 = row[order], x0[order], x1[order]
        if row.size == 0:
            return np.zeros((0, 4))
        new = np.ones(len(row), dtype=bool)
        new[1:] = (x0[1:] != x0[:-1]) | (x1[1:] != x1[:-1]) | (row[1:] != row[:-1] + 1)
        first = np.flatnonzero(new)
        last = np.append(first[1:], len(row)) - 1
        rects = np.column_stack([x0[first], x1[first], row[first], row[last] + 1]).astype(float)
        # shrunk a little, so that a segment along a face or through a corner misses it despite
        # rounding (metres to cells)
        return rects + np.array([_ON_LINE, -_ON_LINE, _ON_LINE, -_ON_LINE])

    @cached_property
    def _pinches(self) -> NDArray[np.float64]:
        """``(q, 2)`` grid vertices (cell units) where only two diagonal cells are free."""
        f = self._padded
        ll, lr, ul, ur = f[:-1, :-1], f[:-1, 1:], f[1:, :-1], f[1:, 1:]
        j, i = np.nonzero((ll & ur & ~lr & ~ul) | (lr & ul & ~ll & ~ur))
        return np.column_stack([i, j]).astype(float)

    def _visible_units(self, a: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.bool_]:
        """Whether each segment ``a[k] -> b[k]`` (cell units) between free points lies in F."""
        d = b - a
        out = np.empty(len(a), dtype=bool)
        # along a grid line the segment may follow the seam of two stacked rectangles
        length = np.abs(d).max(axis=1, keepdims=True)
        along = ((np.abs(d) <= _ON_LINE * length) & (np.abs(a - np.rint(a)) <= _ON_LINE)).any(
            axis=1
        )
        if along.any():
            out[along] = self._visible_probes(a[along], b[along])
        rest = np.flatnonzero(~along)
        rects = self._rects
        size = max(1, _BATCH // max(1, len(rects)))
        for s in range(0, rest.size, size):
            k = rest[s : s + size]
            out[k] = _slab_visible(a[k], d[k], rects)
        if len(self._pinches) and rest.size:
            out[rest] &= ~_through(a[rest], d[rest], self._pinches)
        return out

    def _visible_probes(self, a: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.bool_]:
        """:meth:`_visible_units` cell by cell: a probe at both ends, at every crossing of a grid
        line (which catches pinches) and just past it (inside the cell the segment enters)."""
        m = len(a)
        d = b - a
        length = np.hypot(d[:, 0], d[:, 1])
        lo, hi = np.minimum(a, b), np.maximum(a, b)
        first = np.ceil(lo - _ON_LINE)
        # a segment along a grid line crosses none across it; the other axis probes it
        count = np.where(np.abs(d) > _ON_LINE, np.floor(hi + _ON_LINE) - first + 1, 0)
        count = np.maximum(count, 0).astype(np.intp).ravel()  # (seg, axis) pairs, row-major
        owner = np.repeat(np.arange(2 * m), count)
        step = np.arange(owner.size) - np.repeat(np.cumsum(count) - count, count)
        t = (first.ravel()[owner] + step - a.ravel()[owner]) / d.ravel()[owner]
        seg = owner // 2
        ends = np.arange(m)
        past = t + (_PROBE / np.maximum(length, _PROBE))[seg]
        seg = np.concatenate([seg, seg, ends, ends])
        t = np.clip(np.concatenate([t, past, np.zeros(m), np.ones(m)]), 0.0, 1.0)
        blocked = ~self._free_units(a[seg] + t[:, None] * d[seg])
        return np.bincount(seg, weights=blocked, minlength=m) == 0

    # -- queries -------------------------------------------------------------------------------

    def is_free(self, points: ArrayLike) -> NDArray[np.bool_]:
        """``(n,)`` whether each of ``points`` ``(n, 2)`` (m) lies in free space (False outside
        the grid)."""
        return self._free_units(self._units(_points(points)))

    def clearance(self, points: ArrayLike) -> NDArray[np.float64]:
        """``(n,)`` distance (m) from each of ``points`` ``(n, 2)`` to the nearest place where the
        rover's centre may not be: the smaller of the distance to the drivable area's boundary
        and ``layout.clearance - rover_radius``; negative there. Exact geometry, not the grid:
        it tells points well inside free space (say >= 0.6 m) from the rest."""
        p = _points(points)
        xmin, xmax, ymin, ymax = self.drivable
        edge = np.minimum(np.minimum(p[:, 0] - xmin, xmax - p[:, 0]),
                          np.minimum(p[:, 1] - ymin, ymax - p[:, 1]))  # fmt: skip
        return np.minimum(edge, self.layout.clearance(p) - self.rover_radius)

    def line_of_sight(self, a: ArrayLike, b: ArrayLike) -> NDArray[np.bool_]:
        """``(n,)`` whether the segment from ``a`` ``(2,)`` to each of ``b`` ``(n, 2)`` (m) lies in
        free space, ends included."""
        start = self._units(_point(a, "a"))
        ends = self._units(_points(b, "b"))
        starts = np.broadcast_to(start, ends.shape)
        ok = self._free_units(ends) & self._free_units(start[None])[0]
        out = np.zeros(len(ends), dtype=bool)
        out[ok] = self._visible_units(starts[ok], ends[ok])
        return out

    # -- components and sampling ---------------------------------------------------------------

    @cached_property
    def labels(self) -> NDArray[np.int32]:
        """``(ny, nx)`` the connected component of each free cell (1, 2, ...; 0 where blocked).
        Cells connect through shared edges, never through a corner alone."""
        labels = ndimage.label(self.free)[0].astype(np.int32)
        labels.setflags(write=False)
        return labels

    @property
    def n_components(self) -> int:
        """Number of connected components of free space."""
        return int(self.labels.max())

    def component(self, points: ArrayLike) -> NDArray[np.int32]:
        """``(n,)`` the component (see :attr:`labels`) of each of ``points`` ``(n, 2)`` (m); 0
        where a point is not free."""
        u = self._units(_points(points))
        # a point on a cell edge belongs to the free cell beside it
        best = np.maximum.reduce(self._around(u, np.pad(self.labels, 1)))
        return np.where(self._free_units(u), best, 0)

    def sample_free(
        self, rng: np.random.Generator, n: int, component: int | None = None
    ) -> NDArray[np.float64]:
        """``(n, 2)`` points (m) drawn uniformly over free space, or over one ``component`` of it
        (see :attr:`labels`), with ``rng`` only."""
        cells = np.flatnonzero(self.free if component is None else self.labels == component)
        if cells.size == 0:
            where = "free space" if component is None else f"component {component!r}"
            raise ValueError(f"cannot sample points: {where} of this grid is empty")
        j, i = np.divmod(cells[rng.integers(cells.size, size=n)], self.shape[1])
        return self._metres(np.column_stack([i, j]) + rng.uniform(size=(n, 2)))

    # -- geodesic ------------------------------------------------------------------------------

    @cached_property
    def _nearest_free(self) -> NDArray[np.intp]:
        """``(2, ny, nx)`` ``(j, i)`` of the nearest free cell to each cell."""
        if not self.free.any():
            raise ValueError("the occupancy grid has no free cell")
        return ndimage.distance_transform_edt(~self.free, return_indices=True)[1]

    def _snap(self, u: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Points (cell units) moved into F, to the nearest free cell centre where outside, and
        how far each moved (cells)."""
        out = ~self._free_units(u)
        if not out.any():
            return u, np.zeros(len(u))
        ny, nx = self.shape
        i = np.clip(np.floor(u[out, 0]), 0, nx - 1).astype(np.intp)
        j = np.clip(np.floor(u[out, 1]), 0, ny - 1).astype(np.intp)
        near = self._nearest_free[:, j, i]
        moved = u.copy()
        moved[out] = np.column_stack([near[1], near[0]]) + 0.5
        return moved, np.hypot(*(moved - u).T)

    @cached_property
    def _graph(self) -> _Graph:
        f = self._padded
        ll, lr, ul, ur = f[:-1, :-1], f[:-1, 1:], f[1:, :-1], f[1:, 1:]
        j, i = np.nonzero(ll.astype(np.int8) + lr + ul + ur == 3)
        corners = np.column_stack([i, j]).astype(float)
        blocked = np.column_stack([
            np.where(~ll[j, i] | ~ul[j, i], -1.0, 1.0),
            np.where(~ll[j, i] | ~lr[j, i], -1.0, 1.0),
        ])  # fmt: skip
        k = len(corners)
        # a corner's component is that of the cell diagonally opposite its blocked cell
        labels = np.pad(self.labels, 1)
        comp = labels[j + (blocked[:, 1] < 0), i + (blocked[:, 0] < 0)]
        a, b = np.triu_indices(k, 1)
        d = corners[b] - corners[a]
        keep = _tangent(blocked[a], d) & _tangent(blocked[b], d) & (comp[a] == comp[b])
        a, b = a[keep], b[keep]
        seen = self._visible_units(corners[a], corners[b])
        a, b = a[seen], b[seen]
        weights = np.hypot(*(corners[b] - corners[a]).T)
        graph = sparse.csr_matrix((weights, (a, b)), shape=(k, k))
        if k:
            dist, pred = csgraph.shortest_path(
                graph, method="D", directed=False, return_predecessors=True
            )
        else:
            dist, pred = np.zeros((0, 0)), np.zeros((0, 0), dtype=np.int32)
        return _Graph(corners, blocked, dist, pred.astype(np.int32))

    def geodesic(self, goal: ArrayLike) -> GeodesicField:
        """Shortest-path distances to ``goal`` ``(2,)`` (m), which must be free; see
        :class:`GeodesicField`."""
        return GeodesicField(self, goal)

    def shortest_path_length(self, start: ArrayLike, goal: ArrayLike) -> float:
        """Geodesic distance (m) from ``start`` ``(2,)`` to ``goal`` ``(2,)``; inf when the goal
        cannot be reached."""
        return float(self.geodesic(goal).distance(_point(start, "start")[None])[0])


def free_goal(grid: OccupancyGrid, goal: ArrayLike) -> NDArray[np.float64]:
    """``goal`` as a ``(2,)`` array; ValueError unless it lies in the free space of ``grid``."""
    g = _point(goal, "goal")
    if not grid.is_free(g[None])[0]:
        raise ValueError(
            f"goal {tuple(g.tolist())} is not in free space: outside the drivable area "
            f"{grid.drivable} or within {grid.rover_radius:.3f} m of an obstacle or wall"
        )
    return g


class GeodesicField:
    """Shortest-path distance to one goal over an :class:`OccupancyGrid` (the method is in the
    module docstring). Build it with :meth:`OccupancyGrid.geodesic`.

    Args:
        grid: the occupancy grid.
        goal: ``(2,)`` the goal (m); it must lie in free space.

    Raises:
        ValueError: the goal is not in free space.
    """

    def __init__(self, grid: OccupancyGrid, goal: ArrayLike) -> None:
        self.grid = grid
        self.goal = free_goal(grid, goal)
        self._g = grid._units(self.goal)
        self._open_box = grid.bounds if grid.free.all() else None
        graph = self._graph = grid._graph
        corners = graph.corners
        k = len(corners)
        # D(a) = min over the corners b that the goal sees of d(a, b) + |b - g|, and that b
        self._ends = np.concatenate([self._g[None], corners])
        self._to_goal = np.full(k, np.inf)
        self._exit = np.full(k, -1, dtype=np.intp)
        near = np.flatnonzero(_tangent(graph.blocked, self._g - corners))
        near = near[grid._visible_units(np.broadcast_to(self._g, (near.size, 2)), corners[near])]
        if near.size:
            total = graph.distance[:, near] + np.hypot(*(corners[near] - self._g).T)
            best = np.argmin(total, axis=1)
            self._to_goal = total[np.arange(k), best]
            self._exit = np.where(np.isfinite(self._to_goal), near[best], -1)

    def __repr__(self) -> str:
        return f"GeodesicField(goal={tuple(self.goal.tolist())})"

    def distance(self, points: ArrayLike) -> NDArray[np.float64]:
        """``(n,)`` geodesic distance (m) from each of ``points`` ``(n, 2)`` to the goal; inf
        where the goal cannot be reached. A point outside free space first moves to the nearest
        free cell centre, and that leg counts."""
        moved, extra = self.grid._snap(self.grid._units(_points(points)))
        return (self._solve(moved)[0] + extra) * self.grid.resolution

    def distance_at(self, x: float, y: float) -> float:
        """:meth:`distance` of the single point ``(x, y)`` (m), for per-step use. Where the grid
        has no blocked cell its free space is a rectangle that sees the goal from everywhere,
        and the distance of a point inside it is the straight line, computed without arrays."""
        box = self._open_box
        if box is not None and box[0] <= x <= box[1] and box[2] <= y <= box[3]:
            return math.hypot(x - self.goal[0], y - self.goal[1])
        return float(self.distance(np.array([[x, y]]))[0])

    def path(self, start: ArrayLike) -> NDArray[np.float64]:
        """``(m, 2)`` the shortest path (m) from ``start`` ``(2,)`` to the goal: a polyline from
        ``start`` (then the nearest free cell centre, if ``start`` is not free) over the corners
        it bends at to the goal.

        Raises:
            ValueError: the goal cannot be reached from ``start``.
        """
        u = self.grid._units(_point(start, "start")[None])
        moved, extra = self.grid._snap(u)
        dist, first = self._solve(moved)
        if not np.isfinite(dist[0]):
            raise ValueError(
                f"the goal {tuple(self.goal.tolist())} cannot be reached from {tuple(start)}"
            )
        nodes = [u[0], moved[0]] if extra[0] > 0 else [u[0]]
        a = int(first[0])
        if a >= 0:
            chain = [int(self._exit[a])]
            while chain[-1] != a:
                chain.append(int(self._graph.predecessor[a, chain[-1]]))
            nodes.extend(self._graph.corners[chain[::-1]])
        nodes.append(self._g)
        return self.grid._metres(np.array(nodes))

    def _solve(self, u: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.intp]]:
        """Distances (cells) from free points ``u`` (cell units) and the first corner of each
        path (-1 for the straight line, or none)."""
        # Candidates: the goal (column 0, value |p - g|, never above any other) and the corners
        # (|p - a| + D(a)), checked best first, a few at a time: the first visible one wins.
        d = u[:, None, :] - self._ends
        value = np.hypot(d[..., 0], d[..., 1])
        value[:, 1:] += self._to_goal
        value[:, 1:][~_tangent(self._graph.blocked, d[:, 1:])] = np.inf
        order = np.argsort(value, axis=1)
        dist = np.full(len(u), np.inf)
        first = np.full(len(u), -1, dtype=np.intp)
        todo, s, m = np.arange(len(u)), 0, 4
        while todo.size and s < value.shape[1]:
            cand = order[todo, s : s + m]
            vals = np.take_along_axis(value[todo], cand, axis=1)
            rows, cols = np.nonzero(vals < np.inf)
            seen = np.zeros(vals.shape, dtype=bool)
            seen[rows, cols] = self.grid._visible_units(u[todo[rows]], self._ends[cand[rows, cols]])
            hit, col = seen.any(axis=1), seen.argmax(axis=1)
            dist[todo[hit]] = vals[hit, col[hit]]
            first[todo[hit]] = cand[hit, col[hit]] - 1
            todo = todo[~hit & (vals[:, -1] < np.inf)]  # past an inf, all are inf
            s, m = s + m, 4 * m
        return dist, first
