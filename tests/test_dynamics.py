"""The outdoor world's dynamics (sun, clouds, movers) and the camera's sensor effects."""

from __future__ import annotations

import dataclasses
import math

import gymnasium as gym
import numpy as np
import pytest

import sfa_gym  # noqa: F401  (registers the ids)
from sfa_gym.sim.camera import PanoramaSpec
from sfa_gym.sim.camera.sensor import Sensor, SensorSpec
from sfa_gym.sim.env import OmniRoverEnv
from sfa_gym.sim.worlds import build_world, load_world_spec, world_spec_from_dict
from sfa_gym.sim.worlds.dynamics import DynamicsSpec, MoverSpec

SMALL = PanoramaSpec(width=120, height=16)
STILL = np.zeros(2, np.float32)
CENTRE = {"pose": (0.0, 0.0, 0.0)}
QUIET = {"clock": False, "clouds": False, "movers": False}


def _outdoor(**kwargs):
    return OmniRoverEnv(world="paper_outdoor", panorama=SMALL, **kwargs)


def _standing_frames(env, n, options=CENTRE, seed=0):
    frames = [env.reset(seed=seed, options=options)[0]]
    poses = []
    for _ in range(n):
        obs, _, _, _, info = env.step(STILL)
        frames.append(obs)
        poses.append((info["x"], info["y"], info["yaw"]))
    return frames, poses


def test_a_standing_rover_sees_its_world_change_while_its_pose_does_not():
    # one step = two minutes of the day: the sun moves, clouds pass, movers walk
    spec = dataclasses.replace(load_world_spec("paper_outdoor").dynamics, time_scale=1200.0)
    env = _outdoor(dynamics=spec)
    frames, poses = _standing_frames(env, 4)
    env.close()
    moved = np.ptp(np.array(poses), axis=0)
    assert moved[0] < 2e-3 and moved[1] < 2e-3 and moved[2] < 2e-3
    changes = [np.abs(a.astype(int) - b).mean() for a, b in zip(frames, frames[1:], strict=False)]
    assert min(changes) > 0.2, changes


def test_without_dynamics_a_standing_rover_sees_the_same_pixels():
    env = _outdoor(dynamics=False)
    frames, _ = _standing_frames(env, 3)
    env.close()
    for frame in frames[1:]:
        np.testing.assert_array_equal(frame, frames[0])


def test_each_effect_alone_changes_what_a_standing_rover_sees():
    spec = dataclasses.replace(load_world_spec("paper_outdoor").dynamics, time_scale=1200.0)
    for effect in ("clock", "clouds", "movers"):
        env = _outdoor(dynamics=dataclasses.replace(spec, **{**QUIET, effect: True}))
        frames, _ = _standing_frames(env, 3)
        env.close()
        changes = [
            np.abs(a.astype(int) - b).mean() for a, b in zip(frames, frames[1:], strict=False)
        ]
        assert max(changes) > 0.05, (effect, changes)
    env = _outdoor(dynamics=dataclasses.replace(spec, **QUIET))
    frames, _ = _standing_frames(env, 2)
    env.close()
    np.testing.assert_array_equal(frames[-1], frames[0])


def test_same_seed_same_pixels_with_every_effect_on():
    runs = []
    for _ in range(2):
        env = _outdoor(dynamics=True, sensor=True)
        frames, _ = _standing_frames(env, 2, options=None, seed=7)
        env.close()
        runs.append(frames)
    for a, b in zip(*runs, strict=True):
        np.testing.assert_array_equal(a, b)


def test_sensor_noise_and_exposure_switch_independently():
    env = _outdoor(dynamics=QUIET, sensor={"noise": False})
    frames, _ = _standing_frames(env, 2)
    env.close()
    np.testing.assert_array_equal(frames[1], frames[2])  # exposure settled, no noise
    env = _outdoor(dynamics=QUIET, sensor={"auto_exposure": False})
    frames, _ = _standing_frames(env, 1)
    env.close()
    assert np.abs(frames[0].astype(int) - frames[1]).mean() > 0.5  # fresh noise every frame


def test_movers_off_sends_every_mover_away():
    env = _outdoor(dynamics={"movers": False})
    env.reset(seed=0, options=CENTRE)
    present = env._dynamics.movers_present(env.data)
    env.close()
    assert present.size == 6 and not present.any()
    env = _outdoor(dynamics=True)
    seen = np.zeros(6, bool)
    env.reset(seed=0, options=CENTRE)
    for hour in np.linspace(9, 11, 25):
        env._dynamics.apply(env.data, hour * 3600)
        seen |= env._dynamics.movers_present(env.data)
    env.close()
    assert seen.all()


def test_the_clock_runs_on_across_unseeded_resets_and_reset_can_set_it():
    env = _outdoor(dynamics={**QUIET, "clock": True, "start_hour": 9.5})
    _, info = env.reset(seed=0, options=CENTRE)
    assert info["clock"] == pytest.approx(9.5)
    for _ in range(3):
        _, _, _, _, info = env.step(STILL)
    assert info["clock"] == pytest.approx(9.5 + 3 * env.control_dt / 3600)
    _, info = env.reset(options=CENTRE)  # no seed: the clock runs on
    assert info["clock"] == pytest.approx(9.5 + 3 * env.control_dt / 3600)
    env.step(STILL)
    _, info = env.reset(seed=1, options=CENTRE)  # a seed starts the day again
    assert info["clock"] == pytest.approx(9.5)
    _, info = env.reset(options={**CENTRE, "time_of_day": 16.25})
    assert info["clock"] == pytest.approx(16.25)
    env.close()
    # the clock switched off holds the sun; the time of day still runs for clouds and movers
    env = _outdoor(dynamics=DynamicsSpec(time_scale=3600.0, clock=False, clouds=False))
    env.reset(seed=0, options=CENTRE)
    sun = env.model.light("sun")
    before = sun.dir.copy(), sun.diffuse.copy()
    _, _, _, _, info = env.step(STILL)
    env.close()
    assert info["clock"] == pytest.approx(10.0 + env.control_dt * 3600.0 / 3600.0)
    np.testing.assert_array_equal(sun.dir, before[0])
    np.testing.assert_array_equal(sun.diffuse, before[1])


def test_the_sun_rises_in_the_east_stands_south_at_noon_and_sets():
    env = _outdoor(dynamics=True)
    dyn = env._dynamics
    spec = env.dynamics
    azimuth, elevation = dyn.sun(spec.sunrise_hour * 3600 + 60)
    assert abs(azimuth) < 0.05 and 0 < elevation < 0.05
    noon = (spec.sunrise_hour + spec.sunset_hour) / 2
    azimuth, elevation = dyn.sun(noon * 3600)
    assert azimuth == pytest.approx(-math.pi / 2)
    assert elevation == pytest.approx(math.radians(spec.noon_elevation_deg))
    assert dyn.sun(2 * 3600)[1] < 0
    env.reset(seed=0, options={**CENTRE, "time_of_day": 12.0})
    bright = env.model.light_diffuse[env.model.light("sun").id].sum()
    env.reset(seed=0, options={**CENTRE, "time_of_day": 6.5})
    low = env.model.light_diffuse[env.model.light("sun").id]
    env.close()
    assert low.sum() < bright and low[2] < low[0]  # weaker and warmer near the horizon


def test_overcast_and_clouds_dim_the_sun():
    spec = load_world_spec("paper_outdoor").dynamics
    env = _outdoor(dynamics=dataclasses.replace(spec, overcast=1.0))
    env2 = _outdoor(dynamics=True)
    hours = np.linspace(10, 11, 40) * 3600
    overcast = [env._dynamics.cloud_factor(t) for t in hours]
    sunny = [env2._dynamics.cloud_factor(t) for t in hours]
    env.close(), env2.close()
    assert max(overcast) < min(sunny) or max(overcast) < 0.3
    assert np.ptp(sunny) > 0.05  # clouds pass


def test_no_dynamics_means_the_env_of_before():
    plain = OmniRoverEnv(panorama=SMALL)
    switched = OmniRoverEnv(panorama=SMALL, dynamics=False, sensor=False, camera="cylindrical")
    a, info_a = plain.reset(seed=3)
    b, info_b = switched.reset(seed=3)
    plain.close(), switched.close()
    np.testing.assert_array_equal(a, b)
    assert info_a == info_b and "clock" not in info_a


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"dynamics": {"clock": "yes"}}, "dynamics: field clock must be bool, got 'yes'"),
        ({"dynamics": {"start_hour": 25.0}}, "start_hour must lie in [0, 24)"),
        ({"dynamics": {"start_hour": "noon"}}, "field start_hour must be float, got 'noon'"),
        ({"dynamics": {"colck": False}}, "unknown field 'colck'; the fields of DynamicsSpec"),
        ({"dynamics": "on"}, "dynamics must be None, a bool, a DynamicsSpec or an object"),
        ({"sensor": {"auto_exposure": 1}}, "sensor: field auto_exposure must be bool, got 1"),
        ({"camera": "fisheye"}, "camera must be one of"),
        ({"mirror": "paper_outdoor"}, "is for camera='mirror'"),
        ({"camera": "mirror", "mirror": "dome"}, "unknown mirror preset 'dome'"),
    ],
)
def test_bad_arguments_are_refused_by_name(kwargs, message):
    with pytest.raises((ValueError, TypeError), match=__import__("re").escape(message)):
        _outdoor(**kwargs)


def test_bad_reset_time_and_bad_specs_are_refused_by_name():
    env = _outdoor(dynamics=True)
    with pytest.raises(ValueError, match=r"time_of_day.*\[0, 24\), got 30"):
        env.reset(options={"time_of_day": 30})
    env.close()
    with pytest.raises(ValueError, match="needs dynamics"):
        OmniRoverEnv(panorama=SMALL).reset(options={"time_of_day": 8.0})
    with pytest.raises(ValueError, match="overcast must lie in"):
        DynamicsSpec(overcast=2.0)
    with pytest.raises(ValueError, match="mover kind must be one of"):
        MoverSpec(kind="horse")
    with pytest.raises(ValueError, match=r"unknown key 'dynamics\.weather'"):
        world_spec_from_dict({"name": "w", "dynamics": {"weather": "rain"}})
    with pytest.raises(ValueError, match="dynamics.clouds must be bool"):
        world_spec_from_dict({"name": "w", "dynamics": {"clouds": "yes"}})


def test_movers_are_visual_mocap_bodies_and_other_worlds_have_none():
    spec = load_world_spec("paper_outdoor")
    mjcf = build_world(spec, 0).mjcf
    assert mjcf.count('mocap="true"') == spec.dynamics.n_movers == 6
    assert 'mocap="true"' not in build_world(load_world_spec("paper_sim"), 0).mjcf
    env = _outdoor(dynamics=True)
    model = env.model
    for i in range(6):
        body = model.body(f"mover{i}").id
        geoms = np.flatnonzero(model.geom_bodyid == body)
        assert geoms.size and not model.geom_contype[geoms].any()
    env.close()


def test_auto_exposure_brings_a_darkened_image_back_with_a_lag():
    sensor = Sensor(SensorSpec(noise=False, tau_s=1.0))
    bright = np.full((4, 8, 3), 100, np.uint8)
    sensor.reset(bright)
    assert sensor.gain == pytest.approx(1.0)
    dark = np.full((4, 8, 3), 50, np.uint8)
    rng = np.random.default_rng(0)
    first = sensor.process(dark, 0.1, rng).mean()
    for _ in range(60):
        last = sensor.process(dark, 0.1, rng).mean()
    assert 50 < first < 60 and last == pytest.approx(100, abs=1)


def test_the_exposure_meter_ignores_pixels_black_in_every_channel():
    # a mirror's image: a lit disc (one channel dark in places) inside a black frame
    image = np.zeros((20, 20, 3), np.uint8)
    image[5:15, 5:15] = (80, 0, 40)  # lit: one channel is not zero
    sensor = Sensor(SensorSpec(noise=False, target=100.0))
    sensor.reset(image)
    assert sensor.gain == pytest.approx(100.0 / 40.0)  # mean of the lit pixels' channels: 40
    sensor.reset(image[..., 0])  # a grey image: the zeros are the unlit pixels
    assert sensor.gain == pytest.approx(100.0 / 80.0)
    sensor.reset(np.zeros((4, 4, 3), np.uint8))  # nothing lit: the brightest gain allowed
    assert sensor.gain == pytest.approx(SensorSpec().gain_range[1])


def test_the_registered_outdoor_env_sees_through_the_mirror_with_a_clock():
    env = gym.make("sfa_gym/OmniRoverOutdoor-v0")
    obs, info = env.reset(seed=0)
    assert obs.shape == (60, 600, 3) and obs.dtype == np.uint8
    assert info["clock"] == pytest.approx(10.0)
    assert env.unwrapped.camera == "mirror" and env.unwrapped.sensor is not None
    env.close()
