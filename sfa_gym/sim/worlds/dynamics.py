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
  elevation and its colour warms towards the horizon. The ambient (sky) light and the fill
  lights named ``"sky*"`` follow the sun's height, more weakly.
* **Clouds**: the direct light is multiplied by a slowly varying factor in
  ``[1 - cloud_depth, 1]`` (a sum of three sinusoids with periods drawn from
  ``cloud_period_s``); what clouds take from the sun partly comes back as diffuse sky light.
  ``overcast`` (0 sunny .. 1 overcast) removes most direct light for the whole day.
* **Movers**: pedestrians, cyclists and cars as MuJoCo mocap bodies (visual only: nothing
  collides with them) that go round closed loops around the arena at their own speed, offset
  and direction, and come and go on seeded schedules (absent movers wait below the ground).

The sky's gradient texture is not changed over the day (that would mean re-uploading it).
The camera's own effects (exposure, noise) are in :mod:`sfa_gym.sim.camera.sensor`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = [
    "MOVER_KINDS",
    "Dynamics",
    "DynamicsSpec",
    "MoverSpec",
    "check_switch",
    "movers_mjcf",
    "resolve_dynamics",
]

MOVER_KINDS = ("pedestrian", "cyclist", "car")
_AWAY_Z = -50.0  # where an absent mover waits (m): below the ground, out of every view
_DAY_S = 86400.0


def _check(condition: bool, message: str) -> None:
    if not condition:
        raise ValueError(message)


@dataclass(frozen=True)
class MoverSpec:
    """One kind of mover.

    Attributes:
        kind: "pedestrian", "cyclist" or "car".
        count: how many.
        speed: ``[min, max]`` speed, m/s; each mover draws its own.
        offset: ``[min, max]`` distance of its loop outside the arena's edge, m.
        presence: ``[min, max]`` fraction of the time a mover is there; it comes and goes
            with a period drawn from ``period_s``.
        period_s: ``[min, max]`` period of its schedule, s.
    """

    kind: str
    count: int = 1
    speed: tuple[float, float] = (1.2, 1.5)
    offset: tuple[float, float] = (0.5, 1.0)
    presence: tuple[float, float] = (0.4, 0.8)
    period_s: tuple[float, float] = (60.0, 240.0)

    def __post_init__(self) -> None:
        _check(
            self.kind in MOVER_KINDS, f"mover kind must be one of {MOVER_KINDS}, got {self.kind!r}"
        )
        _check(
            isinstance(self.count, int) and not isinstance(self.count, bool) and self.count >= 0,
            f"mover count must be an integer >= 0, got {self.count!r}",
        )
        for name, low, high in (
            ("speed", 0.0, math.inf),
            ("offset", 0.0, math.inf),
            ("presence", 0.0, 1.0),
            ("period_s", 0.0, math.inf),
        ):
            lo, hi = getattr(self, name)
            _check(
                low < lo <= hi <= high if name != "offset" else low <= lo <= hi,
                f"mover {name} must be a [min, max] pair inside ({low}, {high}], got {[lo, hi]}",
            )


def _default_movers() -> tuple[MoverSpec, ...]:
    return (
        MoverSpec("pedestrian", 3, (1.1, 1.5), (0.4, 1.1)),
        MoverSpec("cyclist", 1, (3.5, 4.5), (1.8, 2.4)),
        MoverSpec("car", 2, (5.0, 8.0), (3.0, 4.0), (0.2, 0.5), (40.0, 120.0)),
    )


@dataclass(frozen=True)
class DynamicsSpec:
    """The dynamics of a world (see the module docstring). Times of day in hours.

    Attributes:
        start_hour: time of day at which the env's clock starts.
        time_scale: simulated seconds of the clock per second of the rover's time (1: real);
            it hurries the whole world, the movers too.
        sunrise_hour, sunset_hour: the sun's day.
        noon_elevation_deg: the sun's elevation at noon.
        sun_diffuse: the sun's diffuse intensity when it stands highest, clear sky.
        ambient: ``[night, noon]`` ambient (sky) light.
        cloud_depth: clouds take up to this fraction of the direct light.
        cloud_period_s: ``[min, max]`` periods of the cloud modulation, s.
        overcast: 0 (sunny) .. 1 (overcast) for the whole day.
        day: which day: another day draws other clouds and mover schedules.
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
    mover_kinds: tuple[MoverSpec, ...] = field(default_factory=_default_movers)

    def __post_init__(self) -> None:
        _check(
            0.0 <= self.start_hour < 24.0,
            f"start_hour must lie in [0, 24) hours, got {self.start_hour!r}",
        )
        _check(self.time_scale > 0, f"time_scale must be > 0, got {self.time_scale!r}")
        _check(
            0.0 <= self.sunrise_hour < self.sunset_hour <= 24.0,
            f"need 0 <= sunrise_hour < sunset_hour <= 24, got {self.sunrise_hour!r} and "
            f"{self.sunset_hour!r}",
        )
        _check(
            0.0 < self.noon_elevation_deg <= 90.0,
            f"noon_elevation_deg must lie in (0, 90], got {self.noon_elevation_deg!r}",
        )
        _check(
            0.0 <= self.sun_diffuse <= 1.0,
            f"sun_diffuse must lie in [0, 1], got {self.sun_diffuse!r}",
        )
        lo, hi = self.ambient
        _check(0.0 <= lo <= hi <= 1.0, f"ambient must be [night, noon] in [0, 1], got {[lo, hi]}")
        _check(
            0.0 <= self.cloud_depth <= 1.0,
            f"cloud_depth must lie in [0, 1], got {self.cloud_depth!r}",
        )
        lo, hi = self.cloud_period_s
        _check(0.0 < lo <= hi, f"cloud_period_s must be [min, max] > 0, got {[lo, hi]}")
        _check(0.0 <= self.overcast <= 1.0, f"overcast must lie in [0, 1], got {self.overcast!r}")
        _check(
            isinstance(self.day, int) and not isinstance(self.day, bool) and self.day >= 0,
            f"day must be an integer >= 0, got {self.day!r}",
        )
        for name in ("clock", "clouds", "movers"):
            value = getattr(self, name)
            _check(isinstance(value, bool), f"{name} must be True or False, got {value!r}")

    @property
    def n_movers(self) -> int:
        return sum(k.count for k in self.mover_kinds)


@dataclass(frozen=True)
class _Mover:
    kind: str
    half: tuple[float, float]  # half sides of its loop (m)
    speed: float  # m/s, negative: clockwise
    phase: float  # where on the loop it is at t = 0 (m)
    period: float  # schedule period (s)
    presence: float  # fraction of the period it is there
    shift: float  # schedule phase (s)
    rgb: tuple[float, float, float]


def _rng(world_seed: int, day: int, stream: int) -> np.random.Generator:
    return np.random.default_rng([int(world_seed), int(day), stream])


def _draw_movers(
    spec: DynamicsSpec, arena_size: tuple[float, float], world_seed: int
) -> list[_Mover]:
    rng = _rng(world_seed, spec.day, 1)
    hx, hy = arena_size[0] / 2, arena_size[1] / 2
    movers = []
    for kind in spec.mover_kinds:
        for _ in range(kind.count):
            offset = rng.uniform(*kind.offset)
            half = (hx + offset, hy + offset)
            speed = rng.uniform(*kind.speed) * (1 if rng.random() < 0.5 else -1)
            perimeter = 4 * (half[0] + half[1])
            movers.append(
                _Mover(
                    kind=kind.kind,
                    half=half,
                    speed=float(speed),
                    phase=float(rng.uniform(0, perimeter)),
                    period=float(rng.uniform(*kind.period_s)),
                    presence=float(rng.uniform(*kind.presence)),
                    shift=float(rng.uniform(0, 1)),
                    rgb=tuple(float(c) for c in rng.uniform(0.1, 0.9, 3)),  # type: ignore[arg-type]
                )
            )
    return movers


def _f(x: float) -> str:
    return f"{x:.4f}".rstrip("0").rstrip(".") or "0"


def _mover_geoms(m: _Mover, material: str) -> list[str]:
    """Geoms of one mover in its body frame (x forward, z up), visual only."""
    vis = f'material="{material}" contype="0" conaffinity="0" mass="0"'
    dark = 'rgba="0.12 0.12 0.12 1" contype="0" conaffinity="0" mass="0"'
    skin = 'rgba="0.85 0.68 0.55 1" contype="0" conaffinity="0" mass="0"'
    if m.kind == "pedestrian":
        return [
            f'<geom type="capsule" fromto="0 0 0.25 0 0 1.35" size="0.17" {vis}/>',
            f'<geom type="sphere" pos="0 0 1.6" size="0.12" {skin}/>',
        ]
    if m.kind == "cyclist":
        return [
            f'<geom type="box" pos="0 0 0.45" size="0.85 0.04 0.35" {dark}/>',
            f'<geom type="capsule" fromto="-0.1 0 0.9 0.15 0 1.5" size="0.17" {vis}/>',
            f'<geom type="sphere" pos="0.2 0 1.75" size="0.13" {skin}/>',
        ]
    return [
        f'<geom type="box" pos="0 0 0.6" size="2.1 0.9 0.38" {vis}/>',
        f'<geom type="box" pos="-0.2 0 1.2" size="1.1 0.8 0.25" {vis}/>',
        f'<geom type="box" pos="0 0 0.22" size="1.9 0.92 0.2" {dark}/>',
    ]


def movers_mjcf(
    spec: DynamicsSpec, arena_size: tuple[float, float], world_seed: int
) -> tuple[str, str]:
    """``(assets, worldbody)`` MJCF of the movers: mocap bodies ``mover0, mover1, ...``.

    The bodies exist whenever the spec declares movers, also with ``spec.movers`` off (they
    then stay away): switching movers off changes no other part of the model.
    """
    assets, bodies = [], []
    for i, m in enumerate(_draw_movers(spec, arena_size, world_seed)):
        material = f"mover{i}_paint"
        assets.append(
            f'<material name="{material}" rgba="{" ".join(_f(c) for c in m.rgb)} 1" '
            f'specular="0" shininess="0"/>'
        )
        geoms = "\n".join(f"  {g}" for g in _mover_geoms(m, material))
        bodies.append(
            f'<body name="mover{i}" mocap="true" pos="0 0 {_f(_AWAY_Z)}">\n{geoms}\n</body>'
        )
    return "\n".join(assets), "\n".join(bodies)


def _loop_pose(m: _Mover, t: float) -> tuple[float, float, float]:
    """Position (x, y) and heading on the mover's rectangular loop at time ``t`` (s)."""
    hx, hy = m.half
    sides = (2 * hx, 2 * hy, 2 * hx, 2 * hy)
    perimeter = sum(sides)
    s = (m.phase + m.speed * t) % perimeter
    # counter-clockwise from the south-west corner: east, north, west, south
    corners = ((-hx, -hy), (hx, -hy), (hx, hy), (-hx, hy))
    headings = (0.0, math.pi / 2, math.pi, -math.pi / 2)
    for (x0, y0), heading, length in zip(corners, headings, sides, strict=True):
        if s <= length:
            x, y = x0 + s * math.cos(heading), y0 + s * math.sin(heading)
            return x, y, heading if m.speed > 0 else heading + math.pi
        s -= length
    return corners[0][0], corners[0][1], 0.0


class Dynamics:
    """Writes the state of a world's dynamics at a time of day into a compiled MuJoCo model.

    Args:
        spec: the dynamics.
        model: the compiled model (lights named ``"sun"`` and ``"sky*"``; bodies ``mover*``
            from :func:`movers_mjcf`).
        arena_size: the arena's ``(x, y)`` size, m (the movers' loops go round it).
        world_seed: the world's seed (with ``spec.day``, it seeds clouds and movers).
    Raises:
        ValueError: the model has no light named ``"sun"`` while the clock or clouds are on,
            or lacks the movers' bodies.
    """

    def __init__(
        self, spec: DynamicsSpec, model: Any, arena_size: tuple[float, float], world_seed: int
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
        self._movers = _draw_movers(spec, arena_size, world_seed)
        self._mocap = []
        for i in range(len(self._movers)):
            body = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, f"mover{i}")
            if body < 0 or model.body_mocapid[body] < 0:
                raise ValueError(f"the model has no mocap body 'mover{i}' (see movers_mjcf)")
            self._mocap.append(int(model.body_mocapid[body]))
        crng = _rng(world_seed, spec.day, 2)
        self._cloud_w = 2 * math.pi / crng.uniform(*spec.cloud_period_s, size=3)
        self._cloud_phase = crng.uniform(0, 2 * math.pi, size=3)

    def sun(self, t: float) -> tuple[float, float]:
        """The sun's azimuth (rad, counter-clockwise from +x) and elevation (rad) at time of
        day ``t`` (s); the elevation is negative at night."""
        spec = self.spec
        hour = (t % _DAY_S) / 3600.0
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
            here = spec.movers and ((t / m.period + m.shift) % 1.0) < m.presence
            if here:
                x, y, heading = _loop_pose(m, t)
                data.mocap_pos[mocap] = (x, y, 0.0)
                data.mocap_quat[mocap] = (math.cos(heading / 2), 0.0, 0.0, math.sin(heading / 2))
            else:
                data.mocap_pos[mocap] = (0.0, 0.0, _AWAY_Z)
        return {
            "sun_azimuth": azimuth,
            "sun_elevation": elevation,
            "clouds": clouds,
            "ambient": ambient,
        }

    def movers_present(self, data: Any) -> NDArray[np.bool_]:
        """Which movers are in the scene now, from ``data``'s mocap poses."""
        z = np.array([data.mocap_pos[i][2] for i in self._mocap])
        return z > _AWAY_Z / 2


def check_switch(name: str, value: Any) -> bool | None:
    """``value`` if it is True, False or None (not given); else a ValueError naming ``name``."""
    if value is not None and not isinstance(value, bool):
        raise ValueError(f"{name} must be True, False or None, got {value!r}")
    return value


def resolve_dynamics(
    declared: DynamicsSpec | None,
    dynamics: bool | DynamicsSpec | None,
    switches: dict[str, bool | None],
    start_hour: float | None,
) -> DynamicsSpec | None:
    """The dynamics an env runs, from its arguments.

    Args:
        declared: what the world spec declares (None: nothing).
        dynamics: None (what the world declares), False (none), True (the world's, else the
            defaults) or a spec.
        switches: ``{"clock": ..., "clouds": ..., "movers": ...}``: True/False override the
            spec's field, None keeps it.
        start_hour: overrides ``start_hour`` when given.
    Raises:
        ValueError: a switch that is not a bool or None, a bad start hour, or a switch turned
            on (or a start hour given) while there are no dynamics.
    """
    if dynamics is None:
        spec = declared
    elif dynamics is False:
        spec = None
    elif dynamics is True:
        spec = declared if declared is not None else DynamicsSpec()
    elif isinstance(dynamics, DynamicsSpec):
        spec = dynamics
    else:
        raise TypeError(f"dynamics must be None, a bool or a DynamicsSpec, got {dynamics!r}")
    given: dict[str, Any] = {k: check_switch(k, v) for k, v in switches.items() if v is not None}
    if start_hour is not None:
        if isinstance(start_hour, bool) or not isinstance(start_hour, int | float):
            raise ValueError(f"start_hour must be a number of hours in [0, 24), got {start_hour!r}")
        given["start_hour"] = float(start_hour)
    if spec is None:
        asked = sorted(k for k, v in given.items() if v is not False)
        if asked:
            raise ValueError(
                f"{asked} need dynamics, but the world declares none and dynamics={dynamics!r}; "
                "pass dynamics=True"
            )
        return None
    return replace(spec, **given) if given else spec
