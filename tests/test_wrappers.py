"""SlowFeatureObservation on the real env with a real (tiny) fitted HierarchicalSFA."""

from __future__ import annotations

import doctest
import warnings
from functools import partial
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env as gym_check_env

import sfa_gym  # noqa: F401  (registers the env ids)
import sfa_gym.wrappers
from sfa_gym.plugins import load_method_plugin
from sfa_gym.rotation import rotated_views
from sfa_gym.sfa import HierarchicalSFA, RankDeficiencyWarning, presets
from sfa_gym.sim.camera import PanoramaSpec
from sfa_gym.wrappers import SlowFeatureObservation

BASELINES = Path(__file__).resolve().parents[1] / "baselines"
ENV_ID = "sfa_gym/OmniRover-v0"
SPEC = PanoramaSpec(width=40, height=10)  # small panoramas keep rendering and SFA cheap
N_OUTPUTS = 4


def _make_env() -> gym.Env:
    return gym.make(ENV_ID, panorama=SPEC)


@pytest.fixture(scope="module")
def panoramas() -> np.ndarray:
    """Panoramas rendered on a 4 x 4 grid of positions, all facing +x, (16, 10, 40, 3)."""
    env = _make_env()
    out = []
    for x in np.linspace(-2.0, 2.0, 4):
        for y in np.linspace(-2.0, 2.0, 4):
            obs, _ = env.reset(seed=0, options={"pose": (float(x), float(y), 0.0)})
            out.append(obs)
    env.close()
    return np.stack(out)


def _fit(panoramas: np.ndarray, window: int | None = None) -> HierarchicalSFA:
    with warnings.catch_warnings():
        # 16 locations are far too few for a full-rank top node; dropped directions are expected.
        warnings.simplefilter("ignore", RankDeficiencyWarning)
        model = HierarchicalSFA(presets.tiny(10, window or 40), n_outputs=N_OUTPUTS, progress=False)
        return model.fit_rotations(panoramas, step=5, window=window)


@pytest.fixture(scope="module")
def model(panoramas) -> HierarchicalSFA:
    return _fit(panoramas)


@pytest.fixture(scope="module")
def window_model(panoramas) -> HierarchicalSFA:
    """Fitted on rotation windows 16 columns wide (144 degrees)."""
    return _fit(panoramas, window=16)


def test_observations_are_the_models_features(model):
    env = SlowFeatureObservation(_make_env(), model)
    assert env.observation_space == gym.spaces.Box(-np.inf, np.inf, (N_OUTPUTS,), np.float32)
    obs, info = env.reset(seed=0, options={"pose": (0.5, -1.0, 0.3)})
    raw = _make_env()  # rendering is deterministic: the same pose gives the same panorama
    expected_panorama, _ = raw.reset(seed=0, options={"pose": (0.5, -1.0, 0.3)})
    assert obs.dtype == np.float32 and obs.shape == (N_OUTPUTS,)
    np.testing.assert_allclose(obs, model.transform(expected_panorama[None])[0], rtol=1e-6)
    assert set(info) >= {"x", "y", "yaw"}
    obs, *_ = env.step(np.array([0.2, 0.5], dtype=np.float32))
    assert env.observation_space.contains(obs)
    env.close()
    raw.close()


def test_average_rotations_is_the_mean_over_rotated_windows(window_model):
    env = SlowFeatureObservation(_make_env(), window_model, average_rotations=True, step=5)
    raw = _make_env()
    pose = {"pose": (-1.0, 1.5, 2.0)}
    obs, _ = env.reset(seed=0, options=pose)
    panorama, _ = raw.reset(seed=0, options=pose)
    views, phis = rotated_views(panorama, step=5, window=16)
    assert views.shape == (8, 10, 16, 3)
    np.testing.assert_allclose(obs, window_model.transform(views).mean(axis=0), rtol=1e-5)
    env.close()
    raw.close()


def test_averaged_features_barely_change_when_the_rover_turns(model):
    """Turning by one rotation step (5 of 40 columns) shifts the panorama by 5 columns, which the
    average over all rotations absorbs; a single view does not."""
    single = SlowFeatureObservation(_make_env(), model)
    averaged = SlowFeatureObservation(_make_env(), model, average_rotations=True)
    turn = 2 * np.pi * 5 / 40
    changes = []
    for env in (single, averaged):
        a, _ = env.reset(seed=0, options={"pose": (1.0, 0.5, 0.0)})
        b, _ = env.reset(seed=0, options={"pose": (1.0, 0.5, turn)})
        changes.append(np.abs(a - b).max())
        env.close()
    assert changes[1] < 0.25 * changes[0], changes


def test_a_fitted_baseline_method_is_a_feature_model(panoramas):
    """A rotation-invariant method gives the same observation with and without averaging."""
    method = load_method_plugin(BASELINES / "band_means.py")().fit(panoramas)
    single = SlowFeatureObservation(_make_env(), method)
    averaged = SlowFeatureObservation(_make_env(), method, average_rotations=True)
    assert single.observation_space.shape == (24,)
    a, _ = single.reset(seed=0, options={"pose": (0.2, 0.4, 1.0)})
    b, _ = averaged.reset(seed=0, options={"pose": (0.2, 0.4, 1.0)})
    np.testing.assert_allclose(a, b, rtol=1e-6)
    single.close()
    averaged.close()


def test_gymnasium_and_sb3_env_checkers_pass(model):
    from stable_baselines3.common.env_checker import check_env as sb3_check_env

    for average in (False, True):
        env = SlowFeatureObservation(_make_env(), model, average_rotations=average)
        with warnings.catch_warnings():
            # Both checkers warn about wrapped envs and unbounded Box observations; only
            # failures matter here.
            warnings.simplefilter("ignore")
            gym_check_env(env, skip_render_check=True)
            sb3_check_env(env, warn=False)
        env.close()


def test_vector_env_wraps_each_copy(model):
    envs = gym.make_vec(
        ENV_ID,
        num_envs=2,
        vectorization_mode="sync",
        wrappers=[partial(SlowFeatureObservation, model=model)],
        panorama=SPEC,
    )
    assert envs.single_observation_space.shape == (N_OUTPUTS,)
    obs, infos = envs.reset(seed=[1, 2])
    assert obs.shape == (2, N_OUTPUTS) and obs.dtype == np.float32
    assert not np.allclose(obs[0], obs[1])  # two random starting poses
    obs, *_ = envs.step(np.zeros((2, 2), dtype=np.float32))
    assert obs.shape == (2, N_OUTPUTS)
    envs.close()


def test_mismatched_panorama_shape_is_refused_clearly(model, window_model):
    big = gym.make(ENV_ID, panorama=PanoramaSpec(width=80, height=10))
    with pytest.raises(ValueError, match=r"SlowFeatureObservation.*\(10, 80, 3\).*\(10, 40, 3\)"):
        SlowFeatureObservation(big, model)
    with pytest.raises(ValueError, match=r"\(10, 16, 3\).*use average_rotations=True"):
        SlowFeatureObservation(_make_env(), window_model)
    taller = gym.make(ENV_ID, panorama=PanoramaSpec(width=40, height=12))
    with pytest.raises(ValueError, match=r"average_rotations=True.*\(10, 16, 3\).*\(12, 40, 3\)"):
        SlowFeatureObservation(taller, window_model, average_rotations=True)
    with pytest.raises(ValueError, match=r"step=7.*not a multiple of step 7"):
        SlowFeatureObservation(_make_env(), model, average_rotations=True, step=7)
    for env in (big, taller):
        env.close()


def test_wrong_spaces_and_models_are_refused_clearly(model):
    with pytest.raises(TypeError, match=r"SlowFeatureObservation.*Box.*Discrete"):
        SlowFeatureObservation(gym.make("FrozenLake-v1"), model)
    with pytest.raises(ValueError, match=r"SlowFeatureObservation.*\(4,\).*float32"):
        SlowFeatureObservation(gym.make("CartPole-v1"), model)
    unfitted = HierarchicalSFA(presets.tiny(10, 40), n_outputs=N_OUTPUTS, progress=False)
    with pytest.raises(TypeError, match="fitted feature model.*is it fitted"):
        SlowFeatureObservation(_make_env(), unfitted)
    with pytest.raises(TypeError, match="average_rotations must be a bool"):
        SlowFeatureObservation(_make_env(), model, average_rotations="yes")


def test_docstring_example_runs():
    result = doctest.testmod(sfa_gym.wrappers, optionflags=doctest.ELLIPSIS)
    assert result.attempted >= 5 and result.failed == 0
