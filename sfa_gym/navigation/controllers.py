"""Controllers for image-goal navigation: the slow-feature-gradient controller, an oracle on
ground truth (upper bound) and a random policy (floor).

A controller sees what :class:`~sfa_gym.navigation.env.OmniRoverNavEnv` gives (its observation
``{"features", "goal_features"}`` and ``info``) and returns an action ``(v, w, stop)``:

    controller.reset(obs, info)
    action = controller.act(obs, info)

The gradient controller uses only the rover's own senses: the features, the wheel odometry
(``info["odometry"]``) and the range sensor (``info["range"]``). The oracle reads the ground truth
pose and the occupancy grid, and is labelled as such everywhere.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sfa_gym._checks import check_finite, check_int, check_positive, check_positive_int
from sfa_gym.geometry import wrap_angle
from sfa_gym.navigation import portable
from sfa_gym.navigation.feature_gradient import LocalLinearFit, gauss_newton_step, slowness_weights
from sfa_gym.sim.steering import Goto, Steering, WaypointFollower

__all__ = [
    "Controller",
    "GradientController",
    "GradientSettings",
    "LocalLinearFit",
    "OracleController",
    "RandomController",
    "gauss_newton_step",
    "slowness_weights",
]


PROBE_TIME = 8.0
"""seconds after which a probe of two legs that has not yet spanned the plane (a wall in the
way) gives way to a curve; the two legs take about 4.5 s"""


class Controller(Protocol):
    """Navigation controller: ``reset`` at the start of an episode, then ``act`` every step."""

    name: str

    def reset(self, obs: Mapping[str, Any], info: Mapping[str, Any]) -> None: ...

    def act(self, obs: Mapping[str, Any], info: Mapping[str, Any]) -> NDArray[np.float32]: ...


@dataclass(frozen=True)
class GradientSettings:
    """Settings of :class:`GradientController` (SI units)."""

    memory: float = 0.3
    """metres of travel over which old samples fade out of the local fit (exponential weight):
    the features curve, and a tangent plane fitted over more path is biased (0.5 m: 3-6
    points less success and 0.01-0.05 less SPL on four 200-episode sets)"""
    window: float = 1.0
    """metres of travel after which samples are dropped"""
    prior: float = 0.02
    """strength (m^2) of the prior that the Jacobian is still the last one: directions the recent
    moves did not explore keep their old estimate instead of becoming undetermined"""
    damping: float = 0.1
    """Levenberg-Marquardt damping of the Gauss-Newton step, relative to the trace of J^T W J"""
    weave_deg: float = 25.0
    """amplitude of the weave around the descent direction: consecutive moves are not collinear,
    so the recent moves span the plane"""
    weave_wavelength: float = 2.0
    """metres of travel per weave cycle"""
    speed: float = 0.3
    """cruising speed (m/s)"""
    slow_distance: float = 0.6
    """estimated distance to the goal (m) below which the rover slows down"""
    min_speed: float = 0.1
    """slowest driving speed (m/s): the rover must keep moving to keep estimating the gradient"""
    accel: float = 0.5
    """largest change of the forward speed (m/s^2): speed reversals tip the rover and its
    camera, which corrupts the features for several steps"""
    turn_gain: float = 2.0
    """yaw rate per radian of heading error (1/s)"""
    stop_distance: float = 0.1
    """the controller stops when the running mean of the cost falls below the cost of being this
    far (m) from the goal along the direction where the cost rises slowest, plus the noise floor
    of the cost"""
    stop_curvature: str = "flattest"
    """curvature of the cost that sets the stop threshold: "flattest" (the smaller eigenvalue
    of J^T W J: stop only when even the flattest direction says the goal is near) or "mean"
    (half its trace)"""
    leave: float = 0.6
    """metres driven straight away from the walls first, when the range sensor sees one closer
    than ``influence`` during the first metre of an episode: along the walls the cost has a
    strip of false minima that traps a rover starting there (0 switches it off)"""
    probe_leg: float = 0.1
    """metres driven straight before the first fit, after which the rover turns on the spot by
    ``probe_turn`` and drives on until its moves span the plane: an L of two short legs gives
    the first fit its 2 cm of spread across for about 0.2 m of path, where a curve of the same
    spread (``probe_leg=0``) costs about 0.4 m (turning on the spot adds no path)"""
    probe_turn: float = 90.0
    """degrees turned on the spot between the probe's legs, towards the side the range sensor
    sees more room on"""
    stop_window: int = 3
    """steps in the running mean of the cost"""
    give_up: float = 10.0
    """metres travelled without lowering the best cost by ``progress`` before giving up (a
    search that finds a lower cost starts the count afresh)"""
    progress: float = 0.1
    """relative decrease of the best cost that counts as progress"""
    clearance: float = 0.55
    """range (m, from the rover's centre) below which a ray direction counts as blocked"""
    repel: float = 2.0
    """weight of the push away from close range readings, against the unit descent direction"""
    influence: float = 0.9
    """range (m) below which a reading pushes the rover away; the push grows linearly to 1 at 0"""
    search_after: float = 6.0
    """seconds without lowering the best cost by ``progress`` after which a rover that is stuck
    searches around itself: stuck near the goal (the fit's curvature puts it within
    ``slow_distance``) or ``parked``"""
    parked: float = 0.2
    """metres travelled over the last ``search_after`` seconds below which the rover counts as
    stuck wherever it is: far from the goal it stalls mostly by turning on the spot against a
    wall or an obstacle, where the descent points into it and the range sensor's push away
    turns with the rover"""
    search_pitch: float = 0.3
    """metres between the loops of the search spiral"""
    search_start: float = 0.2
    """radius (m) of the search spiral's first loop"""
    search_found: float = 0.8
    """the search ends when the cost falls below this fraction of the best cost before it"""
    searches: int = 3
    """searches per episode at most (0: none)"""

    def validate(self) -> None:
        """Raise ValueError naming the first bad setting."""
        for name in (
            "memory", "window", "weave_wavelength", "speed", "slow_distance", "min_speed",
            "accel", "turn_gain", "stop_distance", "give_up", "clearance", "influence",
            "search_pitch", "search_start", "parked",
        ):  # fmt: skip
            check_positive(name, getattr(self, name))
        for name in (
            "prior", "damping", "weave_deg", "leave", "probe_leg", "probe_turn", "progress",
            "repel", "search_after",
        ):  # fmt: skip
            check_finite(name, getattr(self, name), low=0.0)
        if not 0 < self.search_found < 1:
            raise ValueError(f"search_found must be in (0, 1), got {self.search_found!r}")
        check_positive_int("stop_window", self.stop_window)
        if check_int("searches", self.searches) < 0:
            raise ValueError(f"searches must be >= 0, got {self.searches!r}")
        if self.stop_curvature not in ("flattest", "mean"):
            raise ValueError(
                f"stop_curvature must be 'flattest' or 'mean', got {self.stop_curvature!r}"
            )


class GradientController:
    """Follow the gradient of the slow-feature distance to the goal (Metka et al., IROS 2017;
    patent EP3367061), estimated online from the rover's own moves.

    The cost is ``c = sum_i w_i (f_i - g_i)^2`` between the current features ``f`` and the goal's
    ``g`` (``w`` from :func:`slowness_weights`). The controller keeps the features and odometry
    positions of its recent moves (one sample per centimetre of travel, over ``window`` metres)
    and fits the local linear model ``f(p) = a + J (p - p_now)`` by weighted least squares: a
    sample fades with the distance travelled since it (``memory``), and a prior keeps the
    Jacobian's unexplored directions at their last estimate (``prior``), since the rover mostly
    moves along one direction. The damped Gauss-Newton step
    ``d = -(J^T W J + mu I)^-1 J^T W (a - g)`` gives the descent direction; the rover drives
    along it, weaving around it (``weave_deg``) so that consecutive moves are not collinear, and
    pushed away from walls and obstacles its range sensor sees within ``influence``; a blocked
    direction is replaced by the nearest free one. Its speed follows the distance to the goal
    estimated from the cost and the fit's curvature. Before the first fit it probes with two
    short straight legs and a turn on the spot between them (``probe_leg``): its moves span the
    plane after about 0.26 m of path, a curve's after about 0.4 m. Starting next to a wall (within
    ``influence`` in the first metre), it first drives ``leave`` metres away from it: the cost
    has false minima along the walls. It stops when the running mean of the cost
    falls below the cost of being ``stop_distance`` from the goal in the direction where the cost
    rises slowest (the smaller eigenvalue of ``J^T W J``) plus the fit's noise floor,
    and gives up (stops) after ``give_up`` metres without progress. Stuck (``search_after``
    seconds without progress, and either the fit's curvature puts the goal within
    ``slow_distance`` or the rover has moved less than ``parked`` metres in that time: a false
    minimum of the cost, or a stall against a wall or an obstacle), it drives an outward spiral
    until the cost falls to ``search_found`` of its best, and follows the gradient again from
    there (at most ``searches`` times an episode).

    Args:
        weights: ``(k,)`` feature weights (:func:`slowness_weights`).
        range_angles: directions of the range sensor's rays relative to the heading (rad);
            empty for none.
        v_max: largest forward speed (m/s); w_max: largest yaw rate (rad/s); dt: step (s).
        settings: :class:`GradientSettings`.
        seed: seed of the weave's phase.
    """

    name = "gradient"

    def __init__(
        self,
        weights: ArrayLike,
        range_angles: ArrayLike = (),
        v_max: float = 0.4,
        w_max: float = 1.0,
        dt: float = 0.1,
        settings: GradientSettings | None = None,
        seed: int = 0,
    ) -> None:
        self.weights = np.asarray(weights, dtype=np.float64)
        if self.weights.ndim != 1 or np.any(~(self.weights >= 0)):
            raise ValueError(f"weights must be (k,) non-negative numbers, got {weights!r}")
        self.range_angles = np.asarray(range_angles, dtype=np.float64)
        self.v_max, self.w_max, self.dt = float(v_max), float(w_max), float(dt)
        self.settings = GradientSettings() if settings is None else settings
        self.settings.validate()
        self.rng = np.random.default_rng(seed)

    @classmethod
    def for_env(cls, env: Any, weights: ArrayLike, **kwargs: Any) -> GradientController:
        """A controller with the speed limits, step and range sensor of a navigation env."""
        u = env.unwrapped
        return cls(weights, u.range_angles, u.v_max, u.w_max, u.dt, **kwargs)

    # -- episode --------------------------------------------------------------------------------

    def reset(self, obs: Mapping[str, Any], info: Mapping[str, Any]) -> None:
        s = self.settings
        self._local = LocalLinearFit(self.weights, s.memory, s.window, s.prior)
        self._costs: deque[float] = deque(maxlen=self.settings.stop_window)
        self._best = math.inf
        self._best_at = 0.0
        self._v = 0.0
        self._leave: tuple[float, float] | None = None  # (direction, odometer at the start)
        self._t = self._best_t = 0.0  # seconds since the start, and since the best cost
        # (odometer at its start, best cost before it, turning direction) of a search, if on
        self._search: tuple[float, float, float] | None = None
        self._searches = 0
        # the odometer over the last search_after seconds, to tell a parked rover
        self._odometer: deque[float] = deque(maxlen=round(s.search_after / self.dt) + 1)
        self._phase = float(self.rng.uniform(0, math.tau))
        self._probe_yaw: float | None = None  # heading (odometry) of the probe's current leg
        self._probe_turned = False
        self._probe_t = 0.0  # seconds since the start when the probe began
        # what the last step computed, for diagnostics: cost, distance (m), stop_cost and, while
        # descending, the Gauss-Newton step's and the descent's directions and the weave (rad,
        # odometry frame)
        self.estimate: dict[str, float] = {}
        # what the last step did: "leave" (the wall), "probe" (no fit yet), "descend", "search"
        # or "stop"
        self.mode = "start"

    def act(self, obs: Mapping[str, Any], info: Mapping[str, Any]) -> NDArray[np.float32]:
        s = self.settings
        f = np.asarray(obs["features"], dtype=np.float64)
        g = np.asarray(obs["goal_features"], dtype=np.float64)
        x, y, yaw = (float(v) for v in info["odometry"])
        position = np.array([x, y])
        self._local.remember(position, f)
        travelled = self._local.travelled
        self._odometer.append(travelled)

        cost = float(np.sum(self.weights * (f - g) ** 2))
        self._costs.append(cost)
        self._t += self.dt
        if cost < self._best * (1 - s.progress):
            self._best, self._best_at, self._best_t = cost, travelled, self._t
        if travelled - self._best_at > s.give_up:
            return self._stop()
        self.mode = "descend"

        ranges = np.asarray(info.get("range", ()), dtype=np.float64)
        if self._leave is None and s.leave > 0 and travelled < 1.0 and ranges.size:
            if ranges.min() < s.influence:
                push = self._push(ranges, yaw)
                self._leave = (math.atan2(push[1], push[0]), travelled)
        if self._leave is not None and travelled - self._leave[1] < s.leave:
            # a fixed direction, not the range readings of the moment: the sensor sees only
            # ahead, and turning away from a wall would look like having left it
            heading = self._unblocked(ranges, wrap_angle(self._leave[0] - yaw))
            self.mode = "leave"
            return self._drive(s.speed * max(math.cos(heading), 0.0), s.turn_gain * heading)

        fit = self._local.fit()
        if fit is None:
            self.mode = "probe"
            return self._probe(travelled, yaw, ranges)
        a, jac, noise = fit
        metric = portable.gram(jac, jac, self.weights)  # (2, 2) J^T W J
        step = gauss_newton_step(a, jac, g, self.weights, s.damping)
        curvature = float(metric[0, 0] + metric[1, 1]) / 2  # cost per m^2 of distance, on average
        distance = math.sqrt(max(cost - noise, 0.0) / curvature) if curvature > 0 else math.inf
        if s.stop_curvature == "flattest":
            # near walls the features flatten across them, and the mean curvature would stop
            # the rover short of a goal there
            stop_cost = s.stop_distance**2 * portable.smallest_eigenvalue(metric) + noise
        else:
            stop_cost = s.stop_distance**2 * curvature + noise
        self.estimate = {"cost": cost, "distance": distance, "stop_cost": stop_cost}
        if len(self._costs) == s.stop_window and np.mean(self._costs) < stop_cost:
            return self._stop()

        # stuck: where the fit's curvature says the goal is near but the cost stays above the
        # stop threshold (a false minimum, not a slow descent far from the goal), or anywhere
        # without moving (turning on the spot against a wall or an obstacle)
        parked = (
            len(self._odometer) == self._odometer.maxlen
            and travelled - self._odometer[0] < s.parked
        )
        stuck = self._t - self._best_t > s.search_after and (distance < s.slow_distance or parked)
        if self._search is None and stuck:
            if self._searches < s.searches:
                self._searches += 1
                turn = 1.0 if self._searches % 2 else -1.0
                self._search = (travelled, self._best, turn)
        if self._search is not None:
            action = self._spiral(cost, travelled, ranges, yaw)
            if action is not None:
                self.mode = "search"
                return action

        weave = math.radians(s.weave_deg) * math.sin(
            self._phase + math.tau * travelled / s.weave_wavelength
        )
        direction = step / (portable.norm2(step) + 1e-12) + s.repel * self._push(ranges, yaw)
        descent = math.atan2(direction[1], direction[0])
        heading = wrap_angle(descent + weave - yaw)
        self.estimate.update(step=math.atan2(step[1], step[0]), descent=descent, weave=weave)
        heading = self._unblocked(ranges, heading)
        scale = min(1.0, distance / s.slow_distance)
        speed = max(s.min_speed, s.speed * scale) * max(math.cos(heading), 0.0)
        return self._drive(speed, s.turn_gain * heading)

    def _spiral(self, cost: float, travelled: float, ranges: NDArray, yaw: float) -> NDArray | None:
        """The next move of the search spiral, or None once it has found a lower cost (or gone
        ``give_up`` metres): the cost has a false minimum here, and a spiral of growing radius
        around it samples the cost on all sides until one is lower. Its moves span the plane,
        so the local fit that takes over afterwards starts from a well-determined Jacobian."""
        s = self.settings
        start, before, turn = self._search
        if cost < s.search_found * before:
            self._search, self._best_t, self._best_at = None, self._t, travelled
            return None
        # radius after d metres of an Archimedean spiral: r^2 = r0^2 + pitch * d / pi
        radius = math.sqrt(s.search_start**2 + s.search_pitch * (travelled - start) / math.pi)
        speed = min(s.speed, 0.9 * self.w_max * radius)
        # the range sensor bends the spiral as it bends the descent: pushed away from close
        # readings, and never into a blocked direction
        direction = np.array([math.cos(yaw), math.sin(yaw)]) + s.repel * self._push(ranges, yaw)
        heading = self._unblocked(ranges, wrap_angle(math.atan2(direction[1], direction[0]) - yaw))
        speed *= max(math.cos(heading), 0.0)
        return self._drive(speed, turn * speed / radius + s.turn_gain * heading)

    def _probe(self, travelled: float, yaw: float, ranges: NDArray) -> NDArray[np.float32]:
        """The next move before the first fit: the moves do not span the plane yet."""
        s = self.settings
        if self._probe_yaw is None:
            self._probe_yaw, self._probe_t = yaw, self._t
        if s.probe_leg <= 0 or self._t - self._probe_t > PROBE_TIME:
            # a curve: it spans the plane after about 0.4 m, wherever the walls are
            return self._drive(s.min_speed * 1.5, self.w_max * 0.6)
        if not self._probe_turned and travelled >= s.probe_leg:
            # turn towards the side with more room; the ray at 0 counts for neither side
            side = float(np.sum(np.sign(self.range_angles) * ranges)) if ranges.size else 0.0
            self._probe_yaw = yaw + math.copysign(math.radians(s.probe_turn), side or 1.0)
            self._probe_turned = True
        # pushed away from walls as the descent is: a leg must not end against one
        direction = np.array([math.cos(self._probe_yaw), math.sin(self._probe_yaw)])
        direction += s.repel * self._push(ranges, yaw)
        heading = wrap_angle(math.atan2(direction[1], direction[0]) - yaw)
        heading = self._unblocked(ranges, heading)
        if abs(heading) > 0.2:
            # on the spot: a turn costs no path, and the legs stay straight
            return self._drive(0.0, s.turn_gain * heading)
        # 1.5 cm a step: the local fit keeps one sample per centimetre of travel
        return self._drive(1.5 * s.min_speed * math.cos(heading), s.turn_gain * heading)

    def _push(self, ranges: NDArray, yaw: float) -> NDArray:
        """Away from the close range readings, in the odometry frame."""
        if ranges.size == 0:
            return np.zeros(2)
        near = np.clip(1.0 - ranges / self.settings.influence, 0.0, None)
        angles = yaw + self.range_angles
        return -np.array([np.sum(near * np.cos(angles)), np.sum(near * np.sin(angles))])

    def _unblocked(self, ranges: NDArray, heading: float) -> float:
        """The free direction (relative to the rover) nearest to ``heading``."""
        if ranges.size == 0:
            return heading
        free = ranges > self.settings.clearance
        if free[np.argmin(np.abs([wrap_angle(a - heading) for a in self.range_angles]))]:
            return heading
        if not free.any():
            # boxed in ahead: turn towards the side with more room
            return math.copysign(math.pi / 2, float(ranges[-1] - ranges[0]) or 1.0)
        options = self.range_angles[free]
        return float(options[np.argmin(np.abs([wrap_angle(a - heading) for a in options]))])

    def _drive(self, v: float, w: float) -> NDArray[np.float32]:
        limit = self.settings.accel * self.dt
        v = min(max(v, self._v - limit, 0.0), self._v + limit, self.v_max)
        self._v = v
        w = min(max(w, -self.w_max), self.w_max)
        return np.array([v, w, -1.0], dtype=np.float32)

    def _stop(self) -> NDArray[np.float32]:
        self.mode = "stop"
        return np.array([0.0, 0.0, 1.0], dtype=np.float32)


class OracleController:
    """Upper bound: drives the geodesic shortest path with the ground-truth pose and stops at the
    goal. It reads ``info["x"]``, ``"y"``, ``"yaw"`` and ``"goal"``, and the occupancy grid: a
    map and ground truth no real rover has. The path's corners are the waypoints of a
    :class:`~sfa_gym.sim.steering.WaypointFollower`, the closed-loop steering the scripted
    recordings use.

    Args:
        occupancy: the env's :class:`~sfa_gym.navigation.occupancy.OccupancyGrid`.
        v_max: speed limit (m/s).
        w_max: yaw rate limit (rad/s).
        dt: control period (s).
        stop_radius: distance to the goal (m) at which it stops.
    """

    name = "oracle"

    def __init__(
        self,
        occupancy: Any,
        v_max: float = 0.4,
        w_max: float = 1.0,
        dt: float = 0.1,
        stop_radius: float = 0.1,
    ) -> None:
        self.occupancy = occupancy
        self.v_max, self.w_max, self.dt = float(v_max), float(w_max), float(dt)
        self.stop_radius = float(stop_radius)

    @classmethod
    def for_env(cls, env: Any, **kwargs: Any) -> OracleController:
        u = env.unwrapped
        return cls(u.occupancy, u.v_max, u.w_max, u.dt, **kwargs)

    def reset(self, obs: Mapping[str, Any], info: Mapping[str, Any]) -> None:
        self._goal = np.asarray(info["goal"], dtype=np.float64)[:2]
        path = self.occupancy.geodesic(self._goal).path(np.array([info["x"], info["y"]]))
        steering = Steering(speed=self.v_max, turn_rate=self.w_max, tolerance=self.stop_radius)
        self._follower = WaypointFollower([Goto(*map(float, p)) for p in path], steering, self.dt)

    def act(self, obs: Mapping[str, Any], info: Mapping[str, Any]) -> NDArray[np.float32]:
        here = np.array([info["x"], info["y"]])
        if self._follower.done or np.linalg.norm(here - self._goal) <= self.stop_radius:
            return np.array([0.0, 0.0, 1.0], dtype=np.float32)
        v, w = self._follower.act(float(info["x"]), float(info["y"]), float(info["yaw"]))
        return np.array([v, w, -1.0], dtype=np.float32)


class RandomController:
    """Floor: uniform random speeds, and a stop with probability ``stop_probability`` per step."""

    name = "random"

    def __init__(
        self, v_max: float = 0.4, w_max: float = 1.0, stop_probability: float = 0.01, seed: int = 0
    ) -> None:
        self.v_max, self.w_max = float(v_max), float(w_max)
        self.stop_probability = float(stop_probability)
        self.rng = np.random.default_rng(seed)

    @classmethod
    def for_env(cls, env: Any, **kwargs: Any) -> RandomController:
        u = env.unwrapped
        return cls(u.v_max, u.w_max, **kwargs)

    def reset(self, obs: Mapping[str, Any], info: Mapping[str, Any]) -> None:
        pass

    def act(self, obs: Mapping[str, Any], info: Mapping[str, Any]) -> NDArray[np.float32]:
        v, w = self.rng.uniform([-self.v_max, -self.w_max], [self.v_max, self.w_max])
        stop = 1.0 if self.rng.random() < self.stop_probability else -1.0
        return np.array([v, w, stop], dtype=np.float32)
