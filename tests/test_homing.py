"""Panoramic homing: a controller that declares ``Capabilities(panoramas=True)`` gets real
renders of the current and goal panorama (also in a worker process) and no pose; the image
difference falls towards the goal; the shipped homing controllers beat a random driver; bad
arguments are refused by name."""

from __future__ import annotations

import math
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import sfa_gym  # noqa: F401  (registers the envs)
from sfa_gym.capabilities import Capabilities
from sfa_gym.navigation.controllers import RandomController
from sfa_gym.navigation.evaluate import run_episode, run_episodes
from sfa_gym.navigation.field import FeatureField
from sfa_gym.navigation.homing import as_image, heading_difference, rotational_difference
from sfa_gym.navigation.sensors import ROVER_SENSORS, Rover, SensorsOnly
from sfa_gym.plugins import load_controller_plugin

ROOT = Path(__file__).resolve().parents[1]
CONTROLLERS = ROOT / "baselines" / "controllers"
HOMING = ("image_difference", "average_landmark_vector", "min_warping")
ENV_ID = "sfa_gym/OmniRoverNav-v0"
BOUNDS = (-3.0, 3.0, -3.0, 3.0)  # the open arena's drivable area


def _blank_field() -> FeatureField:
    """Features that say nothing (zeros everywhere): the env steps physics only, and what a
    controller learns of where it is comes from the panoramas."""
    return FeatureField(np.zeros((13, 13, 1)), BOUNDS)


class Spy:
    """Drives straight for ``steps`` steps, then stops; keeps what it was given."""

    name = "spy"

    def __init__(self, panoramas: bool, steps: int = 6) -> None:
        if panoramas:
            self.capabilities = Capabilities(panoramas=True)
        self.steps, self.seen = steps, []

    def reset(self, obs, info):
        self.seen = [(dict(obs), dict(info))]

    def act(self, obs, info):
        self.seen.append((dict(obs), dict(info)))
        stop = 1.0 if len(self.seen) > self.steps else -1.0
        return np.array([0.3, 0.0, stop], dtype=np.float32)


def test_a_panorama_controller_gets_real_renders_and_no_pose():
    env = gym.make(ENV_ID, feature_field=_blank_field())
    pixels = gym.make(ENV_ID)  # the env that observes panoramas itself, for the same seed
    try:
        spy = SensorsOnly(Spy(panoramas=True))
        episode = run_episode(env, spy, seed=7)
        blind = SensorsOnly(Spy(panoramas=False))
        blind_episode = run_episode(env, blind, seed=7)
        own, _ = pixels.reset(seed=7)
    finally:
        env.close()
        pixels.close()
    seen = spy.controller.seen
    for obs, info in seen:
        assert set(obs) == {"features", "goal_features", "panorama", "goal_panorama"}
        assert set(info) == set(ROVER_SENSORS)  # no pose, no goal: the rover's own sensors
        for key in ("panorama", "goal_panorama"):
            assert obs[key].dtype == np.uint8 and obs[key].shape == (40, 350, 3)
    # the goal's panorama is the env's own render at the goal, rendered once
    assert np.array_equal(seen[0][0]["goal_panorama"], own["goal"])
    assert np.array_equal(seen[0][0]["panorama"], own["panorama"])
    assert all(obs["goal_panorama"] is seen[0][0]["goal_panorama"] for obs, _ in seen)
    # the panorama changes as the rover drives: more the further it has gone
    first = seen[0][0]["panorama"].astype(float)
    change = [np.abs(obs["panorama"] - first).mean() for obs, _ in seen[2:]]  # [1]: same obs
    assert 0 < change[0] < change[-1]
    # without the capability nothing is rendered, and the physics is the same either way
    assert all("panorama" not in obs for obs, _ in blind.controller.seen)
    assert np.array_equal(episode["path"], blind_episode["path"])


SPY_PLUGIN = """
from dataclasses import dataclass
import numpy as np
from sfa_gym.capabilities import Capabilities

@dataclass(frozen=True)
class Args:
    pass

class Spy:
    name = "spy"
    capabilities = Capabilities(panoramas=True)
    def reset(self, obs, info):
        pass
    def act(self, obs, info):
        # reports what crossed: the shapes of the panoramas, their checksums and the keys
        p, g = obs["panorama"], obs["goal_panorama"]
        keys = sorted(obs) + sorted(info)
        return np.array([*p.shape, *g.shape, int(p.sum()), int(g.sum()), len(keys),
                         int(keys == ["features", "goal_features", "goal_panorama", "panorama",
                                      "odometry", "range"])])

def make_controller(rover, weights):
    return Spy()
"""


def test_panoramas_cross_to_an_isolated_controller_as_arrays(tmp_path):
    from sfa_gym.sandbox import IsolatedController

    path = tmp_path / "spy.py"
    path.write_text(SPY_PLUGIN)
    env = gym.make(ENV_ID, feature_field=_blank_field())
    rover = Rover.of(env)
    try:
        with IsolatedController(path, rover, [1.0]) as isolated:
            assert isolated.capabilities.panoramas  # declared in the worker, reported back
            obs, info = env.reset(seed=3)
            goal = env.unwrapped.render_panorama(info["goal"])
            obs = {**obs, "panorama": env.unwrapped.render_panorama(), "goal_panorama": goal}
            isolated.reset(obs, info)
            found = isolated.act(obs, info)
    finally:
        env.close()
    p, g = obs["panorama"], obs["goal_panorama"]
    assert found.tolist() == [*p.shape, *g.shape, int(p.sum()), int(g.sum()), 6, 1]


def _panorama(env, x, y, yaw):
    return env.unwrapped.render_panorama((x, y, yaw))


def test_the_image_difference_falls_along_a_straight_drive_to_the_goal():
    """What image-difference descent relies on: the difference to the goal's panorama, at the
    best alignment (whatever the headings), shrinks as the rover comes closer, over metres."""
    env = gym.make(ENV_ID)
    rng = np.random.default_rng(0)
    try:
        for _ in range(3):
            goal, direction = rng.uniform(-1.0, 1.0, 2), rng.uniform(-math.pi, math.pi)
            goal_yaw = rng.uniform(-math.pi, math.pi)
            goal_image = as_image(_panorama(env, *goal, goal_yaw), False, 2.0)
            differences = []
            for distance in (1.5, 1.0, 0.5, 0.25):
                x, y = goal + distance * np.array([math.cos(direction), math.sin(direction)])
                yaw = rng.uniform(-math.pi, math.pi)
                image = as_image(_panorama(env, x, y, yaw), False, 2.0)
                difference, shift = rotational_difference(image, goal_image)
                differences.append(difference)
                # the best alignment is the visual compass, the heading difference (within a
                # metre: further out a turned view of elsewhere can match better)
                turn = heading_difference(shift, 350) - (yaw - goal_yaw)
                error = (turn + math.pi) % math.tau - math.pi
                assert distance > 1.0 or abs(error) < math.radians(12), (distance, error)
            assert np.all(np.diff(differences) < 0), differences
    finally:
        env.close()


def _near_seeds(env, n: int, farthest: float) -> list[int]:
    """The first ``n`` episode seeds whose start is at most ``farthest`` m from the goal."""
    found = []
    for seed in range(50000, 50200):
        _, info = env.reset(seed=seed)
        if info["shortest_path"] <= farthest:
            found.append(seed)
        if len(found) == n:
            return found
    raise AssertionError("too few near episodes")


@pytest.mark.parametrize("name", HOMING)
def test_a_homing_controller_reaches_goals_a_random_driver_does_not(name):
    env = gym.make(ENV_ID, feature_field=_blank_field())
    try:
        seeds = _near_seeds(env, 4, 2.0)
        homing = load_controller_plugin(CONTROLLERS / f"{name}.py")(Rover.of(env), [1.0])
        episodes = run_episodes(env, homing, seeds, progress=False)
        randomly = run_episodes(env, RandomController.for_env(env), seeds, progress=False)
    finally:
        env.close()
    start = np.array([e["shortest_path"] for e in episodes])
    final = np.array([e["final_distance"] for e in episodes])
    successes = sum(e["success"] for e in episodes)
    assert successes > sum(e["success"] for e in randomly)
    assert successes >= 2 and np.mean(final < start) >= 0.75


ROVER = Rover(v_max=0.4, w_max=1.0, dt=0.1, range_angles=(0.0,))


@pytest.mark.parametrize(
    ("name", "args", "message"),
    [
        ("image_difference", {"min_run": 0.5}, r"need 0 < min_run <= run, got min_run=0.5"),
        ("image_difference", {"speed": 2.0}, r"speed must be in \(0, v_max=0.4\]"),
        ("image_difference", {"blur": -1.0}, "blur must be >= 0 pixels, got -1.0"),
        ("image_difference", {"colour": "yes"}, "argument colour must be bool, got 'yes'"),
        ("average_landmark_vector", {"band": [0.6, 0.5]}, r"band must be \(from, to\)"),
        ("average_landmark_vector", {"dark": 1.5}, r"dark must be in \(0, 1\), got 1.5"),
        ("average_landmark_vector", {"stop_steps": 0}, "stop_steps must be >= 1, got 0"),
        ("min_warping", {"directions": 0}, "directions must be >= 1, got 0"),
        ("min_warping", {"stop_fraction": 1.0}, r"stop_fraction must be in \[0, 1\), got 1.0"),
    ],
)
def test_bad_arguments_are_refused_by_name(name, args, message):
    with pytest.raises(ValueError, match=message):
        load_controller_plugin(CONTROLLERS / f"{name}.py")(ROVER, [1.0], args)


@pytest.mark.parametrize("name", HOMING)
def test_a_homing_controller_without_panoramas_says_what_is_missing(name):
    controller = load_controller_plugin(CONTROLLERS / f"{name}.py")(ROVER, [1.0])
    obs = {"panorama": np.zeros((40, 350, 3)), "goal_panorama": np.zeros((40, 350, 3))}
    with pytest.raises(ValueError, match=r'obs\["goal_panorama"\] must be a panorama'):
        controller.reset(obs, {"odometry": np.zeros(3), "range": np.ones(1)})
