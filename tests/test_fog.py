"""Fog by Koschmieder's law: the transmission of each pixel from its depth, the airlight from the
daylight, the outdoor env seen through fog (far things fade first, the sky turns to airlight)
and the outdoor protocol's fog condition."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from sfa_gym.protocols.outdoor import Config
from sfa_gym.sim.camera.fog import apply_fog, check_visibility, ray_lengths
from sfa_gym.sim.camera.sensor import SensorSpec
from sfa_gym.sim.env import OmniRoverEnv
from sfa_gym.sim.worlds import load_world_spec

QUIET = {"clock": False, "clouds": False, "movers": False}
ZNEAR, ZFAR = 0.2, 400.0


def _window_depth(eye_depth):
    """The depth buffer's value of an eye depth (the perspective projection's)."""
    return (ZFAR - ZNEAR * ZFAR / np.asarray(eye_depth, np.float64)) / (ZFAR - ZNEAR)


def test_at_the_visibility_a_black_object_keeps_two_percent_contrast():
    distances = np.array([[1.0, 50.0, 100.0, 300.0]])
    buffer = np.zeros((1, 4, 3), np.uint8)  # black objects
    air = np.array([200.0, 200.0, 200.0])
    depth = _window_depth(distances).astype(np.float32)
    apply_fog(buffer, depth, np.ones((1, 4), np.float32), ZNEAR, ZFAR, 100.0, air)
    expected = 200.0 * (1.0 - np.exp(-3.912 * distances[0] / 100.0))
    np.testing.assert_allclose(buffer[0, :, 0], np.rint(expected), atol=1.0)
    assert math.isclose(1.0 - buffer[0, 2, 0] / 200.0, 0.02, abs_tol=0.006)  # at V: 2 %
    # a surface as bright as the fog does not change at any distance
    bright = np.full((1, 4, 3), 200, np.uint8)
    apply_fog(bright, depth, np.ones((1, 4), np.float32), ZNEAR, ZFAR, 100.0, air)
    assert np.all(bright == 200)


def test_ray_lengths_grow_towards_the_views_corners():
    lengths = ray_lengths(8, 4, [(0, 0, 4, 4), (4, 0, 4, 4)], focal=2.0)
    assert lengths.shape == (4, 8)
    np.testing.assert_allclose(lengths[:, :4], lengths[:, 4:])  # every view alike
    np.testing.assert_allclose(lengths[1, 1], math.sqrt(1 + 2 * 0.25**2), rtol=1e-6)
    np.testing.assert_allclose(lengths[0, 0], math.sqrt(1 + 2 * 0.75**2), rtol=1e-6)


@pytest.mark.parametrize("bad", [0.0, -5.0, math.inf, math.nan, "far", True])
def test_a_bad_visibility_is_named(bad):
    with pytest.raises(ValueError, match="visibility_m must be a distance > 0 m"):
        check_visibility(bad)
    declared = load_world_spec("paper_outdoor").dynamics
    with pytest.raises(ValueError, match="visibility_m"):
        dataclasses.replace(declared, visibility_m=bad)
    with pytest.raises(ValueError, match="visibility_m"):
        Config(fog_visibility_m=bad).validate()


def _frame(visibility_m):
    declared = load_world_spec("paper_outdoor").dynamics
    env = OmniRoverEnv(
        world="paper_outdoor",
        camera="cylindrical",
        mirror=None,
        panorama="paper_sim",
        dynamics=dataclasses.replace(declared, visibility_m=visibility_m, **QUIET),
        sensor=SensorSpec(auto_exposure=False, noise=False),
    )
    try:
        return env.reset(seed=0, options={"pose": (0.0, 0.0, 0.0)})[0].astype(float)
    finally:
        env.close()


def test_the_outdoor_world_through_fog_fades_with_distance():
    clear, foggy = _frame(None), _frame(30.0)
    change = np.abs(foggy - clear).mean(axis=(1, 2))  # per row
    # the rows above the horizon look at buildings, trees and sky 10-400 m away, the bottom
    # rows at the asphalt about 3 m away (transmission 0.7 at a visibility of 30 m)
    assert change[: len(change) // 2].mean() > 2 * change[-5:].mean() > 0
    # clear air is no fog; fog thicker than the nearest surface is the airlight everywhere
    assert np.abs(_frame(1e9) - clear).max() <= 1.0
    thick = _frame(0.01)
    assert np.ptp(thick, axis=(0, 1)).max() <= 1.0


def test_the_fog_condition_is_an_overcast_day_in_fog():
    config = Config(conditions=("after", "fog"), fog_visibility_m=80.0)
    assert config.test_conditions == ("after", "fog")
    declared = load_world_spec("paper_outdoor").dynamics
    hour = config.env_kwargs("fog", 0)["dynamics"].start_hour
    expected = dataclasses.replace(declared, overcast=1.0, visibility_m=80.0, start_hour=hour)
    assert config.env_kwargs("fog", 0)["dynamics"] == expected
    # the other conditions keep clear air
    assert config.env_kwargs("after", 0)["dynamics"].visibility_m is None
