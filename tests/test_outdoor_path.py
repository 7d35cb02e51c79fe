"""The paper's outdoor trajectories: frame counts, x/y balance, the avoided south-west region,
bounds, speed and acceleration limits, determinism, errors, and the closed-loop driver (on an
ideal rover and, for a few steps, in the real env)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sfa_gym.recording.drivers import Driver
from sfa_gym.recording.outdoor_path import (
    OutdoorPathDriver,
    plan_grid,
    plan_outdoor_paths,
    south_west,
)
from sfa_gym.sim.rover import RoverSpec

BOUNDS = (-2.5, 2.5, -3.5, 3.5)  # the paper_outdoor world's drivable area
FOOTPRINT = RoverSpec().footprint_radius


@pytest.fixture(scope="module")
def paths():
    return plan_outdoor_paths(BOUNDS, seed=3)


def _distance_to_rect(xy: np.ndarray, rect) -> np.ndarray:
    x0, x1, y0, y1 = rect
    dx = np.maximum.reduce([x0 - xy[:, 0], np.zeros(len(xy)), xy[:, 0] - x1])
    dy = np.maximum.reduce([y0 - xy[:, 1], np.zeros(len(xy)), xy[:, 1] - y1])
    return np.hypot(dx, dy)


def _fine(path, step: float = 0.02) -> np.ndarray:
    """The reference every ``step`` seconds, ``(N, 5)``: x, y, yaw, v, w."""
    return path.reference(np.arange(0.0, path.duration, step))


def test_paths_have_the_papers_frame_counts_and_fill_them(paths):
    train, test = paths
    assert (train.n_frames, test.n_frames) == (5900, 2800)
    for path in paths:
        assert path.poses().shape == (path.n_frames, 3)
        # the legs fill the frames to within a tenth of a frame
        assert 0.0 <= (path.n_frames - 1) * path.dt - path.duration < 0.01 + 1e-9
    both = train.then(test)
    assert both.n_frames == 8700
    np.testing.assert_allclose(both.poses()[5900, :2], test.start[:2], atol=1e-9)
    np.testing.assert_allclose(train.end[:2], test.start[:2])


def test_x_and_y_translation_are_balanced_within_ten_percent(paths):
    for path in paths:
        dx, dy = path.distance("x"), path.distance("y")
        assert abs(dx - dy) <= 0.1 * max(dx, dy)
        # the same measured on the sampled frames, not on the legs
        moves = np.abs(np.diff(path.poses()[:, :2], axis=0)).sum(axis=0)
        assert moves[0] == pytest.approx(dx, rel=0.01)
        assert moves[1] == pytest.approx(dy, rel=0.01)
        assert abs(moves[0] - moves[1]) <= 0.1 * moves.max()


def test_training_path_never_enters_the_south_west_and_the_test_path_crosses_it(paths):
    train, test = paths
    avoid = south_west(BOUNDS)
    assert avoid == (-2.5, -1.0, -3.5, -2.0) and train.avoid == avoid
    # the rover's whole footprint stays out, with room for tracking errors
    gap = _distance_to_rect(_fine(train)[:, :2], avoid)
    assert gap.min() >= FOOTPRINT + 0.05
    inside = _distance_to_rect(test.poses()[:, :2], avoid) == 0.0
    assert inside.sum() >= 100  # 10 s or more in the region never seen in training
    # and the training path covers the rest: every other quarter has frames
    xy = train.poses()[:, :2]
    for qx, qy in ((1, -1), (1, 1), (-1, 1)):
        assert np.any((np.sign(xy[:, 0]) == qx) & (np.sign(xy[:, 1]) == qy))


def test_paths_stay_in_bounds_and_respect_speed_and_acceleration_limits(paths):
    x0, x1, y0, y1 = BOUNDS
    for path in paths:
        ref = _fine(path, 0.01)
        assert np.all((ref[:, 0] >= x0) & (ref[:, 0] <= x1))
        assert np.all((ref[:, 1] >= y0) & (ref[:, 1] <= y1))
        assert np.all(ref[:, 3] >= 0.0) and ref[:, 3].max() <= 0.4
        assert path.speed <= 0.36 + 1e-12 and ref[:, 3].max() == pytest.approx(path.speed)
        assert np.abs(ref[:, 4]).max() <= 0.8 + 1e-9
        assert np.abs(np.diff(ref[:, 3])).max() / 0.01 <= 0.8 + 1e-6  # m/s^2
        assert np.abs(np.diff(ref[:, 4])).max() / 0.01 <= 2.0 + 1e-6  # rad/s^2
        # never driving and turning at once: straight legs along x or y, turns on the spot
        assert not np.any((ref[:, 3] > 1e-9) & (np.abs(ref[:, 4]) > 1e-9))
        for leg in path.legs:
            if leg.kind == "x":
                assert math.sin(leg.start[2]) == pytest.approx(0.0, abs=1e-9)
            elif leg.kind == "y":
                assert math.cos(leg.start[2]) == pytest.approx(0.0, abs=1e-9)


def test_paths_are_deterministic_from_the_seed(paths):
    again = plan_outdoor_paths(BOUNDS, seed=3)
    other = plan_outdoor_paths(BOUNDS, seed=4)
    for a, b in zip(paths, again, strict=True):
        np.testing.assert_array_equal(a.poses(), b.poses())
    assert not np.array_equal(paths[0].poses(), other[0].poses())


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"n_frames": 1}, "n_frames must be at least 2"),
        ({"n_frames": 5900.0}, "n_frames must be a positive int"),
        ({"spacing": -0.5}, "spacing must be a positive number"),
        ({"dt": 0.0}, "dt must be a positive number"),
        ({"avoid": (1.0, 0.0, 0.0, 1.0)}, "avoid must be finite with xmin < xmax"),
        ({"margin": 3.0}, "margin 3.0 leaves no room"),
        ({"min_speed_fraction": 1.5}, "min_speed_fraction must lie in"),
        ({"n_frames": 50}, "try a larger spacing"),
        ({"n_frames": 90000}, "try a smaller spacing"),
        ({"start": (9.0, 0.0, 0.0)}, "lies outside the lanes' area"),
        ({"start": ("east", 0.0, 0.0)}, r"start must be a pose \(x, y, yaw\)"),
        ({"start": (0.0, 0.0)}, r"start must be a pose \(x, y, yaw\)"),
    ],
)
def test_bad_plans_are_refused(kwargs, match):
    with pytest.raises(ValueError, match=match):
        plan_grid(BOUNDS, **{"n_frames": 5900, **kwargs})


def test_bad_driver_settings_and_regions_are_refused():
    with pytest.raises(ValueError, match="part must be 'train', 'test' or 'both'"):
        OutdoorPathDriver("training").reset(BOUNDS)
    with pytest.raises(ValueError, match="speed 0.5 m/s exceeds speed_limit"):
        OutdoorPathDriver(speed=0.5).reset(BOUNDS)
    with pytest.raises(ValueError, match="avoid must be a rectangle, 'south-west' or None"):
        OutdoorPathDriver(avoid="north").reset(BOUNDS)
    with pytest.raises(ValueError, match="size 6.0 m does not fit"):
        south_west(BOUNDS, 6.0)
    with pytest.raises(RuntimeError, match="must be reset"):
        OutdoorPathDriver()({"x": 0.0, "y": 0.0, "yaw": 0.0})


def test_driver_follows_the_whole_drive_on_an_ideal_rover():
    """Closed loop on a unicycle that does what it is told (with a 10 % slow yaw rate, as
    a skid-steer turning less than commanded): the driver corrects the error."""
    driver = OutdoorPathDriver("both")
    driver.reset(BOUNDS, dt=0.1, seed=0)
    assert isinstance(driver, Driver) and driver.describe()["type"] == "OutdoorPathDriver"
    x, y, yaw = driver.start_pose
    steps, errors = 0, []
    reference = driver.path_.poses()
    while not driver.done:
        v, w = driver({"x": x, "y": y, "yaw": yaw})
        assert abs(v) <= 0.4 + 1e-6 and abs(w) <= 1.0 + 1e-6
        yaw += 0.9 * float(w) * 0.1
        x += float(v) * math.cos(yaw) * 0.1
        y += float(v) * math.sin(yaw) * 0.1
        steps += 1
        errors.append(math.hypot(x - reference[steps, 0], y - reference[steps, 1]))
    assert steps == 8700 - 1  # a recording holds exactly the 8700 frames
    assert max(errors) < 0.1
    np.testing.assert_array_equal(driver({"x": x, "y": y, "yaw": yaw}), [0.0, 0.0])


def test_driver_steps_the_real_env():
    from sfa_gym.sim.camera import PanoramaSpec
    from sfa_gym.sim.env import OmniRoverEnv

    # every step renders: a tiny panorama keeps it cheap
    env = OmniRoverEnv(
        world="paper_outdoor",
        panorama=PanoramaSpec(width=32, height=8),
        rover=RoverSpec.outdoor(),
        dynamics=False,
    )
    try:
        driver = OutdoorPathDriver("train")
        driver.reset(env.arena_bounds, dt=env.dt, seed=0)
        _, info = env.reset(seed=0, options={"pose": driver.start_pose})
        reference = driver.path_.poses()
        for k in range(1, 51):
            action = driver(info)
            assert env.action_space.contains(action)
            _, _, _, _, info = env.step(action)
            error = math.hypot(info["x"] - reference[k, 0], info["y"] - reference[k, 1])
            assert error < 0.1
        moved = math.hypot(info["x"] - reference[0, 0], info["y"] - reference[0, 1])
        assert moved > 0.5  # it drove, not just stood
    finally:
        env.close()
