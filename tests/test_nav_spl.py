"""The gradient controller's path length: its probe before the first fit, near walls too.

A kinematic unicycle in a smooth analytic feature field stands in for the env (no rendering, no
SFA): the controller sees the features, the odometry and, where there is a wall, a range sensor
computed from the wall's line, as it would from the env.
"""

from __future__ import annotations

import math

import numpy as np

from sfa_gym.navigation.controllers import PROBE_TIME, GradientController, GradientSettings

ANGLES = np.linspace(-math.pi / 2, math.pi / 2, 7)  # the env's default range sensor
WALL_X = 1.2  # a wall along x = WALL_X, where a test has one
RANGE_MAX = 2.0


def features(p: np.ndarray) -> np.ndarray:
    """Smooth, curved features of the planar position ``(2,)``: four of them."""
    x, y = p
    return np.array([x + 0.1 * y**2, y - 0.1 * x**2, 0.5 * math.sin(x), 0.5 * math.cos(y)])


def ranges(x: float, y: float, yaw: float, wall: bool) -> np.ndarray:
    """Range readings (m) of the rays towards the wall along x = WALL_X."""
    if not wall:
        return np.full(len(ANGLES), RANGE_MAX)
    c = np.cos(yaw + ANGLES)
    with np.errstate(divide="ignore"):
        r = np.where(c > 1e-9, (WALL_X - x) / c, RANGE_MAX)
    return np.clip(r, 0.0, RANGE_MAX)


def drive(controller, start, goal, wall=False, steps=600, dt=0.1):
    """Run one episode; returns the path ``(n, 2)``, the modes and whether it stopped."""
    x, y, yaw = start
    goal_features = features(np.asarray(goal))
    controller.reset({}, {})
    path, modes = [(x, y)], []
    for _ in range(steps):
        obs = {"features": features(np.array([x, y])), "goal_features": goal_features}
        # odometry in the frame of the start pose, as the env gives it
        dx, dy = x - start[0], y - start[1]
        c, s = math.cos(start[2]), math.sin(start[2])
        info = {
            "odometry": np.array([c * dx + s * dy, -s * dx + c * dy, yaw - start[2]]),
            "range": ranges(x, y, yaw, wall) if controller.range_angles.size else np.zeros(0),
        }
        v, w, stop = controller.act(obs, info)
        modes.append(controller.mode)
        if stop > 0:
            return np.array(path), modes, True
        x, y, yaw = x + v * math.cos(yaw) * dt, y + v * math.sin(yaw) * dt, yaw + w * dt
        if wall:
            x = min(x, WALL_X - 0.25)  # the rover's body stops at the wall
        path.append((x, y))
    return np.array(path), modes, False


def path_length(path: np.ndarray) -> float:
    return float(np.sum(np.hypot(*np.diff(path, axis=0).T)))


def test_the_probe_spans_the_plane_on_less_path_than_a_curve():
    lengths = {}
    for leg in (0.0, 0.1):
        controller = GradientController(np.ones(4), settings=GradientSettings(probe_leg=leg))
        path, modes, _ = drive(controller, (0.0, 0.0, 0.3), (1.5, 1.0))
        first_fit = modes.index("descend")
        assert set(modes[:first_fit]) == {"probe"}
        lengths[leg] = path_length(path[: first_fit + 1])
    # two straight legs with a turn on the spot between them: about 0.26 m, the curve 0.4 m
    assert lengths[0.1] < 0.3
    assert lengths[0.1] < 0.75 * lengths[0.0]


def test_reaches_a_goal_in_a_smooth_field_on_a_short_path():
    controller = GradientController(np.ones(4), ANGLES)
    start, goal = (-1.0, -0.8, 2.0), (1.2, 0.6)
    path, modes, stopped = drive(controller, start, goal)
    assert stopped and modes[-1] == "stop"
    assert math.dist(path[-1], goal) < 0.2
    assert path_length(path) < 1.5 * math.dist(start[:2], goal)


def test_a_probe_facing_a_wall_keeps_off_it_and_still_gets_its_first_fit():
    # 0.35 m in front of the wall, facing it, without the rule that first leaves the wall: the
    # first leg would end against it
    settings = GradientSettings(leave=0.0)
    controller = GradientController(np.ones(4), ANGLES, settings=settings)
    path, modes, _ = drive(controller, (WALL_X - 0.35, 0.0, 0.2), (-0.5, 0.5), wall=True)
    assert "descend" in modes
    first_fit = modes.index("descend")
    assert first_fit * 0.1 < PROBE_TIME + 4.0  # the curve after PROBE_TIME takes about 4 s
    # it never touched the wall (the test world stops the body 0.25 m from it)
    assert path[: first_fit + 1, 0].max() < WALL_X - 0.25 - 0.02
