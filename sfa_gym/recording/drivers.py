"""Scripted drivers: the trajectories along which training and test runs are recorded.

(Longer than 500 lines on purpose: the drivers share one base class and are read side by side
when choosing a training or test trajectory; their steering is :mod:`sfa_gym.sim.steering`.)

A driver steers the rover in closed loop. :meth:`Driver.reset` gives it the drivable area
``bounds = (xmin, xmax, ymin, ymax)`` (metres, e.g. ``env.get_wrapper_attr("arena_bounds")``),
the control period ``dt`` (seconds, ``env.get_wrapper_attr("dt")``) and a seed; then, once
per env step, ``driver(info)`` reads the latest ground-truth pose ``info["x"], info["y"],
info["yaw"]`` and returns the next action ``(v, w)`` (float32 m/s and rad/s), until
``driver.done``. ``driver.start_pose`` is the pose to ``reset`` the env to (or ``None`` for the
env's default start).

- :class:`LawnMowerDriver`: the paper's grid-like joystick trajectory (<= 0.4 m/s): a sweep of
  the arena in rows (and/or columns), with turns on the spot at the row ends, optionally rotating
  in place there and avoiding an ``exclude`` rectangle (a region never seen in training).
- :class:`LoopDriver`: concentric rectangular loops close to the walls; a test trajectory that
  differs from the sweeps and passes through every corner, an excluded one included.
- :class:`WaypointDriver`: follows any list of waypoints (the base of the two above).
- :class:`RandomWalkDriver`: straight runs and turns on the spot of random (geometric) durations,
  with a tunable share of turning; turns back towards the centre near the walls.
- :class:`GridPositions`: not a driver but a list of poses ``(x, y, yaw)`` on an ``n x n`` grid
  with random yaw, to be visited with ``env.reset(options={"pose": pose})`` (the paper's
  simulator protocol).
"""

from __future__ import annotations

import dataclasses
import heapq
import inspect
import math
from collections.abc import Mapping, Sequence
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

from sfa_gym._checks import check_finite, check_positive, check_positive_int, is_number
from sfa_gym._types import Pose
from sfa_gym.geometry import Rectangle, check_rectangle, grow_rectangle, wrap_angle
from sfa_gym.recording.ordering import grid_order
from sfa_gym.sim.steering import DEFAULT_STEERING, Goto, Spin, Steering, WaypointFollower, action

__all__ = [
    "Bounds",
    "env_attribute",
    "Driver",
    "Goto",
    "Spin",
    "Steering",
    "WaypointDriver",
    "LawnMowerDriver",
    "LoopDriver",
    "RandomWalkDriver",
    "GridPositions",
]

Bounds = Rectangle
"""Drivable area ``(xmin, xmax, ymin, ymax)`` in metres."""


def env_attribute(env: Any, name: str) -> Any:
    """The public attribute ``name`` of ``env`` or of the env inside its wrappers; ``None``
    if there is none (or ``env`` is not a Gymnasium env)."""
    get = getattr(env, "get_wrapper_attr", None)
    if get is None:
        return None
    try:
        return get(name)
    except AttributeError:
        return None


def _pose(info: Mapping[str, Any]) -> tuple[float, float, float]:
    try:
        return float(info["x"]), float(info["y"]), float(info["yaw"])
    except KeyError as error:
        raise KeyError(
            f"a driver needs info with keys 'x', 'y', 'yaw'; {error} is missing"
        ) from None


_action = action


class Driver:
    """Base class of the scripted drivers (see the module docstring for the protocol).

    Subclasses store their constructor arguments as attributes of the same name (so that
    :meth:`describe` can report them), and implement :meth:`_start` and :meth:`_act`.
    """

    start_pose: Pose | None = None
    """Pose to reset the env to before driving, or ``None`` for the env's default start."""

    def reset(
        self,
        bounds: Sequence[float],
        *,
        dt: float = 0.1,
        seed: int | np.random.Generator | None = None,
    ) -> None:
        """Plan a new drive in ``bounds`` (metres) with control period ``dt`` (seconds)."""
        self.bounds_ = check_rectangle("bounds", bounds)
        self.dt_ = check_positive("dt", dt)
        self.rng_ = np.random.default_rng(seed)
        self._start()

    def __call__(self, info: Mapping[str, Any]) -> NDArray[np.float32]:
        """Next action ``(v, w)``, ``(2,)`` float32 in m/s and rad/s, given the latest ``info``."""
        if not hasattr(self, "bounds_"):
            raise RuntimeError(f"{type(self).__name__} must be reset(bounds, ...) before driving")
        if self.done:
            return _action(0.0, 0.0)
        return self._act(*_pose(info))

    @property
    def done(self) -> bool:
        """Whether the planned drive is finished (never, for open-ended drivers)."""
        return False

    def get_params(self) -> dict[str, Any]:
        """Constructor arguments, by name."""
        names = [
            p.name
            for p in inspect.signature(type(self).__init__).parameters.values()
            if p.name != "self" and p.kind is not p.VAR_KEYWORD
        ]
        return {name: getattr(self, name) for name in names}

    def describe(self) -> dict[str, Any]:
        """``{"type": class name, **constructor arguments}`` in JSON types (settings such as
        :class:`~sfa_gym.sim.steering.Steering` as dicts), stored in a run's header."""
        params = {
            k: dataclasses.asdict(v) if dataclasses.is_dataclass(v) else v
            for k, v in self.get_params().items()
        }
        return {"type": type(self).__name__, **params}

    def _start(self) -> None:
        raise NotImplementedError

    def _act(self, x: float, y: float, yaw: float) -> NDArray[np.float32]:
        raise NotImplementedError


# --------------------------------------------------------------------------- waypoints


class WaypointDriver(Driver):
    """Follow a list of :class:`~sfa_gym.sim.steering.Goto` and
    :class:`~sfa_gym.sim.steering.Spin` segments in closed loop, with the waypoint controller of
    :class:`~sfa_gym.sim.steering.WaypointFollower` (segments the rover is stuck on are given
    up and counted in ``skipped_``, so that every drive ends).

    Args:
        waypoints: segments, in order; a bare ``(x, y)`` pair means ``Goto(x, y)``. The start
            pose is the first point, facing the second.
        steering: the controller's limits and tolerances.
    """

    def __init__(
        self,
        waypoints: Sequence[Goto | Spin | tuple[float, float]] = (),
        *,
        steering: Steering = DEFAULT_STEERING,
    ) -> None:
        self.waypoints = waypoints
        self.steering = steering

    def _plan(self) -> list[Goto | Spin]:
        return [w if isinstance(w, Goto | Spin) else Goto(*map(float, w)) for w in self.waypoints]

    def _start(self) -> None:
        if not isinstance(self.steering, Steering):
            raise TypeError(f"steering must be a Steering, got {self.steering!r}")
        self.steering.validate()
        self.plan_ = self._plan()
        if not self.plan_:
            raise ValueError(f"{type(self).__name__} has no waypoints to follow in {self.bounds_}")
        self._follower = WaypointFollower(self.plan_, self.steering, self.dt_)
        gotos = [s for s in self.plan_ if isinstance(s, Goto)]
        self.start_pose = None
        if gotos:
            first = gotos[0]
            yaw = 0.0
            if len(gotos) > 1:
                yaw = math.atan2(gotos[1].y - first.y, gotos[1].x - first.x)
            self.start_pose = (first.x, first.y, yaw)

    @property
    def done(self) -> bool:
        return hasattr(self, "_follower") and self._follower.done

    @property
    def skipped_(self) -> int:
        """Segments given up because the rover got stuck on them."""
        return self._follower.skipped

    def path(self) -> NDArray[np.float64]:
        """The planned points, ``(M, 2)`` metres (spins omitted); available after ``reset``."""
        return np.array([(s.x, s.y) for s in self.plan_ if isinstance(s, Goto)], dtype=np.float64)

    def _act(self, x: float, y: float, yaw: float) -> NDArray[np.float32]:
        return self._follower.act(x, y, yaw)


# ---------------------------------------------------------------- obstacle-free routing


def _crosses(p: tuple[float, float], q: tuple[float, float], rect: Bounds) -> bool:
    """Whether the segment ``p -> q`` passes through the open rectangle ``rect``."""
    x0, x1, y0, y1 = rect
    t0, t1 = 0.0, 1.0
    dx, dy = q[0] - p[0], q[1] - p[1]
    for delta, low, high, start in ((dx, x0, x1, p[0]), (dy, y0, y1, p[1])):
        if abs(delta) < 1e-12:
            if not low < start < high:
                return False
            continue
        ta, tb = (low - start) / delta, (high - start) / delta
        t0, t1 = max(t0, min(ta, tb)), min(t1, max(ta, tb))
    return t1 - t0 > 1e-9


def _route(
    p: tuple[float, float], q: tuple[float, float], rect: Bounds, area: Bounds
) -> list[tuple[float, float]]:
    """Shortest path ``p -> q`` around ``rect`` through its corners that lie in ``area``.

    Returns the intermediate points (empty if the straight segment is clear).
    """
    if not _crosses(p, q, rect):
        return []
    # corners pushed out a little so that corner-to-corner edges run outside the open rectangle
    eps = 1e-6
    x0, x1, y0, y1 = rect[0] - eps, rect[1] + eps, rect[2] - eps, rect[3] + eps
    corners = [
        c
        for c in ((x0, y0), (x1, y0), (x1, y1), (x0, y1))
        if area[0] <= c[0] <= area[1] and area[2] <= c[1] <= area[3]
    ]
    nodes = [p, q, *corners]
    # Dijkstra by hand on these <= 6 nodes rather than scipy.sparse.csgraph (as the occupancy
    # grid does): when both ways round the rectangle are equally long (it is centred on the
    # segment), the route taken is part of the recorded run, and csgraph.dijkstra takes the other
    # side (51 of 1600 lawn-mower plans with random rectangles differ; the shipped tracks' do
    # not). Here the first route found wins unless another is shorter by more than 1e-12.
    best = {0: 0.0}
    previous: dict[int, int] = {}
    queue = [(0.0, 0)]
    while queue:
        cost, i = heapq.heappop(queue)
        if i == 1:
            break
        if cost > best.get(i, math.inf):
            continue
        for j, node in enumerate(nodes):
            if j == i or _crosses(nodes[i], node, rect):
                continue
            new = cost + math.dist(nodes[i], node)
            if new < best.get(j, math.inf) - 1e-12:
                best[j], previous[j] = new, i
                heapq.heappush(queue, (new, j))
    if 1 not in previous:
        raise ValueError(
            f"no path from {p} to {q} around the excluded rectangle {rect} inside {area}"
        )
    path, i = [], previous[1]
    while i != 0:
        path.append(nodes[i])
        i = previous[i]
    return path[::-1]


class LawnMowerDriver(WaypointDriver):
    """A lawn-mower sweep of the arena: the paper's grid-like trajectory at <= 0.4 m/s.

    The rover drives parallel rows ``spacing`` metres apart, alternating direction, turning on
    the spot at each row end (and, with ``spin != 0``, also rotating in place there by ``spin``
    radians, which raises the share of rotation in the movement statistics). With
    ``pattern="grid"`` the row sweep along x is followed by a column sweep along y, so that
    translations along both axes are equally frequent (as in the paper's outdoor runs).

    Args:
        spacing: distance between neighbouring rows (m).
        margin: distance kept from the bounds (m); rows start at ``margin + offset``.
        offset: shift of the rows (m), e.g. ``spacing / 2`` for a test sweep between the
            training rows.
        pattern: ``"rows"`` (along x), ``"columns"`` (along y) or ``"grid"`` (rows then columns).
        spin: extra rotation on the spot at each row end (rad, signed; 0 for none).
        exclude: rectangle ``(xmin, xmax, ymin, ymax)`` (m) the rover never enters (widened by
            ``clearance``): rows are cut there and the path goes around it.
        clearance: extra distance kept from ``exclude`` (m).
        steering: the waypoint controller's limits and tolerances.
    """

    def __init__(
        self,
        spacing: float = 0.5,
        *,
        margin: float = 0.5,
        offset: float = 0.0,
        pattern: Literal["rows", "columns", "grid"] = "grid",
        spin: float = 0.0,
        exclude: tuple[float, float, float, float] | None = None,
        clearance: float = 0.3,
        steering: Steering = DEFAULT_STEERING,
    ) -> None:
        self.steering = steering
        self.spacing = spacing
        self.margin = margin
        self.offset = offset
        self.pattern = pattern
        self.spin = spin
        self.exclude = exclude
        self.clearance = clearance

    def _plan(self) -> list[Goto | Spin]:
        spacing = check_positive("spacing", self.spacing)
        if self.pattern not in ("rows", "columns", "grid"):
            raise ValueError(f"pattern must be 'rows', 'columns' or 'grid', got {self.pattern!r}")
        check_finite("margin", self.margin, low=0.0)
        check_finite("clearance", self.clearance, low=0.0)
        check_finite("offset", self.offset)
        check_finite("spin", self.spin)
        xmin, xmax, ymin, ymax = self.bounds_
        area = (xmin + self.margin, xmax - self.margin, ymin + self.margin, ymax - self.margin)
        if area[0] >= area[1] or area[2] >= area[3]:
            raise ValueError(f"margin {self.margin} leaves no room inside bounds {self.bounds_}")
        rect = None
        if self.exclude is not None:
            rect = grow_rectangle(check_rectangle("exclude", self.exclude), self.clearance)
        lines: list[list[tuple[float, float]]] = []
        if self.pattern in ("rows", "grid"):
            lines += self._sweep(area, rect, spacing, along_x=True)
        if self.pattern in ("columns", "grid"):
            columns = self._sweep(area, rect, spacing, along_x=False)
            if lines and columns:
                # start the column sweep at the corner nearest to where the rows ended
                variants = [
                    columns,
                    columns[::-1],
                    [line[::-1] for line in columns],
                    [line[::-1] for line in columns[::-1]],
                ]
                columns = min(variants, key=lambda c: math.dist(lines[-1][-1], c[0][0]))
            lines += columns
        if not lines:
            raise ValueError(f"no row fits into {area} with offset {self.offset}")
        return self._connect(lines, rect, area)

    def _sweep(
        self, area: Bounds, rect: Bounds | None, spacing: float, along_x: bool
    ) -> list[list[tuple[float, float]]]:
        lo, hi, across_lo, across_hi = area if along_x else (area[2], area[3], area[0], area[1])
        levels = np.arange(across_lo + self.offset % spacing, across_hi + 1e-9, spacing)
        lines = []
        for j, level in enumerate(levels):
            pieces = [(lo, hi)]
            if rect is not None:
                r_lo, r_hi, c_lo, c_hi = rect if along_x else (rect[2], rect[3], rect[0], rect[1])
                if c_lo < level < c_hi:
                    pieces = [
                        (a, b) for a, b in ((lo, min(hi, r_lo)), (max(lo, r_hi), hi)) if b > a
                    ]
            points = [p for a, b in pieces for p in (a, b)]
            if j % 2 == 1:
                points = points[::-1]
            if points:
                lines.append([(p, float(level)) if along_x else (float(level), p) for p in points])
        return lines

    def _connect(
        self, lines: list[list[tuple[float, float]]], rect: Bounds | None, area: Bounds
    ) -> list[Goto | Spin]:
        points: list[tuple[float, float]] = []
        plan: list[Goto | Spin] = []
        for line in lines:
            for point in line:
                if points and math.dist(points[-1], point) < 1e-9:
                    continue
                if points and rect is not None:
                    for detour in _route(points[-1], point, rect, area):
                        plan.append(Goto(*detour))
                points.append(point)
                plan.append(Goto(*point))
            if self.spin:
                plan.append(Spin(float(self.spin)))
        return plan


class LoopDriver(WaypointDriver):
    """Rectangular loops around the arena, ``insets`` metres from the bounds.

    A test trajectory unlike the lawn-mower sweeps: each loop runs parallel to the walls and
    passes every corner region (including one excluded from a training sweep); consecutive
    loops are joined at the south-west corner.

    Args:
        insets: distance of each loop from the bounds (m), driven in this order.
        clockwise: direction of the loops.
        laps: number of times the whole set of loops is driven.
        steering: the waypoint controller's limits and tolerances.
    """

    def __init__(
        self,
        insets: Sequence[float] = (0.5, 1.0, 1.5),
        *,
        clockwise: bool = False,
        laps: int = 1,
        steering: Steering = DEFAULT_STEERING,
    ) -> None:
        self.steering = steering
        self.insets = insets
        self.clockwise = clockwise
        self.laps = laps

    def _plan(self) -> list[Goto | Spin]:
        if not isinstance(self.laps, int) or self.laps < 1:
            raise ValueError(f"laps must be a positive int, got {self.laps!r}")
        xmin, xmax, ymin, ymax = self.bounds_
        plan: list[Goto | Spin] = []
        for _ in range(self.laps):
            for inset in self.insets:
                inset = check_finite("inset", inset, low=0.0)
                x0, x1, y0, y1 = xmin + inset, xmax - inset, ymin + inset, ymax - inset
                if x0 >= x1 or y0 >= y1:
                    raise ValueError(
                        f"inset {inset!r} must be >= 0 and leave room inside bounds {self.bounds_}"
                    )
                corners = [(x0, y0), (x1, y0), (x1, y1), (x0, y1)]
                if self.clockwise:
                    corners = [corners[0], *corners[:0:-1]]
                plan += [Goto(float(x), float(y)) for x, y in (*corners, corners[0])]
        return plan


# ---------------------------------------------------------------------- random walk


class RandomWalkDriver(Driver):
    """Random alternation of straight runs and turns on the spot.

    At the end of each segment a new one starts: with probability ``turn_probability`` a turn
    on the spot at ``+-turn_rate`` (random sign) lasting on average ``turn_duration`` seconds,
    otherwise a straight run at ``speed`` lasting on average ``straight_duration`` seconds
    (durations geometric in steps of ``dt``). The long-run share of time spent turning is
    therefore :attr:`turn_fraction`; more turning makes slow features more orientation-invariant.
    Within ``margin`` metres of a wall and heading out, the rover instead turns on the spot
    towards the arena centre (within +-45 degrees, random) and then runs straight.

    Args:
        speed: straight-run speed (m/s).
        turn_rate: turn rate (rad/s).
        turn_probability: probability that a new segment is a turn.
        turn_duration: mean duration of a turn (s).
        straight_duration: mean duration of a straight run (s).
        margin: distance from the bounds at which the rover turns back (m); larger than the
            stopping distance.
    """

    def __init__(
        self,
        *,
        speed: float = 0.3,
        turn_rate: float = 1.0,
        turn_probability: float = 0.5,
        turn_duration: float = 1.5,
        straight_duration: float = 3.0,
        margin: float = 0.5,
    ) -> None:
        self.speed = speed
        self.turn_rate = turn_rate
        self.turn_probability = turn_probability
        self.turn_duration = turn_duration
        self.straight_duration = straight_duration
        self.margin = margin

    @property
    def turn_fraction(self) -> float:
        """Expected long-run share of the time spent turning voluntarily (walls not counted)."""
        p = self.turn_probability
        turning = p * self.turn_duration
        return turning / (turning + (1.0 - p) * self.straight_duration)

    def _start(self) -> None:
        for name in ("speed", "turn_rate", "turn_duration", "straight_duration"):
            check_positive(name, getattr(self, name))
        if not (is_number(self.turn_probability) and 0.0 <= self.turn_probability <= 1.0):
            raise ValueError(f"turn_probability must lie in [0, 1], got {self.turn_probability!r}")
        for name in ("turn_duration", "straight_duration"):
            if getattr(self, name) < self.dt_:
                raise ValueError(f"{name} must be >= dt = {self.dt_} s, got {getattr(self, name)}")
        xmin, xmax, ymin, ymax = self.bounds_
        if not (
            is_number(self.margin) and 0.0 <= self.margin < 0.5 * min(xmax - xmin, ymax - ymin)
        ):
            raise ValueError(f"margin {self.margin!r} leaves no room inside bounds {self.bounds_}")
        self.mode_: Literal["turn", "straight", "avoid"] = "straight"
        self._steps_left = 0
        self._turn_sign = 1.0
        self._target_yaw = 0.0

    def _new_segment(self) -> None:
        turn = self.rng_.random() < self.turn_probability
        mean = self.turn_duration if turn else self.straight_duration
        self.mode_ = "turn" if turn else "straight"
        self._steps_left = int(self.rng_.geometric(min(1.0, self.dt_ / mean)))
        self._turn_sign = 1.0 if self.rng_.random() < 0.5 else -1.0

    def _heading_out(self, x: float, y: float, yaw: float) -> bool:
        xmin, xmax, ymin, ymax = self.bounds_
        hx, hy = math.cos(yaw), math.sin(yaw)
        m = self.margin
        return (
            (x < xmin + m and hx < 0)
            or (x > xmax - m and hx > 0)
            or (y < ymin + m and hy < 0)
            or (y > ymax - m and hy > 0)
        )

    def _act(self, x: float, y: float, yaw: float) -> NDArray[np.float32]:
        if self.mode_ != "avoid" and self._heading_out(x, y, yaw):
            xmin, xmax, ymin, ymax = self.bounds_
            centre = math.atan2(0.5 * (ymin + ymax) - y, 0.5 * (xmin + xmax) - x)
            self._target_yaw = centre
            # a random heading around the centre's direction, unless it leads out again
            for _ in range(10):
                target = centre + self.rng_.uniform(-math.pi / 4, math.pi / 4)
                if not self._heading_out(x, y, target):
                    self._target_yaw = target
                    break
            self.mode_ = "avoid"
        if self.mode_ == "avoid":
            error = wrap_angle(self._target_yaw - yaw)
            if abs(error) > 0.15:
                rate = max(0.3 * self.turn_rate, min(self.turn_rate, 2.0 * abs(error)))
                return _action(0.0, math.copysign(rate, error))
            self.mode_ = "straight"
            self._steps_left = int(self.rng_.geometric(min(1.0, self.dt_ / self.straight_duration)))
        if self._steps_left <= 0:
            self._new_segment()
        self._steps_left -= 1
        if self.mode_ == "turn":
            return _action(0.0, self._turn_sign * self.turn_rate)
        return _action(self.speed, 0.0)


# ------------------------------------------------------------------- grid positions


class GridPositions:
    """The discrete ``n x n`` grid of positions, each with a random yaw.

    Not a driver: the rover is placed at each pose with ``env.reset(options={"pose": pose})``
    (the paper's simulator protocol). The yaw of a grid cell depends only on ``seed`` and the
    cell, not on the visiting ``order``.

    Args:
        n: positions per side.
        seed: seed of the yaws, uniform in ``[-pi, pi)``.
        order: visiting order: ``"raster"`` (row by row), ``"serpentine"`` (row by row,
            alternating) or ``"hilbert"`` (both axes change equally slowly).

    Example:
        >>> GridPositions(n=2, seed=0).poses((0.0, 2.0, 0.0, 4.0))[:, :2].tolist()
        [[0.5, 1.0], [1.5, 1.0], [0.5, 3.0], [1.5, 3.0]]
    """

    def __init__(
        self,
        n: int = 30,
        *,
        seed: int = 0,
        order: Literal["raster", "serpentine", "hilbert"] = "raster",
    ) -> None:
        self.n = n
        self.seed = seed
        self.order = order

    def describe(self) -> dict[str, Any]:
        """JSON-friendly description, ``{"type": "GridPositions", n, seed, order}``."""
        return {"type": type(self).__name__, "n": self.n, "seed": self.seed, "order": self.order}

    def poses(self, source: Any) -> NDArray[np.float64]:
        """The poses ``(n*n, 3)`` as ``(x, y, yaw)`` (metres, radians), in visiting order.

        Args:
            source: an env whose ``grid_positions(n)`` gives the positions (through its
                wrappers, see :func:`env_attribute`), or bounds
                ``(xmin, xmax, ymin, ymax)``: then the positions are the centres of the ``n x n``
                cells dividing them. An env without ``grid_positions`` gives its
                ``arena_bounds``.
        """
        check_positive_int("n", self.n)
        if self.order not in ("raster", "serpentine", "hilbert"):
            raise ValueError(
                f"order must be 'raster', 'serpentine' or 'hilbert', got {self.order!r}"
            )
        grid_positions = env_attribute(source, "grid_positions")
        if grid_positions is not None:
            xy = np.asarray(grid_positions(self.n), dtype=np.float64)
            if xy.shape != (self.n * self.n, 2):
                raise ValueError(
                    f"{source}.grid_positions({self.n}) returned shape "
                    f"{xy.shape}, expected ({self.n * self.n}, 2)"
                )
        else:
            arena = env_attribute(source, "arena_bounds")
            xmin, xmax, ymin, ymax = check_rectangle("bounds", source if arena is None else arena)
            fraction = (np.arange(self.n) + 0.5) / self.n
            gx, gy = np.meshgrid(xmin + fraction * (xmax - xmin), ymin + fraction * (ymax - ymin))
            xy = np.stack([gx.ravel(), gy.ravel()], axis=1)
        # integer cell (row = y rank, column = x rank) of every position, for the ordering
        cells = np.stack(
            [
                np.unique(xy[:, 1], return_inverse=True)[1],
                np.unique(xy[:, 0], return_inverse=True)[1],
            ],
            axis=1,
        ).astype(np.int64)
        # yaws are drawn per cell in raster order, so they do not depend on the visiting order
        yaw_of_cell = np.random.default_rng(self.seed).uniform(-np.pi, np.pi, size=self.n * self.n)
        raster = cells[:, 0] * self.n + cells[:, 1]
        if raster.max(initial=0) >= self.n * self.n or len(np.unique(raster)) != len(raster):
            raise ValueError(f"the {len(xy)} positions do not form a {self.n} x {self.n} grid")
        if self.order == "raster":
            visit = np.argsort(raster, kind="stable")
        else:
            visit = grid_order(cells, kind=self.order)
        return np.column_stack([xy[visit], yaw_of_cell[raster[visit]]])
