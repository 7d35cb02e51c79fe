"""The sun by date and place (sfa_gym.sim.worlds.sun) and the default sine arc it leaves alone."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from sfa_gym.sim.camera import PanoramaSpec
from sfa_gym.sim.env import OmniRoverEnv
from sfa_gym.sim.worlds import load_world_spec, world_spec_from_dict
from sfa_gym.sim.worlds.dynamics import DynamicsSpec
from sfa_gym.sim.worlds.sun import daylight_hours, declination, sun_position

SMALL = PanoramaSpec(width=120, height=16)
CENTRE = {"pose": (0.0, 0.0, 0.0), "time_of_day": 15.0}


def _elevation_deg(day: int, latitude: float, hour: float) -> float:
    return math.degrees(sun_position(day, latitude, hour)[1])


def _env(**dynamics):
    spec = dataclasses.replace(load_world_spec("paper_outdoor").dynamics, **dynamics)
    return OmniRoverEnv(world="paper_outdoor", panorama=SMALL, dynamics=spec)


def test_noon_elevations_of_the_textbook():
    # Cooper's declination is 0 on day 81 (the March equinox): the sun is overhead at the equator
    assert math.degrees(declination(81)) == pytest.approx(0.0, abs=1e-9)
    assert _elevation_deg(81, 0.0, 12.0) == pytest.approx(90.0, abs=1e-6)
    # 50 N: 90 - 50 -+ 23.45 at the solstices (day 355: 21 December, day 172: 21 June)
    assert _elevation_deg(355, 50.0, 12.0) == pytest.approx(16.55, abs=0.05)
    assert _elevation_deg(172, 50.0, 12.0) == pytest.approx(63.45, abs=0.05)
    # the southern hemisphere's summer is December: the noon sun stands in the north (+y)
    azimuth, elevation = sun_position(355, -50.0, 12.0)
    assert math.degrees(elevation) == pytest.approx(63.45, abs=0.05)
    assert azimuth == pytest.approx(math.pi / 2)


def test_the_dated_sun_rises_in_the_east_stands_south_and_sets_in_the_west():
    sunrise, sunset = daylight_hours(15, 50.0)
    assert 7.5 < sunrise < 8.2 and 15.8 < sunset < 16.5  # a mid-January day, about 8.3 h
    assert sunrise + sunset == pytest.approx(24.0)  # symmetric about solar noon
    for hour in (sunrise, sunset):
        assert _elevation_deg(15, 50.0, hour) == pytest.approx(0.0, abs=1e-9)
    assert _elevation_deg(15, 50.0, sunrise - 0.5) < 0 < _elevation_deg(15, 50.0, sunrise + 0.5)
    morning, noon, evening = (sun_position(15, 50.0, h)[0] for h in (9.0, 12.0, 15.0))
    assert -math.pi / 2 < morning < 0  # south-east: +x, -y
    assert noon == pytest.approx(-math.pi / 2)
    assert -math.pi < evening < -math.pi / 2  # south-west
    summer = daylight_hours(172, 50.0)
    assert 3.5 < summer[0] < 4.3 and summer[1] - summer[0] > 16  # a long June day
    assert daylight_hours(355, 80.0) == (12.0, 12.0)  # the polar night: no sunrise
    assert daylight_hours(172, 80.0) == (0.0, 24.0)  # the midnight sun


def test_the_default_sun_is_the_old_sine_arc():
    # the reference is the formula of before dates (rise 6, set 20, noon elevation 55 deg),
    # worked out by hand: f = (hour - 6) / 14, elevation = 55 deg * sin(pi f), azimuth = -pi f
    env = _env()
    dynamics = env._dynamics
    expected = {
        10.0: (-0.8975979010256552, 0.7505043460648493),  # f = 2 / 7
        13.0: (-1.5707963267948966, 0.9599310885968813),  # f = 1 / 2: due south, 55 deg
        19.5: (-3.029392915961586, 0.10747818143002792),  # f = 27 / 28
        3.0: (0.6731984257692414, -0.5985072442273078),  # night: f = -3 / 14, below the horizon
    }
    for hour, (azimuth, elevation) in expected.items():
        assert dynamics.sun(hour * 3600.0) == pytest.approx((azimuth, elevation), abs=1e-12)
    env.close()
    assert DynamicsSpec().daylight == (6.0, 20.0)


def test_a_winter_afternoon_is_darker_than_a_summer_one_at_the_same_hour():
    frames, suns = {}, {}
    for name, day in (("winter", 15), ("summer", 196)):
        env = _env(day_of_year=day, latitude_deg=50.0, clouds=False, movers=False)
        obs, info = env.reset(seed=0, options=CENTRE)
        suns[name] = env.model.light_diffuse[env.model.light("sun").id].copy()
        frames[name] = obs
        assert env._dynamics.spec.daylight == daylight_hours(day, 50.0)
        env.close()
    assert suns["winter"].sum() < 0.7 * suns["summer"].sum()
    assert frames["winter"].mean() < frames["summer"].mean()


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"day_of_year": 0}, "day_of_year must be an integer in 1..366, got 0"),
        ({"day_of_year": 367}, "day_of_year must be an integer in 1..366, got 367"),
        ({"day_of_year": 15.5}, "day_of_year must be an integer in 1..366, got 15.5"),
        ({"day_of_year": 15, "latitude_deg": 91.0}, "latitude_deg must be a number of degrees"),
        ({"latitude_deg": 50.0}, "latitude_deg=50.0 places the sun by date: give a day_of_year"),
    ],
)
def test_bad_dates_and_places_are_refused_by_name(kwargs, message):
    with pytest.raises(ValueError, match=__import__("re").escape(message)):
        DynamicsSpec(**kwargs)


def test_a_world_spec_can_declare_the_date_and_place():
    spec = world_spec_from_dict({"name": "w", "dynamics": {"day_of_year": 15, "latitude_deg": 50}})
    assert spec.dynamics.day_of_year == 15 and spec.dynamics.latitude == 50.0
    assert DynamicsSpec(day_of_year=15).latitude == 50.0  # the default place
    with pytest.raises(ValueError, match="day_of_year must be an integer in 1..366, got 400"):
        world_spec_from_dict({"name": "w", "dynamics": {"day_of_year": 400}})
    assert np.isfinite(sun_position(172, 90.0, 3.0)).all()  # the pole is a place too
