"""Simulated rotation: views equal the np.roll definition; the wrapper's contract."""

from __future__ import annotations

import doctest

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env
from hypothesis import given, settings
from hypothesis import strategies as st

import sfa_gym  # noqa: F401  (registers the envs)
import sfa_gym.rotation
import sfa_gym.wrappers
from sfa_gym.rotation import n_rotations, rotated_views
from sfa_gym.wrappers import SimulatedRotation

ENV_ID = "sfa_gym/OmniRover-v0"


def brute_force(panorama, step, window):
    width = panorama.shape[1]
    window = width if window is None else window
    views = [np.roll(panorama, -k * step, axis=1)[:, :window] for k in range(width // step)]
    phis = [2 * np.pi * k * step / width for k in range(width // step)]
    return np.stack(views), np.array(phis)


@pytest.mark.parametrize(
    ("height", "width", "step", "window"),
    [(40, 350, 5, None), (40, 350, 5, 70), (6, 60, 1, 1), (3, 12, 12, None), (5, 24, 4, 23)],
)
def test_views_equal_the_definition(height, width, step, window):
    panorama = np.random.default_rng(0).integers(0, 256, (height, width, 3), dtype=np.uint8)
    views, phis = rotated_views(panorama, step=step, window=window)
    expected_views, expected_phis = brute_force(panorama, step, window)
    np.testing.assert_array_equal(views, expected_views)
    np.testing.assert_allclose(phis, expected_phis, rtol=0, atol=1e-15)
    assert views.dtype == np.uint8 and phis.dtype == np.float64
    assert views.flags.c_contiguous and views.flags.writeable and views.flags.owndata
    assert not np.shares_memory(views, panorama)


@settings(max_examples=40, deadline=None)
@given(
    height=st.integers(1, 4),
    n_views=st.integers(1, 12),
    step=st.integers(1, 6),
    window_fraction=st.floats(0.0, 1.0),
    channels=st.integers(1, 3),
)
def test_views_equal_the_definition_for_any_shape(height, n_views, step, window_fraction, channels):
    width = n_views * step
    window = max(1, round(window_fraction * width))
    panorama = np.random.default_rng(width).random((height, width, channels))
    views, _ = rotated_views(panorama, step=step, window=window)
    np.testing.assert_array_equal(views, brute_force(panorama, step, window)[0])


def test_phis_match_the_camera_convention():
    # column c looks at azimuth 2*pi*c/W: view k starts at the column at azimuth phi_k
    width, step = 360, 5
    panorama = np.broadcast_to(np.arange(width, dtype=np.float64)[None, :, None], (2, width, 3))
    views, phis = rotated_views(panorama, step=step, window=10)
    np.testing.assert_allclose(2 * np.pi * views[:, 0, 0, 0] / width, phis)
    assert len(phis) == n_rotations(width, step) == 72
    np.testing.assert_allclose(np.degrees(phis[:4]), [0, 5, 10, 15])


@pytest.mark.parametrize(
    ("step", "window", "error", "message"),
    [
        (7, None, ValueError, "width 60 is not a multiple of step 7"),
        (0, None, ValueError, r"step must lie in \[1, 60\].*got 0"),
        (61, None, ValueError, r"step must lie in \[1, 60\].*got 61"),
        (5, 0, ValueError, r"window must lie in \[1, 60\].*got 0"),
        (5, 61, ValueError, r"window must lie in \[1, 60\].*got 61"),
        (2.5, None, TypeError, "step must be an int"),
        (5, 3.0, TypeError, "window must be an int"),
    ],
)
def test_bad_step_or_window_is_named(step, window, error, message):
    with pytest.raises(error, match=message):
        rotated_views(np.zeros((4, 60, 3), np.uint8), step=step, window=window)


def test_bad_panorama_and_width():
    with pytest.raises(ValueError, match=r"\(H, W, C\).*\(60, 3\)"):
        rotated_views(np.zeros((60, 3), np.uint8))
    with pytest.raises(ValueError, match="width must be a positive int"):
        n_rotations(0)
    with pytest.raises(ValueError, match="not a multiple"):
        n_rotations(350, 3)
    assert n_rotations(600) == 120


# ----------------------------------------------------------------------- the wrapper


@pytest.fixture(scope="module")
def raw_env():
    env = gym.make(ENV_ID)
    yield env
    env.close()


@pytest.mark.filterwarnings("ignore:.*different from the unwrapped version")  # checked on purpose
def test_wrapper_passes_check_env():
    env = SimulatedRotation(gym.make(ENV_ID).unwrapped, step=5, window=100)
    try:
        check_env(env, skip_render_check=True)
    finally:
        env.close()


def test_sequential_mode_cycles_through_the_views(raw_env):
    env = SimulatedRotation(gym.make(ENV_ID), step=70, window=35, mode="sequential")
    try:
        assert env.observation_space == gym.spaces.Box(0, 255, (40, 35, 3), np.uint8)
        action = np.array([0.2, 0.5], np.float32)
        obs, info = env.reset(seed=0, options={"pose": (0.5, -1.0, 0.3)})
        raw, raw_info = raw_env.reset(seed=0, options={"pose": (0.5, -1.0, 0.3)})
        indices = [info["phi_index"]]
        for _ in range(6):
            np.testing.assert_array_equal(
                obs, np.roll(raw, -info["phi_index"] * 70, axis=1)[:, :35]
            )
            assert info["phi"] == pytest.approx(2 * np.pi * info["phi_index"] * 70 / 350)
            assert (info["x"], info["y"], info["yaw"]) == (
                raw_info["x"], raw_info["y"], raw_info["yaw"]
            )  # fmt: skip
            obs, _, _, _, info = env.step(action)
            raw, _, _, _, raw_info = raw_env.step(action)
            indices.append(info["phi_index"])
        assert indices == [0, 1, 2, 3, 4, 0, 1]
        assert env.observation_space.contains(obs)
    finally:
        env.close()


def test_random_mode_draws_from_the_seeded_generator():
    env = SimulatedRotation(gym.make(ENV_ID), step=5, mode="random")

    def phis(seed):
        _, info = env.reset(seed=seed, options={"pose": (0.0, 0.0, 0.0)})
        out = [info["phi_index"]]
        for _ in range(5):
            out.append(env.step(np.zeros(2, np.float32))[4]["phi_index"])
        return out

    try:
        first = phis(3)
        assert first == phis(3)
        assert len(set(first)) > 2 and all(0 <= k < 70 for k in first)
        assert first != phis(4)
    finally:
        env.close()


def test_wrapper_rejects_non_panorama_spaces():
    class Vector(gym.Env):
        observation_space = gym.spaces.Box(-1, 1, (4,), np.float32)
        action_space = gym.spaces.Discrete(2)

    with pytest.raises(ValueError, match="SimulatedRotation needs a panorama"):
        SimulatedRotation(Vector())
    with pytest.raises(ValueError, match="SimulatedRotation: the panorama width 350"):
        SimulatedRotation(gym.make(ENV_ID).unwrapped, step=3)
    with pytest.raises(ValueError, match="SimulatedRotation mode"):
        SimulatedRotation(gym.make(ENV_ID).unwrapped, mode="spin")


@pytest.mark.parametrize("module", [sfa_gym.rotation, sfa_gym.wrappers])
def test_docstring_examples(module):
    failures, attempted = doctest.testmod(module, verbose=False)
    assert attempted >= 4 and failures == 0
