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
  collides with them) on the world's :class:`Lanes` (:func:`mover_lanes`, from the spec and
  the world seed; the scene keeps them free). Pedestrians walk loops round the pavement ring
  at their own speed, distance and direction. Cyclists and cars keep to a straight road that
  passes the area on one side (a two-way cycle path, then car lanes of alternating
  direction): each goes along its lane from one far end to the other, out of sight there,
  and starts again. They come and go on seeded schedules (absent movers wait below the
  ground); a cyclist or a car comes and goes only at the road's far ends, a whole pass at
  a time.

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
    "FOOTPRINT",
    "MOVER_KINDS",
    "SIDES",
    "Dynamics",
    "DynamicsSpec",
    "Lanes",
    "MoverSpec",
    "RoadSpec",
    "check_switch",
    "mover_lanes",
    "movers_mjcf",
    "resolve_dynamics",
]

MOVER_KINDS = ("pedestrian", "cyclist", "car")
SIDES = ("north", "east", "south", "west")
# half sizes (m) of the movers' footprints: a pedestrian's radius, a cyclist's and a car's
# half length and half width (their bodies' geoms in :func:`_mover_geoms`)
FOOTPRINT = {"pedestrian": (0.25, 0.25), "cyclist": (0.9, 0.3), "car": (2.1, 0.92)}
_WALK = (0.5, 0.85)  # default distance of the pedestrians' loops from the arena's edge (m)
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
        offset: ``[min, max]`` distance of a pedestrian's loop (its centre line) outside
            the arena's edge, m: on the pavement, between the curb and the lamp posts.
            Cyclists and cars keep to the road's lanes (:class:`RoadSpec`) and take none.
        presence: ``[min, max]`` fraction of the time a mover is there; it comes and goes
            with a period drawn from ``period_s``.
        period_s: ``[min, max]`` period of its schedule, s.
    """

    kind: str
    count: int = 1
    speed: tuple[float, float] = (1.2, 1.5)
    offset: tuple[float, float] | None = None
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
        if self.kind == "pedestrian" and self.offset is None:
            object.__setattr__(self, "offset", _WALK)
        _check(
            self.kind == "pedestrian" or self.offset is None,
            f"a {self.kind} keeps to the road's lanes (dynamics.road) and takes no offset, "
            f"got offset {self.offset!r}",
        )
        for name, low, high in (
            ("speed", 0.0, math.inf),
            ("offset", 0.0, math.inf),
            ("presence", 0.0, 1.0),
            ("period_s", 0.0, math.inf),
        ):
            if getattr(self, name) is None:
                continue
            lo, hi = getattr(self, name)
            _check(
                low < lo <= hi <= high if name != "offset" else low <= lo <= hi,
                f"mover {name} must be a [min, max] pair inside ({low}, {high}], got {[lo, hi]}",
            )


@dataclass(frozen=True)
class RoadSpec:
    """The straight road that passes the area on one side (the side drawn from the world
    seed). Distances outward from the asphalt's edge, m.

    Attributes:
        distance: the road's near edge (beyond the pavement and a verge of grass).
        cycle_path: width of the two-way cycle path, the road's near part (one half each
            way).
        lane_width: width of each car lane; the lanes beyond the cycle path alternate in
            direction.
        car_lanes: number of car lanes.
        length: the road's length, centred on the side: its ends lie far beyond what the
            rover sees clearly, where cyclists and cars come and go.
    """

    distance: float = 2.5
    cycle_path: float = 2.0
    lane_width: float = 3.0
    car_lanes: int = 2
    length: float = 120.0

    def __post_init__(self) -> None:
        for name in ("distance", "cycle_path", "lane_width", "length"):
            value = getattr(self, name)
            _check(
                isinstance(value, int | float) and math.isfinite(value) and value > 0,
                f"road {name} must be a positive number of metres, got {value!r}",
            )
        _check(
            isinstance(self.car_lanes, int)
            and not isinstance(self.car_lanes, bool)
            and self.car_lanes >= 1,
            f"road car_lanes must be an integer >= 1, got {self.car_lanes!r}",
        )
        for kind, width in (("cyclist", self.cycle_path / 2), ("car", self.lane_width)):
            _check(
                width >= 2 * FOOTPRINT[kind][1],
                f"road {'cycle_path / 2' if kind == 'cyclist' else 'lane_width'} must be at "
                f"least a {kind}'s width {2 * FOOTPRINT[kind][1]} m, got {width!r}",
            )
        _check(
            self.length >= 8 * FOOTPRINT["car"][0],
            f"road length must be >= {8 * FOOTPRINT['car'][0]} m, got {self.length!r}",
        )

    @property
    def width(self) -> float:
        """Width of the whole road (m)."""
        return self.cycle_path + self.car_lanes * self.lane_width


def _default_movers() -> tuple[MoverSpec, ...]:
    return (
        MoverSpec("pedestrian", 3, (1.1, 1.5), _WALK),
        MoverSpec("cyclist", 1, (3.5, 4.5)),
        MoverSpec("car", 2, (5.0, 8.0), None, (0.2, 0.5), (40.0, 120.0)),
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
    mover_kinds: tuple[MoverSpec, ...] = field(default_factory=_default_movers)
    road: RoadSpec = RoadSpec()

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
class Lanes:
    """Where the movers of one world go: the same every day, known to the scene (which keeps
    them free) and the dynamics (which moves the movers along them). From
    :func:`mover_lanes`. Distances outward from the asphalt's edge, m.

    Attributes:
        half: the arena's (asphalt's) half sizes ``(hx, hy)``, m.
        walk: ``(min, max)`` distance of the pedestrians' loops (centre lines), or None
            without pedestrians.
        road_side: the side the road passes: "north" (+y), "east" (+x), "south" or "west".
        road: ``(near, far)`` distance of the road's edges.
        cycle: the cycle path's two lanes ``(distance, direction)``; direction +1 goes
            along the side's tangent (+x on north and south, +y on east and west).
        cars: the car lanes ``(distance, direction)``.
        length: the road's length (m), centred on the side.
    """

    half: tuple[float, float]
    walk: tuple[float, float] | None
    road_side: str
    road: tuple[float, float]
    cycle: tuple[tuple[float, int], ...]
    cars: tuple[tuple[float, int], ...]
    length: float

    def _frame(self) -> tuple[float, tuple[float, float], tuple[float, float]]:
        """The road side's edge distance from the centre, outward normal and tangent."""
        hx, hy = self.half
        return {
            "north": (hy, (0.0, 1.0), (1.0, 0.0)),
            "east": (hx, (1.0, 0.0), (0.0, 1.0)),
            "south": (hy, (0.0, -1.0), (1.0, 0.0)),
            "west": (hx, (-1.0, 0.0), (0.0, 1.0)),
        }[self.road_side]

    def road_point(self, out: float, along: float) -> tuple[float, float]:
        """World ``(x, y)`` of the point ``out`` m beyond the road side's edge and ``along``
        m along its tangent from the side's middle."""
        edge, (nx, ny), (tx, ty) = self._frame()
        return nx * (edge + out) + tx * along, ny * (edge + out) + ty * along

    def road_rect(self) -> tuple[float, float, float, float]:
        """``(xmin, xmax, ymin, ymax)`` of the whole road, m."""
        (x0, y0), (x1, y1) = (
            self.road_point(self.road[0], -self.length / 2),
            self.road_point(self.road[1], self.length / 2),
        )
        return min(x0, x1), max(x0, x1), min(y0, y1), max(y0, y1)

    def road_heading(self, direction: int) -> float:
        """Heading (rad, counter-clockwise from +x) of a mover going ``direction`` (+1/-1)."""
        _, _, (tx, ty) = self._frame()
        return math.atan2(direction * ty, direction * tx)


def mover_lanes(spec: DynamicsSpec, arena_size: tuple[float, float], world_seed: int) -> Lanes:
    """The lanes of one world: the road's side is drawn from the world seed alone (the scene
    does not change from day to day), the rest comes from ``spec``.

    Args:
        spec: the dynamics (``road``, and the pedestrians' ``offset``).
        arena_size: the arena's ``(x, y)`` size, m.
        world_seed: the world's seed.
    """
    # a seed sequence of its own length: no stream of _rng(world_seed, day, stream) meets it
    side = SIDES[int(np.random.default_rng([int(world_seed), 7]).integers(len(SIDES)))]
    road = spec.road
    near = road.distance
    quarter = road.cycle_path / 4
    # traffic keeps to the right: the near lane goes along the tangent on the north and west
    # sides (+x, +y), against it on the others
    right = 1 if side in ("north", "west") else -1
    cars = tuple(
        (near + road.cycle_path + (j + 0.5) * road.lane_width, right if j % 2 == 0 else -right)
        for j in range(road.car_lanes)
    )
    offsets = [k.offset for k in spec.mover_kinds if k.kind == "pedestrian" and k.count]
    walk = None
    if offsets:
        walk = (min(o[0] for o in offsets), max(o[1] for o in offsets))  # type: ignore[index]
    return Lanes(
        half=(arena_size[0] / 2, arena_size[1] / 2),
        walk=walk,
        road_side=side,
        road=(near, near + road.width),
        cycle=((near + quarter, right), (near + 3 * quarter, -right)),
        cars=cars,
        length=road.length,
    )


@dataclass(frozen=True)
class _Mover:
    kind: str
    speed: float  # m/s along its path, > 0
    cycle: float  # length of its path (m): a pedestrian's loop, or the road
    phase: float  # where on its path it is at t = 0 (m)
    period: float  # schedule period (s)
    presence: float  # fraction of the period it is there
    shift: float  # schedule phase (s)
    rgb: tuple[float, float, float]
    # pedestrians: half sides of their loop (m) and its sense (+1 counter-clockwise)
    half: tuple[float, float] = (0.0, 0.0)
    sense: int = 1
    # cyclists and cars: their lane's distance from the arena's edge (m) and direction
    lane: float = 0.0
    direction: int = 1


def _rng(world_seed: int, day: int, stream: int) -> np.random.Generator:
    return np.random.default_rng([int(world_seed), int(day), stream])


def _draw_movers(spec: DynamicsSpec, lanes: Lanes, world_seed: int) -> list[_Mover]:
    """The movers of ``spec`` on ``lanes`` for the spec's day."""
    rng = _rng(world_seed, spec.day, 1)
    hx, hy = lanes.half
    movers: list[_Mover] = []
    for kind in spec.mover_kinds:
        road_lanes = lanes.cycle if kind.kind == "cyclist" else lanes.cars
        # which lane the kind's first mover takes; the others take the next ones in turn
        first = int(rng.integers(len(road_lanes))) if kind.kind != "pedestrian" else 0
        mine: list[_Mover] = []
        for j in range(kind.count):
            speed = float(rng.uniform(*kind.speed))
            sense = 1 if rng.random() < 0.5 else -1
            phase = float(rng.uniform(0, 1))  # a fraction of the path
            drawn: dict[str, Any] = {
                "kind": kind.kind,
                "period": float(rng.uniform(*kind.period_s)),
                "presence": float(rng.uniform(*kind.presence)),
                "shift": float(rng.uniform(0, 1)),
                "rgb": tuple(float(c) for c in rng.uniform(0.1, 0.9, 3)),
            }
            if kind.kind == "pedestrian":
                offset = float(rng.uniform(*kind.offset))  # type: ignore[misc]
                half = (hx + offset, hy + offset)
                cycle = 4 * (half[0] + half[1])
                mine.append(
                    _Mover(**drawn, speed=speed, cycle=cycle, phase=phase * cycle, half=half,
                           sense=sense)
                )  # fmt: skip
                continue
            n = len(road_lanes)
            lane, direction = road_lanes[(first + j) % n]
            rank, on_lane = j // n, len(range(j % n, kind.count, n))
            if rank:
                # a lane's later movers go at its first one's speed, evenly spaced behind it:
                # none drives through another
                lead = mine[j % n]
                speed, phase = lead.speed, (lead.phase / lead.cycle + rank / on_lane) % 1.0
            mine.append(
                _Mover(**drawn, speed=speed, cycle=lanes.length, phase=phase * lanes.length,
                       lane=lane, direction=direction)
            )  # fmt: skip
        movers += mine
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


def movers_mjcf(spec: DynamicsSpec, lanes: Lanes, world_seed: int) -> tuple[str, str]:
    """``(assets, worldbody)`` MJCF of the movers: mocap bodies ``mover0, mover1, ...``.

    The bodies exist whenever the spec declares movers, also with ``spec.movers`` off (they
    then stay away): switching movers off changes no other part of the model.
    """
    assets, bodies = [], []
    for i, m in enumerate(_draw_movers(spec, lanes, world_seed)):
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


def _loop_pose(m: _Mover, s: float) -> tuple[float, float, float]:
    """Position (x, y) and heading of a pedestrian ``s`` metres round its rectangular loop
    (counter-clockwise from the south-west corner; ``m.sense`` -1 walks it backwards)."""
    hx, hy = m.half
    sides = (2 * hx, 2 * hy, 2 * hx, 2 * hy)
    # counter-clockwise from the south-west corner: east, north, west, south
    corners = ((-hx, -hy), (hx, -hy), (hx, hy), (-hx, hy))
    headings = (0.0, math.pi / 2, math.pi, -math.pi / 2)
    for (x0, y0), heading, length in zip(corners, headings, sides, strict=True):
        if s <= length:
            x, y = x0 + s * math.cos(heading), y0 + s * math.sin(heading)
            return x, y, heading if m.sense > 0 else heading + math.pi
        s -= length
    return corners[0][0], corners[0][1], 0.0


def _pose(m: _Mover, lanes: Lanes, t: float) -> tuple[float, float, float, bool]:
    """``(x, y, heading, present)`` of mover ``m`` at time ``t`` (s): where it is on its path
    whether or not its schedule has it there."""
    travelled = m.phase + m.speed * t  # metres along its path since it first started it
    s = travelled % m.cycle
    if m.kind == "pedestrian":
        x, y, heading = _loop_pose(m, s if m.sense > 0 else (m.cycle - s) % m.cycle)
        return x, y, heading, ((t / m.period + m.shift) % 1.0) < m.presence
    # one pass from a far end of the road to the other; the pass is there or not as a whole,
    # by the schedule at the time it started, so cyclists and cars come and go far away
    start = (travelled - s - m.phase) / m.speed
    present = ((start / m.period + m.shift) % 1.0) < m.presence
    x, y = lanes.road_point(m.lane, m.direction * (s - m.cycle / 2))
    return x, y, lanes.road_heading(m.direction), present


def _check_road(model: Any, lanes: Lanes) -> None:
    """A ValueError when the model's road (the geom ``"road"``, when it has one) is not where
    ``lanes`` put it: the dynamics would drive cars beside the road the scene keeps free."""
    import mujoco

    g = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "road")
    if g < 0:
        return
    (x, y), (sx, sy) = model.geom_pos[g][:2], model.geom_size[g][:2]
    built = (x - sx, x + sx, y - sy, y + sy)
    if not np.allclose(built, lanes.road_rect(), atol=1e-3):
        raise ValueError(
            f"the world's road covers {tuple(round(float(v), 3) for v in built)} but the "
            f"dynamics' lanes put it at {tuple(round(v, 3) for v in lanes.road_rect())}: "
            "pass the lanes the world was built with (World.lanes), or a dynamics spec with "
            "the world's road"
        )


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
        _check_road(model, self.lanes)
        self._movers = _draw_movers(spec, self.lanes, world_seed)
        self._mocap = []
        for i in range(len(self._movers)):
            body = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, f"mover{i}")
            if body < 0 or model.body_mocapid[body] < 0:
                raise ValueError(f"the model has no mocap body 'mover{i}' (see movers_mjcf)")
            self._mocap.append(int(model.body_mocapid[body]))
        crng = _rng(world_seed, spec.day, 2)
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
        return np.array([_pose(m, self.lanes, float(t))[:3] for t in times])

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
            x, y, heading, here = _pose(m, self.lanes, t)
            if spec.movers and here:
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
