"""The slow-feature-gradient controller: its weights, what it may read, and that it reaches goals
on the features of a really fitted (small) hierarchical SFA, read from a coarse feature field."""

from __future__ import annotations

import math
import warnings

import gymnasium as gym
import numpy as np
import pytest

import sfa_gym  # noqa: F401  (registers the ids)
from sfa_gym.cli.navigate import NavigationExperiment
from sfa_gym.features import rotation_averaged_features
from sfa_gym.navigation.controllers import GradientController, GradientSettings, slowness_weights
from sfa_gym.navigation.evaluate import run_episode
from sfa_gym.navigation.field import FeatureField
from sfa_gym.protocols.navigation import training_run
from sfa_gym.recording.cache import RunCache
from sfa_gym.sfa import HierarchicalSFA, RankDeficiencyWarning, presets
from sfa_gym.sim.env import OmniRoverEnv

# what a real rover has: its features, wheel odometry and range sensor, and the episode's clock
OWN_SENSES = {"odometry", "range", "t"}


def test_slowness_weights_known_answer():
    t = np.arange(2000)
    omega = np.array([4, 32]) * 2 * np.pi / len(t)  # whole periods: the variance is A^2 / 2
    sequence = np.column_stack([3 * np.sin(omega[0] * t), np.sin(omega[1] * t)])
    # slowness of a sinusoid: mean squared step A^2 (1 - cos omega) over the variance A^2 / 2
    delta = 2 * (1 - np.cos(omega))
    for power in (1.0, 2.0):
        w = slowness_weights(sequence, power)
        expected = delta**-power / np.array([9 * 0.5, 0.5])
        np.testing.assert_allclose(w, expected, rtol=0.01)
    # power 2 favours the slow feature more than power 1 does
    w1, w2 = slowness_weights(sequence, 1.0), slowness_weights(sequence, 2.0)
    assert (w2[0] * 9) / w2[1] > 50 * (w1[0] * 9) / w1[1]


@pytest.mark.parametrize(
    ("sequence", "power", "match"),
    [
        (np.zeros((5,)), 2.0, r"\(T, k\)"),
        (np.column_stack([np.arange(5.0), np.ones(5)]), 2.0, "does not change"),
        (np.random.default_rng(0).normal(size=(10, 2)), 0.0, "power must be a positive"),
    ],
)
def test_slowness_weights_refuse_bad_input(sequence, power, match):
    with pytest.raises(ValueError, match=match):
        slowness_weights(sequence, power)


def test_controller_refuses_bad_arguments():
    with pytest.raises(ValueError, match="weights"):
        GradientController([1.0, -1.0])
    with pytest.raises(ValueError, match="stop_curvature must be 'flattest' or 'mean', got 'max'"):
        GradientController([1.0], settings=GradientSettings(stop_curvature="max"))
    with pytest.raises(ValueError, match="memory must be a positive number, got -0.5"):
        GradientController([1.0], settings=GradientSettings(memory=-0.5))
    with pytest.raises(ValueError, match="probe_leg must be a finite number >= 0, got nan"):
        GradientController([1.0], settings=GradientSettings(probe_leg=float("nan")))
    with pytest.raises(ValueError, match="search_found must be in"):
        GradientController([1.0], settings=GradientSettings(search_found=1.5))


def test_navigation_experiment_checks_the_controller_settings():
    bad = NavigationExperiment(gradient=GradientSettings(stop_window=0))
    with pytest.raises(ValueError, match="stop_window must be a positive int, got 0"):
        bad.validate()


@pytest.fixture(scope="module")
def trained(tmp_path_factory):
    """Hierarchical SFA (small) fitted on a 14 x 14 grid in Hilbert order, its slowness weights,
    and its feature field at 0.3 m."""
    nav = gym.make("sfa_gym/OmniRoverNav-v0").unwrapped
    camera = OmniRoverEnv(nav.world, nav.world_seed, nav.panorama)
    runs = RunCache(tmp_path_factory.mktemp("renders"))
    train = training_run(NavigationExperiment(train_grid=14), nav, runs).sequence
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RankDeficiencyWarning)
        model = HierarchicalSFA(
            presets.paper_sim(dim=8, out_dim=8), n_outputs=8, weight_sharing="rows", progress=False
        ).fit_rotations(train, step=5)
        weights = slowness_weights(rotation_averaged_features(model, train, step=1))
        field = FeatureField.build(camera, model, spacing=0.3, progress=False)
    camera.close()
    return weights, field


@pytest.mark.parametrize(
    ("start", "goal"),
    [((-1.5, -1.2, 0.5), (1.3, 1.1, 0.0)), ((1.6, -1.0, 2.5), (-1.2, 1.4, 0.0))],
)
def test_gradient_controller_reaches_a_goal_with_its_own_senses(trained, start, goal):
    weights, field = trained
    env = gym.make("sfa_gym/OmniRoverNav-v0", feature_field=field)
    controller = GradientController.for_env(env, weights)
    obs, info = env.reset(seed=0, options={"start": start, "goal": goal})
    controller.reset(obs, {k: info[k] for k in OWN_SENSES})
    for _ in range(600):
        # the controller never sees the ground truth: only its own senses are passed on
        obs, _, terminated, truncated, info = env.step(
            controller.act(obs, {k: info[k] for k in OWN_SENSES})
        )
        if terminated or truncated:
            break
    assert info["success"], (info["x"], info["y"], info["geodesic_distance"])
    assert info["path_length"] < 2.0 * info["shortest_path"]
    assert info["collisions"] == 0


def test_gradient_controller_is_deterministic(trained):
    weights, field = trained
    env = gym.make("sfa_gym/OmniRoverNav-v0", feature_field=field)
    runs = [run_episode(env, GradientController.for_env(env, weights), seed=3) for _ in range(2)]
    np.testing.assert_array_equal(runs[0]["path"], runs[1]["path"])


def test_search_spiral_grows_ends_on_a_lower_cost_and_avoids_what_is_ahead():
    angles = np.linspace(-math.pi / 2, math.pi / 2, 7)
    controller = GradientController(np.ones(2), angles)
    controller.reset({}, {})
    s = controller.settings
    open_ranges = np.full(7, 2.0)
    controller._search = (0.0, 100.0, 1.0)  # started at odometer 0 m, best cost 100, turning left
    radii = []
    for travelled in (0.0, 1.0, 3.0):
        # an Archimedean spiral: r^2 = r0^2 + pitch * d / pi
        expected = math.sqrt(s.search_start**2 + s.search_pitch * travelled / math.pi)
        controller._v = min(s.speed, 0.9 * expected)  # the acceleration limit not in the way
        v, w, stop = controller._spiral(90.0, travelled, open_ranges, yaw=0.0)
        assert v > 0 and w > 0 and stop < 0
        radii.append(v / w)
        assert v / w == pytest.approx(expected, rel=1e-3)
    assert radii[0] < radii[1] < radii[2]
    # a wall close ahead and to the left: the spiral turns right, away from it
    walled = open_ranges.copy()
    walled[3:] = 0.35
    controller._v = 0.3
    _, w, _ = controller._spiral(90.0, 1.0, walled, yaw=0.0)
    assert w < 0
    # a cost below search_found of the best before it ends the search
    assert controller._spiral(s.search_found * 100.0 - 1.0, 1.0, open_ranges, 0.0) is None
    assert controller._search is None


def test_a_parked_rover_searches_far_from_the_goal_and_a_moving_one_does_not():
    # features linear in the position, the goal's 10 m away: far beyond slow_distance
    controller = GradientController(np.ones(2), np.linspace(-math.pi / 2, math.pi / 2, 7))
    s = controller.settings
    goal = {"goal_features": np.array([10.0, 0.0])}
    ranges = np.full(7, 2.0)

    def sense(x, y):
        obs = {"features": np.array([x, y]), **goal}
        return obs, {"odometry": (x, y, 0.0), "range": ranges}

    controller.reset(*sense(0.0, 0.0))
    # an L of two 0.3 m legs, 1 cm a step: moving, with no tenth off the cost (100 -> 94)
    path = [(0.01 * i, 0.0) for i in range(31)] + [(0.3, 0.01 * i) for i in range(1, 31)]
    for x, y in path:
        controller.act(*sense(x, y))
    assert controller._t > s.search_after  # no progress for longer than search_after ...
    assert controller.mode == "descend"  # ... but it moved 0.6 m meanwhile: not stuck
    assert controller.estimate["distance"] > s.slow_distance
    # then it stays where it is (turning on the spot against a wall, say)
    modes = []
    for _ in range(round(s.search_after / controller.dt) + 2):
        controller.act(*sense(0.3, 0.3))
        modes.append(controller.mode)
    assert modes[0] == "descend" and modes[-1] == "search"
    # with searches=0 it never searches
    off = GradientSettings(searches=0)
    still = GradientController(np.ones(2), controller.range_angles, settings=off)
    still.reset(*sense(0.0, 0.0))
    for x, y in path + [(0.3, 0.3)] * 70:
        still.act(*sense(x, y))
        assert still.mode != "search"
