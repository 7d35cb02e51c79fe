"""The sun's position by date and place: the standard solar-position formulas.

Used by :class:`~sfa_gym.sim.worlds.dynamics.Dynamics` when a world's dynamics name a
``day_of_year`` (else the sun follows the spec's sine arc). The world's clock is local solar
time (12:00 is solar noon: no time zone, no equation of time) and the world's axes are its
compass: east is +x, north +y, so the noon sun of the northern hemisphere stands in the south
(-y), as with the sine arc.

* **Declination** (Cooper 1969): ``delta = 23.45 deg * sin(360 deg * (284 + n) / 365)`` for day
  of year ``n`` (about -23.45 deg at the winter solstice, 0 at the equinoxes).
* **Hour angle**: ``omega = 15 deg * (hour - 12)``, negative in the morning.
* **Position**: with latitude ``phi``, the unit vector to the sun in (east, north, up) is
  ``(-cos delta sin omega, cos phi sin delta - sin phi cos delta cos omega,
  sin phi sin delta + cos phi cos delta cos omega)``: its elevation is ``asin(up)``, its azimuth
  ``atan2(north, east)`` (counter-clockwise from +x, as the world measures it).
* **Sunrise and sunset** (geometric, the sun's centre on the horizon): ``cos omega_0 =
  -tan phi tan delta`` at ``12 -+ omega_0 / 15`` hours; beyond the polar circles the sun
  does not set (0 and 24) or does not rise (both 12).
"""

from __future__ import annotations

import math

__all__ = ["check_day_of_year", "check_latitude", "daylight_hours", "declination", "sun_position"]

OBLIQUITY_DEG = 23.45
"""The amplitude of the declination in Cooper's formula, degrees."""


def check_day_of_year(value: object) -> int:
    """``value`` if it is an integer day of the year in 1..366, else a ValueError naming it."""
    if isinstance(value, bool) or not isinstance(value, int) or not 1 <= value <= 366:
        raise ValueError(f"day_of_year must be an integer in 1..366, got {value!r}")
    return value


def check_latitude(value: object) -> float:
    """``value`` if it is a latitude in [-90, 90] degrees (north positive), else a ValueError."""
    if (
        isinstance(value, bool)
        or not isinstance(value, int | float)
        or not -90.0 <= float(value) <= 90.0
    ):
        raise ValueError(
            f"latitude_deg must be a number of degrees in [-90, 90] (north positive), got {value!r}"
        )
    return float(value)


def declination(day_of_year: int) -> float:
    """The sun's declination (rad) on ``day_of_year`` (1..366), Cooper's formula."""
    n = check_day_of_year(day_of_year)
    return math.radians(OBLIQUITY_DEG) * math.sin(2.0 * math.pi * (284 + n) / 365.0)


def sun_position(day_of_year: int, latitude_deg: float, hour: float) -> tuple[float, float]:
    """The sun's azimuth (rad, counter-clockwise from east = +x; south is -pi/2) and elevation
    (rad, negative at night) at local solar time ``hour`` on ``day_of_year`` at
    ``latitude_deg`` (north positive)."""
    delta = declination(day_of_year)
    phi = math.radians(check_latitude(latitude_deg))
    omega = math.radians(15.0 * (hour - 12.0))
    east = -math.cos(delta) * math.sin(omega)
    north = math.cos(phi) * math.sin(delta) - math.sin(phi) * math.cos(delta) * math.cos(omega)
    up = math.sin(phi) * math.sin(delta) + math.cos(phi) * math.cos(delta) * math.cos(omega)
    return math.atan2(north, east), math.asin(max(-1.0, min(1.0, up)))


def daylight_hours(day_of_year: int, latitude_deg: float) -> tuple[float, float]:
    """Sunrise and sunset, local solar time in hours, on ``day_of_year`` at ``latitude_deg``:
    ``(0, 24)`` where the sun does not set, ``(12, 12)`` where it does not rise."""
    delta = declination(day_of_year)
    phi = math.radians(check_latitude(latitude_deg))
    cos_h = -math.tan(phi) * math.tan(delta)  # finite at the poles: tan(pi / 2) is ~1.6e16
    half = math.degrees(math.acos(max(-1.0, min(1.0, cos_h)))) / 15.0
    return 12.0 - half, 12.0 + half
