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

from sfa_gym.geometry import wrap_angle
from sfa_gym.recording.drivers import WaypointDriver

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


class Controller(Protocol):
    """Navigation controller: ``reset`` at the start of an episode, then ``act`` every step."""

    name: str

    def reset(self, obs: Mapping[str, Any], info: Mapping[str, Any]) -> None: ...

    def act(self, obs: Mapping[str, Any], info: Mapping[str, Any]) -> NDArray[np.float32]: ...


def slowness_weights(sequence: ArrayLike, power: float = 2.0) -> NDArray[np.float64]:
    """Feature weights ``delta_i ** -power`` from features ``(T, k)`` along a trajectory in time
    order (a training run; no positions needed).

    ``delta_i = mean((f_i[t+1] - f_i[t])^2) / var(f_i)`` is the slowness SFA minimises. The cost
    ``sum_i w_i (f_i - g_i)^2`` weighs the standardised features by their slowness, so that slow
    features, which vary smoothly over the whole arena, dominate and fast ones, whose many
    extrema would create false minima, count less. SFA's outputs approximate the slowest
    eigenfunctions of the Laplacian of the space the training run explored, with ``delta_i`` their
    eigenvalues; ``power=1`` then gives the commute-time (diffusion) distance and ``power=2``
    (default) the biharmonic distance (Lipman et al. 2010), which is smooth at the goal and keeps
    its slope far from it (the README's navigation section compares the powers).
    """
    f = np.asarray(sequence, dtype=np.float64)
    if f.ndim != 2 or len(f) < 3:
        raise ValueError(f"sequence must be (T, k) features with T >= 3, got shape {f.shape}")
    if not (isinstance(power, int | float) and power > 0):
        raise ValueError(f"power must be a positive number, got {power!r}")
    variance = np.var(f, axis=0)
    delta = np.mean(np.diff(f, axis=0) ** 2, axis=0) / np.where(variance > 0, variance, 1.0)
    if np.any(~(delta > 0)) or np.any(~(variance > 0)):
        raise ValueError("a feature does not change along the sequence: its slowness is undefined")
    return (1.0 / delta) ** power / variance


@dataclass(frozen=True)
class GradientSettings:
    """Settings of :class:`GradientController` (SI units)."""

    memory: float = 0.5
    """metres of travel over which old samples fade out of the local fit (exponential weight)"""
    window: float = 1.5
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
    stop_window: int = 3
    """steps in the running mean of the cost"""
    give_up: float = 6.0
    """metres travelled without lowering the best cost by ``progress`` before giving up"""
    progress: float = 0.1
    """relative decrease of the best cost that counts as progress"""
    clearance: float = 0.55
    """range (m, from the rover's centre) below which a ray direction counts as blocked"""
    repel: float = 2.0
    """weight of the push away from close range readings, against the unit descent direction"""
    influence: float = 0.9
    """range (m) below which a reading pushes the rover away; the push grows linearly to 1 at 0"""
    search_after: float = 4.0
    """seconds without lowering the best cost by ``progress`` (the rover circles or sits in a
    false minimum of the cost, most of them along walls) before it searches around itself"""
    search_pitch: float = 0.3
    """metres between the loops of the search spiral"""
    search_start: float = 0.2
    """radius (m) of the search spiral's first loop"""
    search_found: float = 0.5
    """the search ends when the cost falls below this fraction of the best cost before it"""
    searches: int = 0
    """searches per episode at most (0, the default: none). On 100-episode sets (two seed sets,
    two world seeds, obstacle and open worlds) 3 searches changed success by -4 to +5 points,
    within the spread that the weave's random phase alone gives: not yet a gain"""


class LocalLinearFit:
    """The local linear model of the features around the rover, ``f(p) = a + J (p - p_now)``,
    fitted by weighted least squares to the features and odometry positions of its recent moves:
    what the gradient controller (and a learning agent) can know about the feature gradient
    without a map.

    One sample per centimetre of travel is kept, over ``window`` metres; a sample fades with the
    distance travelled since it (``memory``); a prior keeps the Jacobian's unexplored directions
    at their last estimate (``prior``), since the rover mostly moves along one direction.

    Args:
        weights: ``(k,)`` feature weights of the cost (for the fit's noise floor).
        memory, window, prior: as in :class:`GradientSettings`.
    """

    def __init__(self, weights: NDArray, memory: float, window: float, prior: float) -> None:
        self.weights = weights
        self.memory, self.window, self.prior = memory, window, prior
        self._positions: list[NDArray] = []
        self._features: list[NDArray] = []
        self._odometer: list[float] = []  # distance travelled when each sample was taken
        self._last_position: NDArray | None = None
        self._jacobian: NDArray | None = None
        self.travelled = 0.0
        """metres travelled since the start (odometry)"""

    def remember(self, position: NDArray, features: NDArray) -> None:
        """Add the features ``(k,)`` seen at the odometry position ``(2,)``."""
        if self._last_position is not None:
            self.travelled += float(np.linalg.norm(position - self._last_position))
        self._last_position = position
        if self._positions and np.linalg.norm(position - self._positions[-1]) < 0.01:
            # turning on the spot adds no information: keep only the latest features there
            self._positions[-1], self._features[-1] = position, features
            self._odometer[-1] = self.travelled
        else:
            self._positions.append(position)
            self._features.append(features)
            self._odometer.append(self.travelled)
        while self.travelled - self._odometer[0] > self.window:
            del self._positions[0], self._features[0], self._odometer[0]

    def fit(self) -> tuple[NDArray, NDArray, float] | None:
        """``(a, J, noise floor of the cost)`` of the model around the last position, or None
        while the first moves do not span the plane."""
        if len(self._positions) < 4:
            return None
        p = np.array(self._positions) - self._last_position
        f = np.array(self._features)
        sw = np.exp(-(self.travelled - np.array(self._odometer)) / self.memory)
        design = np.column_stack([np.ones(len(p)), p])
        normal = design.T @ (sw[:, None] * design)
        rhs = design.T @ (sw[:, None] * f)
        if self._jacobian is None:
            spread = np.linalg.eigvalsh(np.cov(p.T, aweights=sw))
            if spread[0] < 0.02**2:  # the moves span less than a couple of cm across
                return None
        else:
            strength = self.prior * sw.sum()
            normal[1:, 1:] += strength * np.eye(2)
            rhs[1:] += strength * self._jacobian.T
        coef = np.linalg.solve(normal, rhs)
        a, self._jacobian = coef[0], coef[1:].T
        residual = f - design @ coef
        noise = float(np.sum(sw[:, None] * self.weights * residual**2) / max(sw.sum() - 3, 1))
        return a, self._jacobian, noise


def gauss_newton_step(
    a: NDArray, jacobian: NDArray, goal: NDArray, weights: NDArray, damping: float
) -> NDArray:
    """The damped Gauss-Newton step ``-(J^T W J + mu I)^-1 J^T W (a - g)`` (m, in the odometry
    frame) towards the goal features ``g`` under the local linear model, ``mu`` = ``damping``
    times the trace of ``J^T W J``."""
    metric = jacobian.T @ (weights[:, None] * jacobian)
    gradient = jacobian.T @ (weights * (a - goal))
    mu = damping * float(np.trace(metric)) + 1e-12
    return -np.linalg.solve(metric + mu * np.eye(2), gradient)


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
    estimated from the cost and the fit's curvature. Starting next to a wall (within
    ``influence`` in the first metre), it first drives ``leave`` metres away from it: the cost
    has false minima along the walls. It stops when the running mean of the cost
    falls below the cost of being ``stop_distance`` from the goal in the direction where the cost
    rises slowest (the smaller eigenvalue of ``J^T W J``) plus the fit's noise floor,
    and gives up (stops) after ``give_up`` metres without progress. With ``searches``, stuck
    in a false minimum (``search_after`` seconds without progress while the fit's curvature
    puts the goal within ``slow_distance``: mostly by walls and obstacles, where the rover
    otherwise turns on the spot until the time limit), it drives an outward spiral until the
    cost falls to ``search_found`` of its best, and follows the gradient again from there.

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
        if self.settings.stop_curvature not in ("flattest", "mean"):
            raise ValueError(
                "settings.stop_curvature must be 'flattest' or 'mean', got "
                f"{self.settings.stop_curvature!r}"
            )
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
        self._phase = float(self.rng.uniform(0, math.tau))
        self.estimate: dict[str, float] = {}

    def act(self, obs: Mapping[str, Any], info: Mapping[str, Any]) -> NDArray[np.float32]:
        s = self.settings
        f = np.asarray(obs["features"], dtype=np.float64)
        g = np.asarray(obs["goal_features"], dtype=np.float64)
        x, y, yaw = (float(v) for v in info["odometry"])
        position = np.array([x, y])
        self._local.remember(position, f)
        travelled = self._local.travelled

        cost = float(np.sum(self.weights * (f - g) ** 2))
        self._costs.append(cost)
        self._t += self.dt
        if cost < self._best * (1 - s.progress):
            self._best, self._best_at, self._best_t = cost, travelled, self._t
        if travelled - self._best_at > s.give_up:
            return self._stop()

        ranges = np.asarray(info.get("range", ()), dtype=np.float64)
        if self._leave is None and s.leave > 0 and travelled < 1.0 and ranges.size:
            if ranges.min() < s.influence:
                push = self._push(ranges, yaw)
                self._leave = (math.atan2(push[1], push[0]), travelled)
        if self._leave is not None and travelled - self._leave[1] < s.leave:
            # a fixed direction, not the range readings of the moment: the sensor sees only
            # ahead, and turning away from a wall would look like having left it
            heading = self._unblocked(ranges, wrap_angle(self._leave[0] - yaw))
            return self._drive(s.speed * max(math.cos(heading), 0.0), s.turn_gain * heading)

        fit = self._local.fit()
        if fit is None:
            # not enough spread yet: drive a curve to get it
            return self._drive(s.min_speed * 1.5, self.w_max * 0.6)
        a, jac, noise = fit
        metric = jac.T @ (self.weights[:, None] * jac)  # (2, 2) J^T W J
        step = gauss_newton_step(a, jac, g, self.weights, s.damping)
        curvature = float(np.trace(metric)) / 2  # cost per m^2 of distance, on average
        distance = math.sqrt(max(cost - noise, 0.0) / curvature) if curvature > 0 else math.inf
        if s.stop_curvature == "flattest":
            # near walls the features flatten across them, and the mean curvature would stop
            # the rover short of a goal there
            stop_cost = s.stop_distance**2 * float(np.linalg.eigvalsh(metric)[0]) + noise
        else:
            stop_cost = s.stop_distance**2 * curvature + noise
        self.estimate = {"cost": cost, "distance": distance, "stop_cost": stop_cost}
        if len(self._costs) == s.stop_window and np.mean(self._costs) < stop_cost:
            return self._stop()

        # stuck where the fit's curvature says the goal is near but the cost stays above the
        # stop threshold: a false minimum, not a slow descent far from the goal
        stuck = self._t - self._best_t > s.search_after and distance < s.slow_distance
        if self._search is None and stuck:
            if self._searches < s.searches:
                self._searches += 1
                turn = 1.0 if self._searches % 2 else -1.0
                self._search = (travelled, self._best, turn)
        if self._search is not None:
            action = self._spiral(cost, travelled, ranges, yaw)
            if action is not None:
                return action

        direction = step / (np.linalg.norm(step) + 1e-12) + s.repel * self._push(ranges, yaw)
        weave = math.radians(s.weave_deg) * math.sin(
            self._phase + math.tau * travelled / s.weave_wavelength
        )
        heading = wrap_angle(math.atan2(direction[1], direction[0]) + weave - yaw)
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
            self._search, self._best_t = None, self._t
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
        return np.array([0.0, 0.0, 1.0], dtype=np.float32)


class OracleController:
    """Upper bound: drives the geodesic shortest path with the ground-truth pose and stops at the
    goal. It reads ``info["x"]``, ``"y"``, ``"yaw"`` and ``"goal"``, and the occupancy grid: a
    map and ground truth no real rover has. The path's corners are the waypoints of a
    :class:`~sfa_gym.recording.drivers.WaypointDriver`, the closed-loop steering the scripted
    recordings use.

    Args:
        occupancy: the env's :class:`~sfa_gym.navigation.occupancy.OccupancyGrid`.
        v_max, w_max: speed limits; dt: control period (s);
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
        self._driver = WaypointDriver(
            [tuple(p) for p in path], speed=self.v_max, turn_rate=self.w_max,
            tolerance=self.stop_radius,
        )  # fmt: skip
        self._driver.reset(self.occupancy.bounds, dt=self.dt)

    def act(self, obs: Mapping[str, Any], info: Mapping[str, Any]) -> NDArray[np.float32]:
        here = np.array([info["x"], info["y"]])
        if self._driver.done or np.linalg.norm(here - self._goal) <= self.stop_radius:
            return np.array([0.0, 0.0, 1.0], dtype=np.float32)
        v, w = self._driver(info)
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
