"""Scripted drivers: coverage, speed limits, bounds, turning statistics, grid poses."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

import sfa_gym  # noqa: F401  (registers the envs)
from sfa_gym.recording.drivers import (
    GridPositions,
    LawnMowerDriver,
    LoopDriver,
    RandomWalkDriver,
    WaypointDriver,
    _route,
)
from sfa_gym.sim.steering import Steering

BOUNDS = (-3.0, 3.0, -3.0, 3.0)
DT = 0.1


def simulate(driver, bounds=BOUNDS, n=20000, lag=0.5, seed=0, start=None):
    """Drive a unicycle whose speeds follow the commands with a first-order lag.

    Returns the poses ``(T + 1, 3)`` and the commanded actions ``(T, 2)``.
    """
    driver.reset(bounds, dt=DT, seed=seed)
    x, y, yaw = start or driver.start_pose or (0.0, 0.0, 0.0)
    v = w = 0.0
    poses, actions = [(x, y, yaw)], []
    for _ in range(n):
        if driver.done:
            break
        action = driver({"x": x, "y": y, "yaw": yaw})
        actions.append(action)
        v += (float(action[0]) - v) * lag
        w += (float(action[1]) - w) * lag
        x, y = x + v * math.cos(yaw) * DT, y + v * math.sin(yaw) * DT
        yaw = (yaw + w * DT + math.pi) % (2 * math.pi) - math.pi
        poses.append((x, y, yaw))
    return np.array(poses), np.array(actions)


def visited_cells(poses, bounds=BOUNDS, cells=6):
    xmin, xmax, ymin, ymax = bounds
    i = np.clip(((poses[:, 0] - xmin) / (xmax - xmin) * cells).astype(int), 0, cells - 1)
    j = np.clip(((poses[:, 1] - ymin) / (ymax - ymin) * cells).astype(int), 0, cells - 1)
    grid = np.zeros((cells, cells), bool)
    grid[j, i] = True
    return grid


def in_rect(poses, rect):
    x0, x1, y0, y1 = rect
    return (poses[:, 0] > x0) & (poses[:, 0] < x1) & (poses[:, 1] > y0) & (poses[:, 1] < y1)


def travel(poses):
    step = np.abs(np.diff(poses[:, :2], axis=0))
    return step[:, 0].sum(), step[:, 1].sum()


# ------------------------------------------------------------------------ lawn mower


def test_lawn_mower_covers_the_arena_within_the_speed_limits():
    driver = LawnMowerDriver(spacing=0.5, steering=Steering(speed=0.4, turn_rate=1.0))
    poses, actions = simulate(driver)
    assert driver.done
    assert visited_cells(poses).all()  # every cell of a 6 x 6 grid of 1 m cells
    assert np.abs(actions[:, 0]).max() <= np.float32(0.4)
    assert np.abs(actions[:, 1]).max() <= np.float32(1.0)
    assert actions.dtype == np.float32 and actions.shape[1] == 2
    speed = np.hypot(*np.diff(poses[:, :2], axis=0).T) / DT
    assert speed.max() <= 0.4 + 1e-6  # float32 commands
    # it stays in the margin it was given, up to the reach tolerance and the lag
    assert np.abs(poses[:, :2]).max() < 2.5 + 0.2


def test_grid_pattern_balances_x_and_y_translation():
    along_x, along_y = travel(simulate(LawnMowerDriver(spacing=1.0, pattern="rows"))[0])
    assert along_x > 3 * along_y
    along_x, along_y = travel(simulate(LawnMowerDriver(spacing=1.0, pattern="grid"))[0])
    assert 0.8 < along_x / along_y < 1.25


def test_lawn_mower_offset_moves_the_rows():
    a, b = (
        LawnMowerDriver(spacing=1.0, pattern="rows"),
        LawnMowerDriver(spacing=1.0, pattern="rows", offset=0.5),
    )
    a.reset(BOUNDS)
    b.reset(BOUNDS)
    rows_a, rows_b = np.unique(a.path()[:, 1]), np.unique(b.path()[:, 1])
    np.testing.assert_allclose(rows_a, [-2.5, -1.5, -0.5, 0.5, 1.5, 2.5])
    np.testing.assert_allclose(rows_b, [-2.0, -1.0, 0.0, 1.0, 2.0])


def test_spins_add_rotation_in_place():
    plain, _ = simulate(LawnMowerDriver(spacing=1.0, pattern="rows"))
    driver = LawnMowerDriver(spacing=1.0, pattern="rows", spin=2 * math.pi)
    spun, actions = simulate(driver)
    turned = lambda p: np.abs(np.angle(np.exp(1j * np.diff(p[:, 2])))).sum()  # noqa: E731
    n_rows = 6
    assert turned(spun) - turned(plain) > 0.9 * n_rows * 2 * math.pi
    assert ((actions[:, 0] == 0) & (actions[:, 1] != 0)).sum() > n_rows * 2 * math.pi / DT * 0.9


@pytest.mark.parametrize("exclude", [(-3.0, -1.5, -3.0, -1.5), (-0.6, 0.6, -0.4, 0.8)])
def test_training_sweep_never_enters_the_excluded_region_and_test_loop_does(exclude):
    driver = LawnMowerDriver(spacing=0.5, exclude=exclude, clearance=0.3)
    poses, _ = simulate(driver)
    assert driver.done
    assert not in_rect(poses, exclude).any()
    assert visited_cells(poses).sum() >= 36 - 4  # the rest of the arena is still covered
    loop = LoopDriver(insets=(0.5, 1.5, 2.5))
    loop_poses, _ = simulate(loop)
    assert loop.done and in_rect(loop_poses, exclude).any()


def test_waypoint_driver_reaches_its_points_in_order():
    points = [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (-1.0, 0.5)]
    driver = WaypointDriver(points, steering=Steering(tolerance=0.05))
    poses, _ = simulate(driver)
    assert driver.done and driver.start_pose == (0.0, 0.0, 0.0)
    first_close = [np.flatnonzero(np.hypot(*(poses[:, :2] - p).T) < 0.1)[0] for p in points]
    assert first_close == sorted(first_close)


def test_driver_arguments_are_checked():
    with pytest.raises(ValueError, match="pattern"):
        LawnMowerDriver(pattern="spiral").reset(BOUNDS)
    with pytest.raises(ValueError, match="margin 4"):
        LawnMowerDriver(margin=4).reset(BOUNDS)
    with pytest.raises(ValueError, match="bounds"):
        LawnMowerDriver().reset((1.0, 0.0, 0.0, 1.0))
    with pytest.raises(ValueError, match="exclude"):
        LawnMowerDriver(exclude=(0.0, 1.0)).reset(BOUNDS)
    with pytest.raises(ValueError, match="spacing"):
        LawnMowerDriver(spacing=0).reset(BOUNDS)
    with pytest.raises(ValueError, match="turn_probability"):
        RandomWalkDriver(turn_probability=1.5).reset(BOUNDS)
    with pytest.raises(RuntimeError, match="reset"):
        LoopDriver()({"x": 0, "y": 0, "yaw": 0})
    driver = LoopDriver()
    driver.reset(BOUNDS)
    with pytest.raises(KeyError, match="yaw"):
        driver({"x": 0.0, "y": 0.0})


@pytest.mark.parametrize(
    "driver, name",
    [
        (LawnMowerDriver(spin=math.nan), "spin"),
        (LawnMowerDriver(offset=math.inf), "offset"),
        (LawnMowerDriver(margin=math.nan), "margin"),
        (LawnMowerDriver(clearance=-0.1), "clearance"),
        (LawnMowerDriver(exclude=(0.0, math.nan, 0.0, 1.0)), "exclude"),
        (LawnMowerDriver(exclude=(1.0, 0.0, 0.0, 1.0)), "exclude"),
        (LawnMowerDriver(steering=Steering(speed=math.nan)), "speed"),
        (LoopDriver(insets=(0.5, math.nan)), "inset"),
        (LoopDriver(steering=Steering(turn_rate=0.0)), "turn_rate"),
        (RandomWalkDriver(turn_probability=math.nan), "turn_probability"),
        (RandomWalkDriver(margin=math.nan), "margin"),
    ],
)
def test_non_finite_and_out_of_range_arguments_are_named(driver, name):
    with pytest.raises(ValueError, match=name):
        driver.reset(BOUNDS)


def test_infinite_bounds_are_refused():
    with pytest.raises(ValueError, match="bounds"):
        RandomWalkDriver().reset((-math.inf, 3.0, -3.0, 3.0))


def test_every_waypoint_driver_takes_one_steering_setting():
    steering = Steering(speed=0.3, turn_rate=0.7, tolerance=0.2, turn_in_place=0.4)
    for cls in (WaypointDriver, LawnMowerDriver, LoopDriver):
        driver = cls(steering=steering)
        assert driver.get_params()["steering"] == steering
        # a run's header holds the setting as plain JSON types
        assert driver.describe()["steering"] == {
            "speed": 0.3,
            "turn_rate": 0.7,
            "tolerance": 0.2,
            "turn_in_place": 0.4,
        }


def test_a_steering_setting_that_is_not_one_is_named():
    with pytest.raises(TypeError, match="steering"):
        WaypointDriver([(0.0, 0.0), (1.0, 0.0)], steering={"speed": 0.3}).reset(BOUNDS)


def test_describe_reports_the_arguments():
    description = LawnMowerDriver(spacing=0.7, exclude=(0, 1, 0, 1)).describe()
    assert description["type"] == "LawnMowerDriver"
    assert description["spacing"] == 0.7 and description["exclude"] == (0, 1, 0, 1)
    assert RandomWalkDriver(turn_probability=0.3).describe()["turn_probability"] == 0.3


# ----------------------------------------------------------------------- random walk


@pytest.mark.parametrize(
    ("turn_probability", "turn_duration", "straight_duration"), [(0.2, 1.0, 4.0), (0.8, 3.0, 1.0)]
)
def test_random_walk_turning_share_follows_its_parameters(
    turn_probability, turn_duration, straight_duration
):
    driver = RandomWalkDriver(
        turn_probability=turn_probability,
        turn_duration=turn_duration,
        straight_duration=straight_duration,
        turn_rate=0.8,
    )
    # an arena far larger than the walk, so that no wall interferes
    big = (-1000.0, 1000.0, -1000.0, 1000.0)
    _, actions = simulate(driver, bounds=big, n=20000)
    turning = (actions[:, 0] == 0) & (np.abs(actions[:, 1]) == np.float32(0.8))
    straight = (actions[:, 0] == np.float32(0.3)) & (actions[:, 1] == 0)
    assert (turning | straight).all()
    assert abs(turning.mean() - driver.turn_fraction) < 0.03
    # both turning directions occur about equally often
    assert 0.35 < (actions[turning, 1] > 0).mean() < 0.65


def test_random_walk_stays_in_bounds_and_is_reproducible():
    small = (-1.0, 1.0, -1.5, 1.5)
    a, actions_a = simulate(RandomWalkDriver(margin=0.4), bounds=small, n=4000, seed=5)
    b, actions_b = simulate(RandomWalkDriver(margin=0.4), bounds=small, n=4000, seed=5)
    _, actions_c = simulate(RandomWalkDriver(margin=0.4), bounds=small, n=4000, seed=6)
    np.testing.assert_array_equal(actions_a, actions_b)
    assert not np.array_equal(actions_a, actions_c)
    assert (np.abs(a[:, 0]) < 1.0).all() and (np.abs(a[:, 1]) < 1.5).all()
    assert visited_cells(a, bounds=small, cells=3).sum() >= 7  # it does get around


# -------------------------------------------------------------------- grid positions


def test_grid_positions_are_distinct_inside_bounds_with_reproducible_yaws():
    bounds = (-2.0, 4.0, 0.0, 3.0)
    poses = GridPositions(n=5, seed=1).poses(bounds)
    assert poses.shape == (25, 3)
    assert len(np.unique(poses[:, :2], axis=0)) == 25
    assert (poses[:, 0] > -2).all() and (poses[:, 0] < 4).all()
    assert (poses[:, 1] > 0).all() and (poses[:, 1] < 3).all()
    assert (np.abs(poses[:, 2]) <= math.pi).all() and np.std(poses[:, 2]) > 1.0
    np.testing.assert_array_equal(poses, GridPositions(n=5, seed=1).poses(bounds))
    assert not np.allclose(poses[:, 2], GridPositions(n=5, seed=2).poses(bounds)[:, 2])
    # the visiting order permutes the poses; each position keeps its yaw
    hilbert = GridPositions(n=5, seed=1, order="hilbert").poses(bounds)
    key = lambda p: np.lexsort((p[:, 0], p[:, 1]))  # noqa: E731
    np.testing.assert_array_equal(hilbert[key(hilbert)], poses[key(poses)])
    serpentine = GridPositions(n=5, seed=1, order="serpentine").poses(bounds)
    assert np.hypot(*np.diff(serpentine[:, :2], axis=0).T).max() <= 1.2 + 1e-9


def test_grid_positions_of_an_env_without_its_own_grid_divide_its_arena():
    class Arena(gym.Env):
        arena_bounds = (-2.0, 4.0, 0.0, 3.0)

    np.testing.assert_array_equal(
        GridPositions(n=5, seed=1).poses(Arena()),
        GridPositions(n=5, seed=1).poses(Arena.arena_bounds),
    )
    with pytest.raises(ValueError, match="bounds must be a rectangle"):
        GridPositions(n=5).poses(gym.Env())


def test_grid_positions_bad_arguments():
    with pytest.raises(ValueError, match="order"):
        GridPositions(order="spiral").poses(BOUNDS)
    with pytest.raises(ValueError, match="n must"):
        GridPositions(n=0).poses(BOUNDS)


# ------------------------------------------------------------------- the real env


@pytest.fixture(scope="module")
def env():
    env = gym.make("sfa_gym/OmniRover-v0")
    yield env
    env.close()


def _drive(env, driver, n, seed=0, pose=None):
    driver.reset(env.get_wrapper_attr("arena_bounds"), dt=env.get_wrapper_attr("dt"), seed=seed)
    pose = pose or driver.start_pose
    _, info = env.reset(seed=seed, options=None if pose is None else {"pose": pose})
    poses = [(info["x"], info["y"], info["yaw"])]
    for _ in range(n):
        _, _, _, _, info = env.step(driver(info))
        poses.append((info["x"], info["y"], info["yaw"]))
    return np.array(poses)


def test_lawn_mower_drives_the_real_rover_along_its_first_row(env):
    driver = LawnMowerDriver(spacing=1.0, pattern="rows", steering=Steering(speed=0.4))
    poses = _drive(env, driver, n=40)
    (x0, y0), (x1, y1) = driver.path()[:2]
    assert (x0, y0) == pytest.approx(poses[0, :2], abs=1e-6) and y1 == y0 and x1 > x0
    speed = np.hypot(*np.diff(poses[:, :2], axis=0).T) / env.get_wrapper_attr("dt")
    assert speed.max() < 0.4 * 1.1
    assert poses[-1, 0] - x0 > 0.6 * 0.4 * 40 * env.get_wrapper_attr("dt")
    assert np.abs(poses[:, 1] - y0).max() < 0.1


class _Shrunk(gym.Wrapper):
    """A wrapper that offers its own, coarser grid of positions."""

    def grid_positions(self, n: int = 30) -> np.ndarray:
        g = np.linspace(-1.0, 1.0, n)
        gx, gy = np.meshgrid(g, g)
        return np.stack([gx.ravel(), gy.ravel()], axis=1)


def test_grid_positions_ask_the_outermost_wrapper_that_offers_them(env):
    poses = GridPositions(n=3, seed=0).poses(_Shrunk(env))
    assert sorted(set(poses[:, 0].tolist())) == [-1.0, 0.0, 1.0]


def test_grid_positions_of_the_real_env(env):
    poses = GridPositions(n=30, seed=0, order="hilbert").poses(env)
    assert poses.shape == (900, 3)
    grid = env.get_wrapper_attr("grid_positions")(30)
    key = lambda p: np.lexsort((p[:, 0], p[:, 1]))  # noqa: E731
    np.testing.assert_array_equal(poses[key(poses), :2], grid[key(grid)])
    _, info = env.reset(seed=0, options={"pose": tuple(poses[17])})
    assert (info["x"], info["y"]) == pytest.approx(tuple(poses[17, :2]), abs=1e-6)


def test_random_walk_turns_back_before_the_real_wall(env):
    xmax = env.get_wrapper_attr("arena_bounds")[1]
    # start 0.2 m from the edge of the drivable area, heading straight at it
    poses = _drive(env, RandomWalkDriver(margin=0.5), n=30, pose=(xmax - 0.2, 0.0, 0.0))
    assert poses[:, 0].max() < xmax


def test_docstring_examples():
    import doctest

    import sfa_gym.recording.drivers

    failures, attempted = doctest.testmod(sfa_gym.recording.drivers, verbose=False)
    assert attempted >= 1 and failures == 0


def test_a_stuck_rover_gives_up_the_segment_and_the_drive_ends():
    driver = WaypointDriver([(0.0, 0.0), (1.0, 0.0), (1.0, 1.0)])
    _, actions = simulate(driver, lag=0.0, n=5000)  # the rover never moves
    assert driver.done and driver.skipped_ == 2
    assert len(actions) < 1000


def test_route_around_a_rectangle_keeps_its_ties_and_stays_in_the_area():
    # the recorded runs depend on which of two equally long detours is taken: pin it
    square, arena = (-0.5, 0.5, -0.5, 0.5), (-3.0, 3.0, -3.0, 3.0)
    c = 0.500001  # corners are pushed out by 1e-6
    assert _route((-1.0, 0.0), (1.0, 0.0), square, arena) == [(-c, -c), (c, -c)]
    assert _route((0.0, -1.0), (0.0, 1.0), square, arena) == [(c, -c), (c, c)]
    # only the corners inside the area are used
    assert _route((0.0, -1.0), (0.0, 1.0), square, (-3.0, 0.5, -3.0, 3.0)) == [(-c, -c), (-c, c)]
    assert _route((-1.0, 0.8), (1.0, 0.8), square, arena) == []
    with pytest.raises(ValueError, match="no path"):
        _route((-1.0, 0.0), (1.0, 0.0), square, (-3.0, 3.0, -0.2, 0.2))
