"""The navigation envs: contract (checkers, determinism, info), the task's rules, geodesic
distances with known answers, odometry against the ground truth, and the controllers."""

from __future__ import annotations

import math
import warnings
from types import SimpleNamespace

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import sfa_gym  # noqa: F401  (registers the ids)
from sfa_gym.navigation.controllers import OracleController, RandomController
from sfa_gym.navigation.evaluate import run_episodes, summarize
from sfa_gym.navigation.field import FeatureField
from sfa_gym.navigation.occupancy import OccupancyGrid
from sfa_gym.registration import NAV_ENV_IDS

INFO_KEYS = {
    "x", "y", "yaw", "t", "start", "goal", "geodesic_distance", "shortest_path", "path_length",
    "success", "collisions", "interior", "odometry", "range",
}  # fmt: skip


def _position_field(env_id: str = "sfa_gym/OmniRoverNav-v0") -> FeatureField:
    """A field whose features are the position itself: stands in for a feature model where
    the test is about the env's mechanics, not the features."""
    bounds = gym.make(env_id).unwrapped.arena_bounds
    xs, ys = np.linspace(*bounds[:2], 13), np.linspace(*bounds[2:], 13)
    gx, gy = np.meshgrid(xs, ys)
    return FeatureField(np.stack([gx, gy], axis=2), bounds)


@pytest.mark.parametrize("env_id", NAV_ENV_IDS[:2])
def test_gymnasium_and_sb3_checkers_pass(env_id, monkeypatch):
    from stable_baselines3.common.env_checker import check_env as sb3_check_env

    monkeypatch.setenv("SDL_VIDEODRIVER", "dummy")  # the checker also opens a "human" window
    env = gym.make(env_id)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # SB3 recommends a [-1, 1] action box; ours is physical
        check_env(env.unwrapped)
        sb3_check_env(env.unwrapped, warn=True)
    obs, info = env.reset(seed=0)
    assert env.observation_space.contains(obs)
    assert set(info) >= INFO_KEYS
    env.close()


def test_checkers_pass_in_feature_field_mode(monkeypatch):
    monkeypatch.setenv("SDL_VIDEODRIVER", "dummy")  # the checker also opens a "human" window
    env = gym.make("sfa_gym/OmniRoverNav-v0", feature_field=_position_field())
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        check_env(env.unwrapped)
    obs, info = env.reset(seed=0)
    # the stand-in field's features are the position
    np.testing.assert_allclose(obs["features"], [info["x"], info["y"]], atol=1e-5)
    np.testing.assert_allclose(obs["goal_features"], info["goal"][:2], atol=1e-5)


def test_same_seed_same_episode_and_pixels():
    actions = np.random.default_rng(0).uniform([-0.4, -1, -1], [0.4, 1, -0.5], (20, 3))
    runs = []
    for _ in range(2):
        env = gym.make("sfa_gym/OmniRoverNav-v0")
        obs, info = env.reset(seed=7)
        frames = [obs["panorama"], obs["goal"]]
        for a in actions:
            obs, *_ = env.step(a.astype(np.float32))
            frames.append(obs["panorama"])
        runs.append((info["start"], info["goal"], np.stack(frames)))
        env.close()
    np.testing.assert_array_equal(runs[0][0], runs[1][0])
    np.testing.assert_array_equal(runs[0][1], runs[1][1])
    np.testing.assert_array_equal(runs[0][2], runs[1][2])
    other = gym.make("sfa_gym/OmniRoverNav-v0").reset(seed=8)[1]
    assert not np.allclose(other["start"], runs[0][0])


def test_episodes_respect_min_distance_and_free_space():
    env = gym.make("sfa_gym/OmniRoverNavObstacles-v0", feature_field=None, min_distance=2.0)
    occupancy = env.unwrapped.occupancy
    for seed in range(10):
        _, info = env.reset(seed=seed)
        assert info["shortest_path"] >= 2.0
        assert occupancy.is_free(np.array([info["start"][:2], info["goal"][:2]])).all()


def test_stop_near_the_goal_succeeds_and_far_from_it_fails():
    env = gym.make("sfa_gym/OmniRoverNav-v0", feature_field=_position_field())
    _, info = env.reset(options={"start": (0.0, 0.0, 0.0), "goal": (0.2, 0.0, 1.0)})
    _, reward, terminated, _, info = env.step(np.array([0, 0, 1], np.float32))
    assert terminated and info["success"] and reward >= 1.0
    env.reset(options={"start": (0.0, 0.0, 0.0), "goal": (2.0, 0.0, 1.0)})
    _, reward, terminated, _, info = env.step(np.array([0, 0, 1], np.float32))
    assert terminated and not info["success"] and reward < 1.0


def test_without_stop_action_the_episode_ends_on_arrival():
    env = gym.make("sfa_gym/OmniRoverNav-v0", feature_field=_position_field(), stop_action=False)
    assert env.action_space.shape == (2,)
    env.reset(options={"start": (0.0, 0.0, 0.0), "goal": (0.8, 0.0, 0.0)})
    for _ in range(60):
        _, _, terminated, _, info = env.step(np.array([0.3, 0.0], np.float32))
        if terminated:
            break
    assert terminated and info["success"]
    assert 0.5 - 0.05 <= info["x"] <= 0.8  # arrived at the radius (0.3 m), not before


def test_geodesic_reward_sums_to_the_distance_covered():
    env = gym.make("sfa_gym/OmniRoverNav-v0", feature_field=_position_field())
    env.reset(options={"start": (-1.0, 0.0, 0.0), "goal": (2.0, 0.0, 0.0)})
    total = 0.0
    for _ in range(20):
        _, reward, _, _, info = env.step(np.array([0.4, 0.0, -1], np.float32))
        total += reward
    assert total == pytest.approx(3.0 - info["geodesic_distance"], abs=1e-9)
    assert total > 0.5


def test_odometry_tracks_the_ground_truth_over_a_short_drive():
    env = gym.make("sfa_gym/OmniRoverNav-v0", feature_field=_position_field())
    env.reset(options={"start": (-2.0, -2.0, 0.3), "goal": (2.0, 2.0, 0.0)})
    for k in range(40):
        _, _, _, _, info = env.step(np.array([0.3, 0.4 if k < 20 else -0.4, -1], np.float32))
    x0, y0, yaw0 = -2.0, -2.0, 0.3
    truth = np.array([info["x"] - x0, info["y"] - y0])
    c, s = math.cos(-yaw0), math.sin(-yaw0)
    truth = np.array([c * truth[0] - s * truth[1], s * truth[0] + c * truth[1]])
    odo = info["odometry"]
    assert np.linalg.norm(truth) > 1.0
    assert np.linalg.norm(odo[:2] - truth) < 0.1 * np.linalg.norm(truth)
    assert abs(math.remainder(odo[2] - (info["yaw"] - yaw0), math.tau)) < 0.15


def test_driving_into_a_wall_counts_a_collision_and_the_range_sensor_sees_it():
    env = gym.make("sfa_gym/OmniRoverNav-v0", feature_field=_position_field())
    _, info = env.reset(options={"start": (2.3, 0.0, 0.0), "goal": (-2.0, 0.0, 0.0)})
    ahead = env.unwrapped.range_angles == 0
    assert info["range"][ahead][0] < 1.5  # the wall is 1.2 m ahead of the centre
    for _ in range(40):
        _, _, _, _, info = env.step(np.array([0.4, 0.0, -1], np.float32))
    assert info["collisions"] >= 1
    assert info["range"][ahead][0] < 0.4


def test_bad_options_and_arguments_are_refused():
    env = gym.make("sfa_gym/OmniRoverNav-v0", feature_field=_position_field())
    with pytest.raises(ValueError, match="not in free space"):
        env.reset(options={"start": (9.0, 0.0, 0.0)})
    with pytest.raises(ValueError, match="unknown reset options"):
        env.reset(options={"pose": (0.0, 0.0, 0.0)})
    with pytest.raises(ValueError, match="reward"):
        gym.make("sfa_gym/OmniRoverNav-v0", reward="dense")
    with pytest.raises(ValueError, match="success_radius"):
        gym.make("sfa_gym/OmniRoverNav-v0", success_radius=0)


def _layout(obstacles=()):
    return SimpleNamespace(bounds=(-3.0, 3.0, -3.0, 3.0), obstacles=tuple(obstacles))


def test_geodesic_equals_the_straight_line_in_the_open_arena():
    grid = OccupancyGrid.from_layout(_layout(), rover_radius=0.35)
    rng = np.random.default_rng(0)
    for _ in range(20):
        a, b = rng.uniform(-3, 3, (2, 2))
        assert grid.shortest_path_length(a, b) == pytest.approx(np.linalg.norm(a - b), abs=1e-9)


def test_geodesic_goes_around_an_obstacle():
    # a post of radius 0.4 grown by 0.35: the path hugs a circle of radius 0.75
    grid = OccupancyGrid.from_layout(_layout([(0.0, 0.0, 0.4)]), rover_radius=0.35)
    a, b = np.array([-2.0, 0.0]), np.array([2.0, 0.0])
    r, d = 0.75, 2.0
    exact = 2 * math.sqrt(d * d - r * r) + r * (math.pi - 2 * math.acos(r / d))
    got = grid.shortest_path_length(a, b)
    assert got > 4.0
    assert exact - 0.01 <= got <= exact + 1.5 * grid.resolution
    path = grid.geodesic(b).path(a)
    assert np.all(np.linalg.norm(path, axis=1) >= r - grid.resolution)
    assert np.sum(np.linalg.norm(np.diff(path, axis=0), axis=1)) == pytest.approx(got)


def test_oracle_reaches_every_goal_and_random_rarely_does():
    env = gym.make("sfa_gym/OmniRoverNavObstacles-v0", feature_field=_position_field())
    oracle = run_episodes(env, OracleController.for_env(env), range(8), progress=False)
    assert all(e["success"] for e in oracle), [e["final_distance"] for e in oracle]
    assert summarize(oracle)["all"]["spl"]["mean"] > 0.8
    random = run_episodes(env, RandomController.for_env(env), range(8), progress=False)
    assert np.mean([e["success"] for e in random]) <= 0.25
