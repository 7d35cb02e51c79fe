"""Moving people and cars of a world's dynamics, on lanes the scene keeps free.

Pedestrians, cyclists and cars are MuJoCo mocap bodies (visual only: nothing collides with them)
on the world's :class:`Lanes` (:func:`mover_lanes`, from the dynamics spec and the world seed;
the scene builder keeps them free). Pedestrians walk loops round the pavement ring at their own
speed, distance and direction. Cyclists and cars keep to a straight road that passes the area
on one side (a two-way cycle path, then car lanes of alternating direction): each goes along its
lane from one far end to the other, out of sight there, and starts again. They come and go on
seeded schedules (absent movers wait below the ground); a cyclist or a car comes and goes only
at the road's far ends, a whole pass at a time. :class:`~sfa_gym.sim.worlds.dynamics.Dynamics`
moves them; this module draws them, places them at a time and writes their MJCF.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from sfa_gym._checks import check_int_in

__all__ = [
    "FOOTPRINT",
    "MOVER_KINDS",
    "SIDES",
    "Lanes",
    "MoverSpec",
    "RoadSpec",
    "mover_lanes",
    "movers_mjcf",
]

MOVER_KINDS = ("pedestrian", "cyclist", "car")
SIDES = ("north", "east", "south", "west")
# half sizes (m) of the movers' footprints: a pedestrian's radius, a cyclist's and a car's
# half length and half width (their bodies' geoms in :func:`_mover_geoms`)
FOOTPRINT = {"pedestrian": (0.25, 0.25), "cyclist": (0.9, 0.3), "car": (2.1, 0.92)}
_WALK = (0.5, 0.85)  # default distance of the pedestrians' loops from the arena's edge (m)
AWAY_Z = -50.0  # where an absent mover waits (m): below the ground, out of every view


def check_value(condition: bool, message: str) -> None:
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
        check_value(
            self.kind in MOVER_KINDS, f"mover kind must be one of {MOVER_KINDS}, got {self.kind!r}"
        )
        check_int_in("mover count", self.count, 0)
        if self.kind == "pedestrian" and self.offset is None:
            object.__setattr__(self, "offset", _WALK)
        check_value(
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
            check_value(
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
            check_value(
                isinstance(value, int | float) and math.isfinite(value) and value > 0,
                f"road {name} must be a positive number of metres, got {value!r}",
            )
        check_int_in("road car_lanes", self.car_lanes, 1)
        for kind, width in (("cyclist", self.cycle_path / 2), ("car", self.lane_width)):
            check_value(
                width >= 2 * FOOTPRINT[kind][1],
                f"road {'cycle_path / 2' if kind == 'cyclist' else 'lane_width'} must be at "
                f"least a {kind}'s width {2 * FOOTPRINT[kind][1]} m, got {width!r}",
            )
        check_value(
            self.length >= 8 * FOOTPRINT["car"][0],
            f"road length must be >= {8 * FOOTPRINT['car'][0]} m, got {self.length!r}",
        )

    @property
    def width(self) -> float:
        """Width of the whole road (m)."""
        return self.cycle_path + self.car_lanes * self.lane_width


class MoverSettings(Protocol):
    """What the movers read of a :class:`~sfa_gym.sim.worlds.dynamics.DynamicsSpec`."""

    @property
    def road(self) -> RoadSpec: ...
    @property
    def mover_kinds(self) -> tuple[MoverSpec, ...]: ...
    @property
    def day(self) -> int: ...


def default_movers() -> tuple[MoverSpec, ...]:
    return (
        MoverSpec("pedestrian", 3, (1.1, 1.5), _WALK),
        MoverSpec("cyclist", 1, (3.5, 4.5)),
        MoverSpec("car", 2, (5.0, 8.0), None, (0.2, 0.5), (40.0, 120.0)),
    )


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


def mover_lanes(spec: MoverSettings, arena_size: tuple[float, float], world_seed: int) -> Lanes:
    """The lanes of one world: the road's side is drawn from the world seed alone (the scene
    does not change from day to day), the rest comes from ``spec``.

    Args:
        spec: the dynamics (``road``, and the pedestrians' ``offset``).
        arena_size: the arena's ``(x, y)`` size, m.
        world_seed: the world's seed.
    """
    # a seed sequence of its own length: no stream of seeded_rng(world_seed, day, stream) meets it
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


def seeded_rng(world_seed: int, day: int, stream: int) -> np.random.Generator:
    return np.random.default_rng([int(world_seed), int(day), stream])


def draw_movers(spec: MoverSettings, lanes: Lanes, world_seed: int) -> list[_Mover]:
    """The movers of ``spec`` on ``lanes`` for the spec's day."""
    rng = seeded_rng(world_seed, spec.day, 1)
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


def movers_mjcf(spec: MoverSettings, lanes: Lanes, world_seed: int) -> tuple[str, str]:
    """``(assets, worldbody)`` MJCF of the movers: mocap bodies ``mover0, mover1, ...``.

    The bodies exist whenever the spec declares movers, also with ``spec.movers`` off (they
    then stay away): switching movers off changes no other part of the model.
    """
    assets, bodies = [], []
    for i, m in enumerate(draw_movers(spec, lanes, world_seed)):
        material = f"mover{i}_paint"
        assets.append(
            f'<material name="{material}" rgba="{" ".join(_f(c) for c in m.rgb)} 1" '
            f'specular="0" shininess="0"/>'
        )
        geoms = "\n".join(f"  {g}" for g in _mover_geoms(m, material))
        bodies.append(
            f'<body name="mover{i}" mocap="true" pos="0 0 {_f(AWAY_Z)}">\n{geoms}\n</body>'
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


def mover_pose(m: _Mover, lanes: Lanes, t: float) -> tuple[float, float, float, bool]:
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


def check_road(model: Any, lanes: Lanes) -> None:
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
