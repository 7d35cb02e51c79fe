"""What changes in a world while the rover drives: the sun over the day, clouds, moving people
and cars. Declared in a world spec's ``dynamics`` block, seeded, deterministic and cheap.

Everything is a pure function of the time of day ``t`` (seconds since midnight), the world seed
and the ``day`` (another day: other clouds and other mover schedules): :meth:`Dynamics.apply`
writes the lights and the movers' poses for ``t`` into a compiled model, without recompiling.
So a rover standing still sees its panorama change, and the same (seed, day, t) always gives
the same scene.

* **Sun** (the model's light named ``"sun"``): it rises in the east (+x) at ``sunrise_hour``,
  stands in the south (-y) at noon at ``noon_elevation_deg`` and sets in the west at
  ``sunset_hour``; its elevation follows a sine arc. Its intensity grows with the sine of the
  elevation and its colour warms towards the horizon. With a ``day_of_year`` (and
  ``latitude_deg``), the sun follows the standard solar-position formulas of that date and
  place instead (:mod:`sfa_gym.sim.worlds.sun`: a low winter sun, a long summer day); the
  clock is then local solar time, and sunrise, sunset and the noon elevation follow. The
  ambient (sky) light and the fill lights named ``"sky*"`` follow the sun's height, more
  weakly, either way.
* **Clouds**: the direct light is multiplied by a slowly varying factor in
  ``[1 - cloud_depth, 1]`` (a sum of three sinusoids with periods drawn from
  ``cloud_period_s``); what clouds take from the sun partly comes back as diffuse sky light.
  ``overcast`` (0 sunny .. 1 overcast) removes most direct light for the whole day.
* **Fog**: with a ``visibility_m`` (the meteorological visibility), every view sees the scene
  through fog by Koschmieder's law, lit by the same daylight (:mod:`sfa_gym.sim.camera.fog`).
* **Shadows**: with ``shadows``, the sun casts the static scene's shadows on the ground
  (:mod:`sfa_gym.sim.camera.shadows`).
* **Movers**: pedestrians on the pavement, a cyclist and cars on a road past one side, as
  mocap bodies on lanes the scene keeps free (:mod:`sfa_gym.sim.worlds.movers`).

The sky's texture is not changed over the day (that would mean re-uploading it); with a
``cloud_cover`` it is drawn for the clock's start hour (:mod:`sfa_gym.sim.worlds.sky`).
The camera's own effects (exposure, noise) are in :mod:`sfa_gym.sim.camera.sensor`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from sfa_gym._checks import check_int_in, is_number
from sfa_gym.sim.camera.fog import check_visibility
from sfa_gym.sim.worlds.ground import check_ground

# the movers live in their own module; their public names are re-exported here
from sfa_gym.sim.worlds.movers import (
    AWAY_Z,
    FOOTPRINT,
    MOVER_KINDS,
    SIDES,
    Lanes,
    MoverSpec,
    RoadSpec,
    check_road,
    check_value,
    default_movers,
    draw_movers,
    mover_lanes,
    mover_pose,
    movers_mjcf,
    seeded_rng,
)
from sfa_gym.sim.worlds.sun import (
    check_day_of_year,
    check_latitude,
    daylight_hours,
    sun_position,
)

__all__ = [
    "FOOTPRINT",
    "MOVER_KINDS",
    "SIDES",
    "Dynamics",
    "DEFAULT_LATITUDE_DEG",
    "DynamicsSpec",
    "Lanes",
    "MoverSpec",
    "RoadSpec",
    "mover_lanes",
    "movers_mjcf",
]

_DAY_S = 86400.0

DEFAULT_LATITUDE_DEG = 50.0
"""The latitude of a dated sun when none is given: about that of central Germany, where the
paper's outdoor runs were recorded."""


@dataclass(frozen=True)
class DynamicsSpec:
    """The dynamics of a world (see the module docstring). Times of day in hours.

    Attributes:
        start_hour: time of day at which the env's clock starts.
        time_scale: simulated seconds of the clock per second of the rover's time (1: real);
            it hurries the whole world, the movers too.
        sunrise_hour, sunset_hour: the sun's day (the sine arc; not read with a
            ``day_of_year``).
        noon_elevation_deg: the sun's elevation at noon (the sine arc; not read with a
            ``day_of_year``).
        day_of_year: the date (1..366); given, the sun's path is that of this date at
            ``latitude_deg`` (:mod:`sfa_gym.sim.worlds.sun`); None: the sine arc.
        latitude_deg: the place's latitude, degrees north (negative: south); only with a
            ``day_of_year``; None there: :data:`DEFAULT_LATITUDE_DEG`.
        sun_diffuse: the sun's diffuse intensity when it stands highest, clear sky.
        ambient: ``[night, noon]`` ambient (sky) light.
        cloud_depth: clouds take up to this fraction of the direct light.
        cloud_period_s: ``[min, max]`` periods of the cloud modulation, s.
        overcast: 0 (sunny) .. 1 (overcast) for the whole day.
        day: which day: another day draws other clouds and mover schedules.
        visibility_m: fog's meteorological visibility in metres (thick fog: 50-200), or None:
            clear air.
        arrangement: which day's parked objects (cars, bins, benches, a building-site fence;
            :mod:`sfa_gym.sim.worlds.rearrange`): 0, the world as its seed built it; another
            number moves, removes and adds some, drawn from the world seed and this number.
            Apart from ``day`` (clouds and movers), so that each change can be had alone.
        rearrange_share: how much another ``arrangement`` changes: the chance that a parked
            car has left, and the expected newcomers per parked car.
        seasons: the trees' foliage by the date (needs a ``day_of_year``): leaf-out in
            spring, autumn colours, bare crowns in winter (:mod:`sfa_gym.sim.worlds.seasons`);
            False: the crowns as drawn, whatever the date.
        shadows: the sun's cast shadows on the ground (:mod:`sfa_gym.sim.camera.shadows`),
            moving with the clock and fading under clouds.
        ground: the ground's state: ``"dry"``, ``"wet"`` (after rain: darker, with the
            water film's highlight) or ``"snow"`` (lying snow; the asphalt cleared to wet
            slush); :mod:`sfa_gym.sim.worlds.ground`.
        grass_seasons: the lawn's colour by the date (needs a ``day_of_year``): green from
            May to October, a dormant straw-olive in winter (:mod:`sfa_gym.sim.worlds.ground`);
            False: the lawn as drawn, whatever the date.
        cloud_cover: the fraction of the sky that a layer of clouds covers, drawn into the
            skybox for the clock's start hour on this ``day`` (:mod:`sfa_gym.sim.worlds.sky`;
            ``overcast`` closes it into a grey deck); None: the world's plain gradient sky.
        road: the road of the cyclists and cars.
        clock, clouds, movers: switch each effect (the clock off holds the sun where it
            stood when the episode started, while clouds and movers go on; the movers off
            leave them all away).
        mover_kinds: the movers.
    """

    start_hour: float = 10.0
    time_scale: float = 1.0
    sunrise_hour: float = 6.0
    sunset_hour: float = 20.0
    noon_elevation_deg: float = 55.0
    sun_diffuse: float = 0.6
    ambient: tuple[float, float] = (0.12, 0.38)
    cloud_depth: float = 0.5
    cloud_period_s: tuple[float, float] = (40.0, 400.0)
    overcast: float = 0.0
    day: int = 0
    clock: bool = True
    clouds: bool = True
    movers: bool = True
    mover_kinds: tuple[MoverSpec, ...] = field(default_factory=default_movers)
    road: RoadSpec = RoadSpec()
    day_of_year: int | None = None
    latitude_deg: float | None = None
    visibility_m: float | None = None
    arrangement: int = 0
    rearrange_share: float = 0.5
    seasons: bool = False
    shadows: bool = False
    ground: str = "dry"
    grass_seasons: bool = False
    cloud_cover: float | None = None

    def __post_init__(self) -> None:
        check_value(
            0.0 <= self.start_hour < 24.0,
            f"start_hour must lie in [0, 24) hours, got {self.start_hour!r}",
        )
        check_value(self.time_scale > 0, f"time_scale must be > 0, got {self.time_scale!r}")
        check_value(
            0.0 <= self.sunrise_hour < self.sunset_hour <= 24.0,
            f"need 0 <= sunrise_hour < sunset_hour <= 24, got {self.sunrise_hour!r} and "
            f"{self.sunset_hour!r}",
        )
        check_value(
            0.0 < self.noon_elevation_deg <= 90.0,
            f"noon_elevation_deg must lie in (0, 90], got {self.noon_elevation_deg!r}",
        )
        check_value(
            0.0 <= self.sun_diffuse <= 1.0,
            f"sun_diffuse must lie in [0, 1], got {self.sun_diffuse!r}",
        )
        lo, hi = self.ambient
        check_value(
            0.0 <= lo <= hi <= 1.0, f"ambient must be [night, noon] in [0, 1], got {[lo, hi]}"
        )
        check_value(
            0.0 <= self.cloud_depth <= 1.0,
            f"cloud_depth must lie in [0, 1], got {self.cloud_depth!r}",
        )
        lo, hi = self.cloud_period_s
        check_value(0.0 < lo <= hi, f"cloud_period_s must be [min, max] > 0, got {[lo, hi]}")
        check_value(
            0.0 <= self.overcast <= 1.0, f"overcast must lie in [0, 1], got {self.overcast!r}"
        )
        check_int_in("day", self.day, 0)
        check_value(
            isinstance(self.arrangement, int)
            and not isinstance(self.arrangement, bool)
            and self.arrangement >= 0,
            f"arrangement must be an integer >= 0 (0: the world as built), got "
            f"{self.arrangement!r}",
        )
        check_value(
            is_number(self.rearrange_share) and 0.0 <= self.rearrange_share <= 1.0,
            f"rearrange_share must lie in [0, 1], got {self.rearrange_share!r}",
        )
        for name in ("clock", "clouds", "movers", "seasons", "shadows", "grass_seasons"):
            value = getattr(self, name)
            check_value(isinstance(value, bool), f"{name} must be True or False, got {value!r}")
        check_visibility(self.visibility_m)
        if self.day_of_year is not None:
            check_day_of_year(self.day_of_year)
        check_value(
            not self.seasons or self.day_of_year is not None,
            "seasons=True sets the foliage by the date: give a day_of_year (1..366) too",
        )
        check_value(
            not self.grass_seasons or self.day_of_year is not None,
            "grass_seasons=True sets the lawn's colour by the date: give a day_of_year (1..366) "
            "too",
        )
        check_ground(self.ground)
        check_value(
            self.cloud_cover is None
            or (is_number(self.cloud_cover) and 0.0 <= self.cloud_cover <= 1.0),
            f"cloud_cover must be None (the plain gradient sky) or lie in [0, 1], got "
            f"{self.cloud_cover!r}",
        )
        if self.latitude_deg is not None:
            check_latitude(self.latitude_deg)
            check_value(
                self.day_of_year is not None,
                f"latitude_deg={self.latitude_deg!r} places the sun by date: give a day_of_year "
                "(1..366) too, or leave latitude_deg out for the sine arc",
            )

    @property
    def latitude(self) -> float:
        """The latitude the sun is placed at, degrees north (with a ``day_of_year``)."""
        return DEFAULT_LATITUDE_DEG if self.latitude_deg is None else float(self.latitude_deg)

    @property
    def daylight(self) -> tuple[float, float]:
        """Sunrise and sunset, hours: the spec's own, or those of its date and place."""
        if self.day_of_year is None:
            return self.sunrise_hour, self.sunset_hour
        return daylight_hours(self.day_of_year, self.latitude)

    @property
    def n_movers(self) -> int:
        return sum(k.count for k in self.mover_kinds)


class Dynamics:
    """Writes the state of a world's dynamics at a time of day into a compiled MuJoCo model.

    Args:
        spec: the dynamics.
        model: the compiled model (lights named ``"sun"`` and ``"sky*"``; bodies ``mover*``
            from :func:`movers_mjcf`).
        arena_size: the arena's ``(x, y)`` size, m.
        world_seed: the world's seed (with ``spec.day``, it seeds clouds and movers).
        lanes: the world's lanes (those the world was built with, ``World.lanes``); by
            default :func:`mover_lanes` of ``spec``, ``arena_size`` and ``world_seed``.
    Raises:
        ValueError: the model has no light named ``"sun"`` while the clock or clouds are on,
            lacks the movers' bodies, or its road (the geom ``"road"``) is not where the
            lanes put it.
    """

    def __init__(
        self,
        spec: DynamicsSpec,
        model: Any,
        arena_size: tuple[float, float],
        world_seed: int,
        lanes: Lanes | None = None,
    ) -> None:
        import mujoco

        self.spec = spec
        self._model = model
        names = [
            mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_LIGHT, i) for i in range(model.nlight)
        ]
        if "sun" not in names:
            raise ValueError(
                f"the world has no light named 'sun' (its lights: {names}); the dynamics' clock "
                "and clouds move and dim the sun: use a world spec with lights.sun"
            )
        self._sun = names.index("sun")
        self._sky = [i for i, n in enumerate(names) if n and n.startswith("sky")]
        self._sky_diffuse = model.light_diffuse[self._sky].copy()
        self.lanes = lanes if lanes is not None else mover_lanes(spec, arena_size, world_seed)
        check_road(model, self.lanes)
        self._movers = draw_movers(spec, self.lanes, world_seed)
        self._mocap = []
        for i in range(len(self._movers)):
            body = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, f"mover{i}")
            if body < 0 or model.body_mocapid[body] < 0:
                raise ValueError(f"the model has no mocap body 'mover{i}' (see movers_mjcf)")
            self._mocap.append(int(model.body_mocapid[body]))
        crng = seeded_rng(world_seed, spec.day, 2)
        self._cloud_w = 2 * math.pi / crng.uniform(*spec.cloud_period_s, size=3)
        self._cloud_phase = crng.uniform(0, 2 * math.pi, size=3)

    @property
    def mover_kinds(self) -> tuple[str, ...]:
        """The kind of each mover ``mover0, mover1, ...``."""
        return tuple(m.kind for m in self._movers)

    def path(self, i: int, step: float = 0.05) -> NDArray[np.float64]:
        """``(n, 3)`` poses ``(x, y, heading)`` (m, rad) of mover ``i`` every ``step`` metres
        over one whole cycle of its path (a pedestrian's loop, a pass along the road): every
        place it can be, schedules aside."""
        if not 0 <= i < len(self._movers):
            raise ValueError(f"mover index must lie in [0, {len(self._movers)}), got {i!r}")
        if not step > 0:
            raise ValueError(f"step must be > 0 m, got {step!r}")
        m = self._movers[i]
        times = np.arange(0.0, m.cycle, step) / m.speed
        return np.array([mover_pose(m, self.lanes, float(t))[:3] for t in times])

    def sun(self, t: float) -> tuple[float, float]:
        """The sun's azimuth (rad, counter-clockwise from +x) and elevation (rad) at time of
        day ``t`` (s); the elevation is negative at night."""
        spec = self.spec
        hour = (t % _DAY_S) / 3600.0
        if spec.day_of_year is not None:  # the date's sun; else the sine arc, as before dates
            return sun_position(spec.day_of_year, spec.latitude, hour)
        day_len = spec.sunset_hour - spec.sunrise_hour
        f = (hour - spec.sunrise_hour) / day_len  # 0 at sunrise, 1 at sunset
        elevation = math.radians(spec.noon_elevation_deg) * math.sin(math.pi * f)
        if not 0.0 <= f <= 1.0:
            elevation = -abs(elevation) if elevation else -0.1
        azimuth = -math.pi * f  # east (0) -> south (-pi/2) -> west (-pi)
        return azimuth, elevation

    def cloud_factor(self, t: float) -> float:
        """Fraction of the direct light that passes the clouds at time of day ``t`` (s)."""
        spec = self.spec
        clear = 1.0 - 0.85 * spec.overcast
        if not spec.clouds or spec.cloud_depth == 0:
            return clear
        wave = float(np.mean(np.sin(self._cloud_w * t + self._cloud_phase)))  # in [-1, 1]
        # cubed: mostly sun with passing clouds rather than a steady half-shade
        cover = ((wave + 1) / 2) ** 3
        return clear * (1.0 - spec.cloud_depth * cover)

    def apply(self, data: Any, t: float, sun_t: float | None = None) -> dict[str, float]:
        """Set the lights and the movers for time of day ``t`` (s) in the model and ``data``
        (mocap poses); call ``mj_forward`` or step afterwards. Returns what was set.

        ``sun_t`` (default ``t``) is the time of day the sun is shown at: with the clock
        switched off, the env holds it at the episode's start time while clouds and movers
        go on.
        """
        spec, model = self.spec, self._model
        azimuth, elevation = self.sun(t if sun_t is None else sun_t)
        height = max(0.0, math.sin(elevation))
        clouds = self.cloud_factor(t)
        direct = spec.sun_diffuse * math.sqrt(height) * clouds
        # warmer light near the horizon: less blue and green
        warm = 1.0 - math.sqrt(height)
        colour = np.array([1.0, 1.0 - 0.25 * warm, 1.0 - 0.55 * warm])
        el = max(elevation, math.radians(1.0))  # a light from below the ground lights nothing
        model.light_dir[self._sun] = (
            -math.cos(el) * math.cos(azimuth),
            -math.cos(el) * math.sin(azimuth),
            -math.sin(el),
        )
        model.light_diffuse[self._sun] = direct * colour
        # the sky: brighter with the sun; light that clouds take from the sun is scattered back
        sky = math.sqrt(height) * (1.0 + 0.5 * (1.0 - clouds))
        lo, hi = spec.ambient
        ambient = lo + (hi - lo) * min(1.0, sky)
        model.vis.headlight.ambient[:] = ambient
        if self._sky:
            model.light_diffuse[self._sky] = self._sky_diffuse * min(1.5, max(0.2, sky))
        for m, mocap in zip(self._movers, self._mocap, strict=True):
            x, y, heading, here = mover_pose(m, self.lanes, t)
            if spec.movers and here:
                data.mocap_pos[mocap] = (x, y, 0.0)
                data.mocap_quat[mocap] = (math.cos(heading / 2), 0.0, 0.0, math.sin(heading / 2))
            else:
                data.mocap_pos[mocap] = (0.0, 0.0, AWAY_Z)
        return {
            "sun_azimuth": azimuth,
            "sun_elevation": elevation,
            "clouds": clouds,
            "ambient": ambient,
        }

    def movers_present(self, data: Any) -> NDArray[np.bool_]:
        """Which movers are in the scene now, from ``data``'s mocap poses."""
        z = np.array([data.mocap_pos[i][2] for i in self._mocap])
        return z > AWAY_Z / 2
