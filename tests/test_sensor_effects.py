"""The camera's optional effects: auto white balance and a mirror camera's vignetting."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sfa_gym.sim.camera import MirrorSpec
from sfa_gym.sim.camera.mirror import vignetting_gain
from sfa_gym.sim.camera.sensor import Sensor, SensorSpec
from sfa_gym.sim.env import OmniRoverEnv

QUIET = {"clock": False, "clouds": False, "movers": False}


def test_white_balance_greys_a_tinted_scene_with_the_exposures_lag():
    sensor = Sensor(SensorSpec(noise=False, auto_exposure=False, white_balance=True, tau_s=1.0))
    grey = np.full((4, 8, 3), 90, np.uint8)
    sensor.reset(grey)
    np.testing.assert_allclose(sensor.balance, 1.0)
    evening = np.empty((4, 8, 3), np.uint8)
    evening[...] = (120, 90, 60)  # a warm light: red up, blue down
    rng = np.random.default_rng(0)
    first = sensor.process(evening, 0.1, rng)[0, 0].astype(int)
    for _ in range(80):
        last = sensor.process(evening, 0.1, rng)[0, 0].astype(int)
    assert first[0] > first[1] > first[2]  # the tint first passes
    assert np.abs(last - 90).max() <= 1  # then the grey world's gains take it out
    # a tint beyond the gains' range is only partly taken out
    sensor.reset(np.full((4, 8, 3), (200, 20, 20), np.uint8))
    np.testing.assert_allclose(sensor.balance, [0.5, 2.0, 2.0])


def test_white_balance_needs_colour_and_bad_settings_are_named():
    sensor = Sensor(SensorSpec(white_balance=True))
    with pytest.raises(ValueError, match=r"RGB images \(\.\.\., 3\), got shape \(4, 4\)"):
        sensor.reset(np.ones((4, 4), np.uint8))
    with pytest.raises(ValueError, match="vignetting must be a number in \\[0, 1\\), got 1.0"):
        SensorSpec(vignetting=1.0)
    with pytest.raises(ValueError, match="white_balance_range must be"):
        SensorSpec(white_balance_range=(1.5, 2.0))
    with pytest.raises(ValueError, match="needs the camera's falloff map"):
        Sensor(SensorSpec(vignetting=0.3))


def test_vignetting_follows_the_cos4_law_and_loses_its_share_at_the_rim():
    spec = MirrorSpec.paper_outdoor()
    circular = vignetting_gain(spec, 0.3, circular=True)
    v, u = np.mgrid[0 : spec.image_size, 0 : spec.image_size]
    radius = np.hypot(u - spec.cx, v - spec.cy)
    rim = spec.disc_radii[1]
    at_rim = circular[np.abs(radius - rim) < 0.5]
    np.testing.assert_allclose(at_rim, 0.7, atol=2e-3)
    assert (
        circular[np.argmin(radius) // spec.image_size, np.argmin(radius) % spec.image_size] > 0.999
    )
    # the unwarped panorama: its top row lies nearer the rim (higher elevation), so it is darker
    panorama = vignetting_gain(spec, 0.3)
    assert panorama.shape == spec.panorama_shape[:2]
    assert panorama[0].mean() < panorama[-1].mean() < 1.0
    # off-centre unwarp: a row's radius, and so its gain, wobbles with the azimuth
    assert np.ptp(panorama[0]) > 0
    np.testing.assert_array_equal(vignetting_gain(spec, 0.0), np.ones_like(panorama))
    half = vignetting_gain(spec, 0.5, circular=True)[np.abs(radius - rim) < 0.5]
    assert math.isclose(float(half.mean()), 0.5, abs_tol=2e-3)


def test_an_env_with_vignetting_darkens_the_panorama_towards_the_rim():
    def frame(sensor):
        env = OmniRoverEnv(
            world="paper_outdoor",
            camera="mirror",
            mirror="paper_outdoor",
            dynamics=QUIET,
            sensor=sensor,
        )
        obs = env.reset(seed=0, options={"pose": (0.0, 0.0, 0.0)})[0].astype(float)
        env.close()
        return obs

    plain = SensorSpec(auto_exposure=False, noise=False)
    flat = frame(plain)
    vignetted = frame(SensorSpec(auto_exposure=False, noise=False, vignetting=0.4))
    ratio = vignetted.mean(axis=(1, 2)) / np.maximum(flat.mean(axis=(1, 2)), 1.0)
    assert ratio[0] < ratio[-1] < 1.0  # the top rows lie nearer the rim
    with pytest.raises(ValueError, match="needs a mirror camera"):
        OmniRoverEnv(
            world="paper_outdoor",
            camera="cylindrical",
            mirror=None,
            sensor=SensorSpec(vignetting=0.2),
        )
