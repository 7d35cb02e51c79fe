"""Motion blur: a frame taken while the rover turns is the mean of the panoramas its camera saw
during the exposure (checked against renders at those headings), on the right side, with the
exposure following the auto-exposure's gain and a clear error where it cannot apply."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

import sfa_gym  # noqa: F401  (registers the envs)
from sfa_gym.sim.camera.sensor import Sensor, SensorSpec, azimuth_blur

STILL = {"auto_exposure": False, "noise": False}
"""A sensor that changes nothing but by the blur."""


def test_the_blur_is_the_mean_of_the_panoramas_seen_during_the_turn():
    env = gym.make("sfa_gym/OmniRover-v0").unwrapped
    x, y, yaw, rate, exposure = 0.3, 0.2, 0.4, 0.8, 0.2

    def seen(heading: float) -> np.ndarray:
        return env.reset(options={"pose": (x, y, heading)})[0].astype(float)

    last = env.reset(options={"pose": (x, y, yaw)})[0]
    # the camera turned counter-clockwise: `t` seconds before the exposure ended it faced
    # `rate * t` less far round
    truth = np.mean([seen(yaw - rate * t) for t in np.linspace(0.0, exposure, 41)], axis=0)
    columns = rate * exposure * last.shape[1] / (2 * math.pi)  # about 9 of 350
    error = np.abs(azimuth_blur(last, columns) - truth).mean()
    assert error < 0.1 * np.abs(last - truth).mean()  # far nearer than the instant
    assert error < 0.1 * np.abs(azimuth_blur(last, -columns) - truth).mean()  # the right side
    sensor = Sensor(SensorSpec(**STILL, exposure_s=exposure))
    frame = sensor.process(last, 0.5, np.random.default_rng(0), yaw_rate=rate)
    np.testing.assert_array_equal(frame, azimuth_blur(last, columns))


def test_the_blur_spreads_a_column_over_the_swept_ones_and_keeps_the_light():
    image = np.zeros((2, 40, 3), np.uint8)
    image[:, 10] = 200
    smeared = azimuth_blur(image, 4.0).astype(int)
    lit = np.flatnonzero(smeared[0, :, 0])
    assert lit.min() >= 10 and lit.max() <= 15  # towards higher columns, 4 (+ 1 interpolated)
    assert abs(int(smeared[0, :, 0].sum()) - 200) <= len(lit)  # up to a rounding per column
    assert np.flatnonzero(azimuth_blur(image, -4.0)[0, :, 0]).max() <= 10  # the other way
    wrapped = np.roll(image, 28, axis=1)  # column 38: the smear wraps round the panorama
    assert azimuth_blur(wrapped, 4.0)[0, [39, 0, 1], 0].min() > 0
    assert azimuth_blur(image, 0.0) is image
    flat = np.full((3, 30, 3), 77, np.uint8)
    np.testing.assert_array_equal(azimuth_blur(flat, 7.3), flat)
    # a whole turn or more: every pixel is its row's mean
    full = azimuth_blur(image, 1000.0)
    assert np.all(np.abs(full[0, :, 0].astype(int) - 5) <= 1)


def test_the_exposure_grows_with_the_gain_and_stays_within_the_frame():
    sensor = Sensor(SensorSpec(noise=False, exposure_s=0.01))
    dark = np.full((4, 20, 3), 25, np.uint8)
    sensor.reset(dark)  # the auto-exposure settles at gain 4 (100 / 25)
    assert sensor.gain == pytest.approx(4.0)
    assert sensor.exposure(0.1) == pytest.approx(0.04)
    assert sensor.exposure(0.02) == pytest.approx(0.02)  # at most the frame interval
    assert Sensor(SensorSpec(**STILL, exposure_s=0.01)).exposure(0.1) == pytest.approx(0.01)


def test_an_env_blurs_its_frames_while_turning_only():
    def frames(exposure_s: float, action: tuple[float, float]) -> np.ndarray:
        sensor = SensorSpec(**STILL, exposure_s=exposure_s)
        env = gym.make("sfa_gym/OmniRover-v0", sensor=sensor).unwrapped
        env.reset(seed=3, options={"pose": (0.0, 0.0, 0.0)})
        return np.stack([env.step(np.array(action, np.float32))[0] for _ in range(6)])

    turning = np.abs(frames(0.1, (0.0, 1.0)).astype(int) - frames(0.0, (0.0, 1.0))).mean()
    straight = np.abs(frames(0.1, (0.2, 0.0)).astype(int) - frames(0.0, (0.2, 0.0))).mean()
    assert turning > 2.0
    assert straight < 0.05 * turning


def test_motion_blur_errors_name_the_value():
    with pytest.raises(ValueError, match=r"exposure_s must be .* got -0.1"):
        SensorSpec(exposure_s=-0.1)
    with pytest.raises(ValueError, match=r"exposure_s must be .* got nan"):
        SensorSpec(exposure_s=float("nan"))
    with pytest.raises(ValueError, match=r"needs a panorama.*not 'mirror_circular'"):
        gym.make(
            "sfa_gym/OmniRoverOutdoor-v0",
            camera="mirror_circular",
            sensor=SensorSpec(exposure_s=0.01),
        )
