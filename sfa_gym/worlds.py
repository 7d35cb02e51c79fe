"""Worlds as data: a JSON world spec plus a world seed -> a MuJoCo model (MJCF text).

A world is a walled, flat arena that the rover drives in, surrounded by landmarks (trees,
coloured pillars, blocks) standing outside the walls, under a gradient sky. The spec (see
``envs/paper_sim.json``) fixes the geometry and the *ranges* of colours, textures, sizes and
counts; the world seed draws one world from those ranges with ``np.random.default_rng``:
the same spec and seed give the identical MJCF string, another seed gives another world.

Lighting is chosen for an omnidirectional camera made of several pinhole cameras: the
headlight (which MuJoCo attaches to whichever camera renders) carries ambient light only,
because a directional headlight would light a surface differently in each pinhole camera
and leave seams in the panorama; fixed directional lights from several azimuths make sure
that no wall face is black. Materials are matte (no specular highlights) for the same reason.
Shadows are off (``shadowsize=0``, ``castshadow="false"``): they make software rendering
about 40 times slower.

This module does not import ``mujoco``: it produces text, which the env compiles.
"""

from __future__ import annotations

import colorsys
import json
import math
import os
import types
import typing
from dataclasses import dataclass, fields, is_dataclass
from pathlib import Path
from typing import Any

import numpy as np

from sfa_gym.data import envs_dir

TEXTURE_KINDS = ("checker", "gradient", "flat")
LANDMARK_KINDS = ("tree", "pillar", "box")
OBSTACLE_KINDS = ("box", "cylinder")


def _check_range(value: tuple[float, float], name: str, *, low: float | None = None) -> None:
    if len(value) != 2 or value[0] > value[1]:
        raise ValueError(f"{name} must be a [min, max] pair with min <= max, got {list(value)}")
    if low is not None and value[0] < low:
        raise ValueError(f"{name} must be >= {low}, got {list(value)}")


def _check_positive(value: float, name: str) -> None:
    if not value > 0:
        raise ValueError(f"{name} must be positive, got {value!r}")


@dataclass(frozen=True)
class ColourRange:
    """Colours drawn uniformly in HSV; each field is a ``[min, max]`` pair within [0, 1]."""

    hue: tuple[float, float] = (0.0, 1.0)
    saturation: tuple[float, float] = (0.3, 0.9)
    value: tuple[float, float] = (0.4, 0.9)

    def __post_init__(self) -> None:
        for f in fields(self):
            _check_range(getattr(self, f.name), f"colour {f.name}", low=0.0)
            if getattr(self, f.name)[1] > 1.0:
                raise ValueError(f"colour {f.name} must lie in [0, 1], got {getattr(self, f.name)}")

    def draw(self, rng: np.random.Generator) -> tuple[float, float, float]:
        """One RGB colour in [0, 1]^3."""
        h, s, v = (rng.uniform(*getattr(self, name)) for name in ("hue", "saturation", "value"))
        return colorsys.hsv_to_rgb(h % 1.0, s, v)


@dataclass(frozen=True)
class SurfaceSpec:
    """A textured surface (floor, ground or wall panel).

    Attributes:
        textures: builtin MuJoCo texture kinds to choose from: "checker", "gradient", "flat".
        colours: range of the two texture colours.
        repeat: range of texture repeats per metre.
        marks: fraction of texels replaced by random marks (noise), in [0, 1].
    """

    textures: tuple[str, ...] = ("checker", "gradient", "flat")
    colours: ColourRange = ColourRange()
    repeat: tuple[float, float] = (0.5, 2.0)
    marks: float = 0.05

    def __post_init__(self) -> None:
        if not self.textures or any(t not in TEXTURE_KINDS for t in self.textures):
            raise ValueError(
                f"textures must be a non-empty subset of {TEXTURE_KINDS}, got {self.textures}"
            )
        _check_range(self.repeat, "repeat", low=1e-3)
        if not 0.0 <= self.marks <= 1.0:
            raise ValueError(f"marks must lie in [0, 1], got {self.marks}")


@dataclass(frozen=True)
class ArenaSpec:
    """The walled arena, centred on the world origin (metres).

    Attributes:
        size: inner size (x, y) between the walls.
        margin: distance kept between the drivable area and the walls, so that the rover
            (about 0.5 m square) fits at every position of the drivable area.
        wall_height: height of the walls.
        wall_thickness: thickness of the walls.
        panels_per_wall: each wall is split into this many panels with their own texture.
    """

    size: tuple[float, float] = (7.0, 7.0)
    margin: float = 0.5
    wall_height: float = 0.8
    wall_thickness: float = 0.1
    panels_per_wall: int = 4

    def __post_init__(self) -> None:
        for i, s in enumerate(self.size):
            _check_positive(s, f"arena size[{i}]")
        for name in ("margin", "wall_height", "wall_thickness"):
            _check_positive(getattr(self, name), f"arena {name}")
        if self.panels_per_wall < 1:
            raise ValueError(f"panels_per_wall must be >= 1, got {self.panels_per_wall}")
        if min(self.size) <= 2 * self.margin:
            raise ValueError(
                f"arena size {self.size} leaves no drivable area with margin {self.margin}"
            )

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        """Drivable area ``(xmin, xmax, ymin, ymax)``: the inner area less the margin."""
        hx, hy = self.size[0] / 2 - self.margin, self.size[1] / 2 - self.margin
        return (-hx, hx, -hy, hy)


@dataclass(frozen=True)
class LandmarkKind:
    """One kind of landmark and how many of it stand around the arena.

    Attributes:
        kind: "tree" (trunk and crown), "pillar" (upright cylinder) or "box" (a block).
        count: how many.
        height: range of heights (m).
        width: range of widths (m): crown or pillar diameter, block side.
        colours: range of colours (the crown for trees).
    """

    kind: str
    count: int
    height: tuple[float, float]
    width: tuple[float, float]
    colours: ColourRange = ColourRange()

    def __post_init__(self) -> None:
        if self.kind not in LANDMARK_KINDS:
            raise ValueError(f"landmark kind must be one of {LANDMARK_KINDS}, got {self.kind!r}")
        if self.count < 0:
            raise ValueError(f"landmark count must be >= 0, got {self.count}")
        _check_range(self.height, "landmark height", low=1e-3)
        _check_range(self.width, "landmark width", low=1e-3)


@dataclass(frozen=True)
class LandmarksSpec:
    """Landmarks outside the walls, spread evenly over the azimuth around the arena centre.

    Attributes:
        clearance: minimum distance between a landmark's footprint and the walls (m).
        depth: landmarks stand up to ``clearance + depth`` beyond the walls (m).
        min_gap: minimum gap between two landmark footprints (m).
        kinds: the landmark kinds and counts.
    """

    clearance: float = 0.5
    depth: float = 4.0
    min_gap: float = 0.3
    kinds: tuple[LandmarkKind, ...] = ()

    def __post_init__(self) -> None:
        _check_positive(self.clearance, "landmarks clearance")
        _check_positive(self.depth, "landmarks depth")
        if self.min_gap < 0:
            raise ValueError(f"landmarks min_gap must be >= 0, got {self.min_gap}")


@dataclass(frozen=True)
class ObstaclesSpec:
    """Sparse obstacles inside the drivable area (for navigation worlds; none by default).

    Attributes:
        count: number of obstacles.
        kinds: shapes to choose from: "box", "cylinder".
        height: range of heights (m).
        width: range of widths (m).
        min_gap: minimum free gap between obstacles, and between obstacles and walls (m);
            keep it above the rover's width so that obstacles never close a passage.
        colours: range of colours.
    """

    count: int = 0
    kinds: tuple[str, ...] = ("box", "cylinder")
    height: tuple[float, float] = (0.3, 0.6)
    width: tuple[float, float] = (0.2, 0.4)
    min_gap: float = 1.0
    colours: ColourRange = ColourRange()

    def __post_init__(self) -> None:
        if self.count < 0:
            raise ValueError(f"obstacle count must be >= 0, got {self.count}")
        if not self.kinds or any(k not in OBSTACLE_KINDS for k in self.kinds):
            raise ValueError(
                f"obstacle kinds must be a subset of {OBSTACLE_KINDS}, got {self.kinds}"
            )
        _check_range(self.height, "obstacle height", low=1e-3)
        _check_range(self.width, "obstacle width", low=1e-3)


@dataclass(frozen=True)
class DirectionalLight:
    """A directional light shining from ``azimuth_deg`` (from +x, counter-clockwise) and
    ``elevation_deg`` above the horizon, with diffuse intensity ``diffuse`` (0..1)."""

    azimuth_deg: float
    elevation_deg: float
    diffuse: float

    def __post_init__(self) -> None:
        if not 0.0 < self.elevation_deg <= 90.0:
            raise ValueError(f"light elevation_deg must lie in (0, 90], got {self.elevation_deg}")
        if not 0.0 <= self.diffuse <= 1.0:
            raise ValueError(f"light diffuse must lie in [0, 1], got {self.diffuse}")


@dataclass(frozen=True)
class LightsSpec:
    """Ambient light (carried by the headlight) and fixed directional lights.

    Attributes:
        ambient: ambient intensity (0..1) that reaches every face.
        directional: the directional lights.
        jitter_deg: each light's azimuth and elevation vary by up to this much per world.
    """

    ambient: float = 0.35
    directional: tuple[DirectionalLight, ...] = ()
    jitter_deg: float = 0.0

    def __post_init__(self) -> None:
        if not 0.0 <= self.ambient <= 1.0:
            raise ValueError(f"ambient must lie in [0, 1], got {self.ambient}")
        if self.jitter_deg < 0:
            raise ValueError(f"jitter_deg must be >= 0, got {self.jitter_deg}")


@dataclass(frozen=True)
class SkySpec:
    """A gradient skybox from ``zenith`` colours to ``horizon`` colours."""

    zenith: ColourRange = ColourRange((0.55, 0.65), (0.5, 0.8), (0.6, 0.9))
    horizon: ColourRange = ColourRange((0.55, 0.65), (0.05, 0.25), (0.85, 1.0))


@dataclass(frozen=True)
class WorldSpec:
    """Everything that defines a family of worlds; one world seed picks one member.

    Load one with :func:`load_world_spec`. Lengths in metres, angles in degrees.
    """

    name: str
    description: str = ""
    arena: ArenaSpec = ArenaSpec()
    floor: SurfaceSpec = SurfaceSpec()
    ground: SurfaceSpec = SurfaceSpec()
    walls: SurfaceSpec = SurfaceSpec()
    landmarks: LandmarksSpec = LandmarksSpec()
    obstacles: ObstaclesSpec = ObstaclesSpec()
    lights: LightsSpec = LightsSpec()
    sky: SkySpec = SkySpec()


def _convert(value: Any, hint: Any, where: str) -> Any:
    """Turn parsed JSON into the type ``hint`` (dataclass, tuple, float, int, str)."""
    origin = typing.get_origin(hint)
    if is_dataclass(hint):
        return _from_dict(hint, value, where)
    if origin in (typing.Union, types.UnionType):
        return _convert(value, next(a for a in typing.get_args(hint) if a is not type(None)), where)
    if origin is tuple:
        if not isinstance(value, list | tuple):
            raise ValueError(f"{where} must be a list, got {value!r}")
        args = typing.get_args(hint)
        if len(args) == 2 and args[1] is Ellipsis:
            return tuple(_convert(v, args[0], f"{where}[{i}]") for i, v in enumerate(value))
        if len(value) != len(args):
            raise ValueError(f"{where} must have {len(args)} entries, got {value!r}")
        return tuple(
            _convert(v, a, f"{where}[{i}]")
            for i, (v, a) in enumerate(zip(value, args, strict=True))
        )
    if hint is float:
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise ValueError(f"{where} must be a number, got {value!r}")
        return float(value)
    if hint is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise ValueError(f"{where} must be an integer, got {value!r}")
        return value
    if hint is str:
        if not isinstance(value, str):
            raise ValueError(f"{where} must be a string, got {value!r}")
        return value
    raise TypeError(f"unsupported field type {hint!r} at {where}")


def _from_dict(cls: type, data: Any, where: str) -> Any:
    if not isinstance(data, dict):
        raise ValueError(f"{where} must be a JSON object, got {data!r}")
    hints = typing.get_type_hints(cls)
    names = {f.name for f in fields(cls)}
    unknown = sorted(set(data) - names)
    if unknown:
        raise ValueError(f"{where}: unknown keys {unknown}; expected some of {sorted(names)}")
    kwargs = {k: _convert(v, hints[k], f"{where}.{k}") for k, v in data.items()}
    try:
        return cls(**kwargs)
    except TypeError as e:
        raise ValueError(f"{where}: {e}") from e


def world_spec_from_dict(data: dict[str, Any]) -> WorldSpec:
    """Build a validated :class:`WorldSpec` from parsed JSON; errors name the bad key."""
    return _from_dict(WorldSpec, data, "world")


def available_worlds() -> list[str]:
    """Names of the world specs shipped with the package (``envs/*.json``)."""
    return sorted(p.stem for p in envs_dir().glob("*.json"))


def load_world_spec(world: str | os.PathLike[str]) -> WorldSpec:
    """Load a world spec by name (``"paper_sim"``) or from a path to a JSON file.

    Raises:
        ValueError: no such world, or the file is not a valid spec (the message says where).
    """
    path = Path(world)
    if path.suffix != ".json":
        path = envs_dir() / f"{world}.json"
        if not path.is_file():
            raise ValueError(f"unknown world {str(world)!r}; available: {available_worlds()}")
    elif not path.is_file():
        raise ValueError(f"world spec file {str(path)!r} does not exist")
    with open(path, encoding="utf-8") as f:
        data = json.load(f)
    return world_spec_from_dict(data)


@dataclass(frozen=True)
class MJCFParts:
    """Pieces of MJCF that a robot contributes to a world model (XML text, possibly empty)."""

    assets: str = ""
    worldbody: str = ""
    actuators: str = ""
    sensors: str = ""
    contacts: str = ""


@dataclass(frozen=True)
class WorldLayout:
    """Where things are in one generated world (metres, world frame).

    Attributes:
        bounds: drivable area ``(xmin, xmax, ymin, ymax)``.
        obstacles: ``(x, y, radius)`` of each obstacle's bounding circle inside the arena.
        landmarks: ``(kind, x, y, height)`` of each landmark outside the walls.
    """

    bounds: tuple[float, float, float, float]
    obstacles: tuple[tuple[float, float, float], ...]
    landmarks: tuple[tuple[str, float, float, float], ...]


@dataclass(frozen=True)
class World:
    """A generated world: the full MJCF text and its layout."""

    mjcf: str
    layout: WorldLayout


def _num(x: float) -> str:
    # Fixed precision keeps the MJCF text identical for identical seeds on every platform.
    s = f"{x:.4f}".rstrip("0").rstrip(".")
    return "0" if s in ("-0", "") else s


def _vec(*xs: float) -> str:
    return " ".join(_num(x) for x in xs)


class _Builder:
    """Accumulates assets and geoms while drawing from one random generator, in a fixed order."""

    def __init__(self, spec: WorldSpec, rng: np.random.Generator):
        self.spec = spec
        self.rng = rng
        self.assets: list[str] = []
        self.body: list[str] = []
        self.n_materials = 0

    def plain_material(self, rgb: tuple[float, float, float]) -> str:
        name = f"mat{self.n_materials}"
        self.n_materials += 1
        self.assets.append(
            f'<material name="{name}" rgba="{_vec(*rgb, 1.0)}" specular="0" shininess="0"/>'
        )
        return name

    def surface_material(self, surface: SurfaceSpec) -> str:
        """A textured material drawn from ``surface``: kind, two colours, repeat, marks."""
        rng = self.rng
        kind = surface.textures[int(rng.integers(len(surface.textures)))]
        rgb1, rgb2 = surface.colours.draw(rng), surface.colours.draw(rng)
        mark_rgb = surface.colours.draw(rng)
        repeat = rng.uniform(*surface.repeat)
        name = f"mat{self.n_materials}"
        self.n_materials += 1
        marks = ""
        if surface.marks > 0:
            marks = f' mark="random" random="{_num(surface.marks)}" markrgb="{_vec(*mark_rgb)}"'
        self.assets.append(
            f'<texture name="tex_{name}" type="2d" builtin="{kind}" rgb1="{_vec(*rgb1)}" '
            f'rgb2="{_vec(*rgb2)}" width="128" height="128"{marks}/>'
        )
        self.assets.append(
            f'<material name="{name}" texture="tex_{name}" texrepeat="{_vec(repeat, repeat)}" '
            f'texuniform="true" specular="0" shininess="0"/>'
        )
        return name


def _wall_panels(b: _Builder) -> None:
    arena = b.spec.arena
    hx, hy = arena.size[0] / 2, arena.size[1] / 2
    t, h, n = arena.wall_thickness, arena.wall_height, arena.panels_per_wall
    # Walls run counter-clockwise; the x walls are long enough to cover the corners.
    walls = [
        ((-hx - t, hx + t), -hy - t / 2, "x"),
        ((-hy, hy), hx + t / 2, "y"),
        ((hx + t, -hx - t), hy + t / 2, "x"),
        ((hy, -hy), -hx - t / 2, "y"),
    ]
    for w, ((a0, a1), offset, axis) in enumerate(walls):
        for p in range(n):
            s0 = a0 + (a1 - a0) * p / n
            s1 = a0 + (a1 - a0) * (p + 1) / n
            mid, half = (s0 + s1) / 2, abs(s1 - s0) / 2
            mat = b.surface_material(b.spec.walls)
            # Every panel is thin along its local x axis and turned into place: MuJoCo maps a
            # 2d texture well onto faces spanned by the local y and z axes, but smears it into
            # stripes on faces spanned by x and z.
            pos = (mid, offset, h / 2) if axis == "x" else (offset, mid, h / 2)
            yaw = 90 if axis == "x" else 0
            b.body.append(
                f'<geom name="wall{w}_{p}" type="box" pos="{_vec(*pos)}" '
                f'size="{_vec(t / 2, half, h / 2)}" euler="0 0 {yaw}" material="{mat}"/>'
            )


def _square_distance(azimuth: float, hx: float, hy: float) -> float:
    """Distance from the centre to the rectangle ``|x| <= hx, |y| <= hy`` along ``azimuth``."""
    c, s = abs(math.cos(azimuth)), abs(math.sin(azimuth))
    return min(hx / c if c > 1e-9 else math.inf, hy / s if s > 1e-9 else math.inf)


def _landmarks(b: _Builder) -> list[tuple[str, float, float, float]]:
    spec, rng = b.spec.landmarks, b.rng
    kinds = [k for k in spec.kinds for _ in range(k.count)]
    order = rng.permutation(len(kinds))
    n = len(kinds)
    hx = b.spec.arena.size[0] / 2 + b.spec.arena.wall_thickness
    hy = b.spec.arena.size[1] / 2 + b.spec.arena.wall_thickness
    offset = rng.uniform(0, 2 * math.pi)
    placed: list[tuple[float, float, float]] = []
    out = []
    for slot, idx in enumerate(order):
        kind = kinds[idx]
        height = rng.uniform(*kind.height)
        width = rng.uniform(*kind.width)
        radius = width / 2 if kind.kind != "box" else width / math.sqrt(2)
        # One landmark per azimuth sector so that every viewing direction sees some; within
        # its sector the landmark moves until it clears the others.
        for _ in range(100):
            az = offset + (slot + rng.uniform(0.1, 0.9)) * 2 * math.pi / n
            r = _square_distance(az, hx, hy) + spec.clearance + radius
            r += rng.uniform(0, spec.depth)
            x, y = r * math.cos(az), r * math.sin(az)
            if all(
                math.hypot(x - px, y - py) >= radius + pr + spec.min_gap for px, py, pr in placed
            ):
                break
        else:
            raise ValueError(
                f"cannot place {n} landmarks apart by min_gap {spec.min_gap}: "
                "increase landmarks depth or reduce their counts or widths"
            )
        placed.append((x, y, radius))
        out.append((kind.kind, x, y, height))
        colour = kind.colours.draw(rng)
        i = len(out) - 1
        if kind.kind == "pillar":
            mat = b.plain_material(colour)
            b.body.append(
                f'<geom name="landmark{i}" type="cylinder" pos="{_vec(x, y, height / 2)}" '
                f'size="{_vec(width / 2, height / 2)}" material="{mat}" contype="0" '
                f'conaffinity="0"/>'
            )
        elif kind.kind == "box":
            mat = b.plain_material(colour)
            depth = width * rng.uniform(0.5, 1.0)
            yaw = rng.uniform(0, 180)
            b.body.append(
                f'<geom name="landmark{i}" type="box" pos="{_vec(x, y, height / 2)}" '
                f'size="{_vec(width / 2, depth / 2, height / 2)}" euler="0 0 {_num(yaw)}" '
                f'material="{mat}" contype="0" conaffinity="0"/>'
            )
        else:
            trunk_h = height * rng.uniform(0.35, 0.55)
            trunk_r = max(0.04, width * 0.08)
            bark = b.plain_material(ColourRange((0.05, 0.1), (0.4, 0.7), (0.2, 0.4)).draw(rng))
            crown = b.plain_material(colour)
            crown_h = height - trunk_h
            b.body.append(
                f'<geom name="landmark{i}" type="cylinder" pos="{_vec(x, y, trunk_h / 2)}" '
                f'size="{_vec(trunk_r, trunk_h / 2)}" material="{bark}" contype="0" '
                f'conaffinity="0"/>'
            )
            b.body.append(
                f'<geom name="landmark{i}_crown" type="ellipsoid" '
                f'pos="{_vec(x, y, trunk_h + crown_h * 0.45)}" '
                f'size="{_vec(width / 2, width / 2, crown_h * 0.55)}" material="{crown}" '
                f'contype="0" conaffinity="0"/>'
            )
    return out


def _obstacles(b: _Builder) -> list[tuple[float, float, float]]:
    spec, rng = b.spec.obstacles, b.rng
    xmin, xmax, ymin, ymax = b.spec.arena.bounds
    placed: list[tuple[float, float, float]] = []
    for i in range(spec.count):
        kind = spec.kinds[int(rng.integers(len(spec.kinds)))]
        width, height = rng.uniform(*spec.width), rng.uniform(*spec.height)
        radius = width / 2 if kind == "cylinder" else width / math.sqrt(2)
        hx = b.spec.arena.size[0] / 2 - radius - spec.min_gap
        hy = b.spec.arena.size[1] / 2 - radius - spec.min_gap
        for _ in range(1000):
            x, y = rng.uniform(-hx, hx), rng.uniform(-hy, hy)
            if all(
                math.hypot(x - px, y - py) >= radius + pr + spec.min_gap for px, py, pr in placed
            ):
                break
        else:
            raise ValueError(
                f"cannot place {spec.count} obstacles apart by min_gap {spec.min_gap} in the arena"
            )
        placed.append((x, y, radius))
        mat = b.plain_material(spec.colours.draw(rng))
        shape = (
            f'type="cylinder" size="{_vec(width / 2, height / 2)}"'
            if kind == "cylinder"
            else f'type="box" size="{_vec(width / 2, width / 2, height / 2)}"'
        )
        b.body.append(
            f'<geom name="obstacle{i}" {shape} pos="{_vec(x, y, height / 2)}" material="{mat}"/>'
        )
    return placed


def _lights(b: _Builder) -> None:
    lights = b.spec.lights
    for i, light in enumerate(lights.directional):
        az = math.radians(light.azimuth_deg + b.rng.uniform(-1, 1) * lights.jitter_deg)
        el = light.elevation_deg + b.rng.uniform(-1, 1) * lights.jitter_deg
        el = math.radians(min(90.0, max(1.0, el)))
        # The light shines *from* (az, el), so its direction points the other way.
        d = (-math.cos(el) * math.cos(az), -math.cos(el) * math.sin(az), -math.sin(el))
        b.body.append(
            f'<light name="sun{i}" type="directional" dir="{_vec(*d)}" '
            f'diffuse="{_vec(*(light.diffuse,) * 3)}" specular="0 0 0" ambient="0 0 0" '
            f'castshadow="false"/>'
        )


def build_world(spec: WorldSpec, world_seed: int = 0, robot: MJCFParts | None = None) -> World:
    """Generate one world of ``spec`` from ``world_seed``, optionally with a robot in it.

    Args:
        spec: the world spec.
        world_seed: seed of ``np.random.default_rng``; same seed -> identical MJCF text.
        robot: the robot's MJCF pieces (its bodies go into the worldbody).

    Returns:
        The MJCF text of the whole model and the world's layout. The model contains a fixed
        camera ``"overhead"`` looking straight down on the arena.
    """
    if isinstance(world_seed, bool) or not isinstance(world_seed, int | np.integer):
        raise TypeError(f"world_seed must be an integer, got {world_seed!r}")
    if world_seed < 0:
        raise ValueError(f"world_seed must be >= 0, got {world_seed}")
    robot = robot or MJCFParts()
    rng = np.random.default_rng(int(world_seed))
    b = _Builder(spec, rng)
    arena = spec.arena
    hx, hy = arena.size[0] / 2, arena.size[1] / 2

    zenith, horizon = spec.sky.zenith.draw(rng), spec.sky.horizon.draw(rng)
    b.assets.append(
        f'<texture name="sky" type="skybox" builtin="gradient" rgb1="{_vec(*zenith)}" '
        f'rgb2="{_vec(*horizon)}" width="256" height="1536"/>'
    )
    ground = b.surface_material(spec.ground)
    floor = b.surface_material(spec.floor)
    reach = max(hx, hy) + arena.wall_thickness + spec.landmarks.clearance + spec.landmarks.depth
    ground_half = 4 * reach
    _wall_panels(b)
    # The rover drives on the ground plane (plane contacts are exact and cheap); the floor
    # is a visual tile lying a millimetre above it.
    b.body.append(
        f'<geom name="floor" type="box" pos="0 0 -0.004" size="{_vec(hx, hy, 0.005)}" '
        f'material="{floor}" contype="0" conaffinity="0"/>'
    )
    obstacles = _obstacles(b)
    landmarks = _landmarks(b)
    # Geoms are drawn in model order: near occluders first and the ground last lets the
    # depth test discard hidden ground pixels early (about 10 % faster on llvmpipe). The
    # plane's third size is its rendering grid: with directional and ambient light only, one
    # coarse grid looks like a fine one and renders faster.
    b.body.append(
        f'<geom name="ground" type="plane" size="{_vec(ground_half, ground_half, ground_half)}" '
        f'material="{ground}"/>'
    )
    _lights(b)

    view_half = max(hx, hy) + arena.wall_thickness + 1.2
    cam_height = 2.5 * view_half
    fovy = 2 * math.degrees(math.atan(view_half / cam_height))
    b.body.append(
        f'<camera name="overhead" pos="0 0 {_num(cam_height)}" xyaxes="1 0 0 0 1 0" '
        f'fovy="{_num(fovy)}"/>'
    )

    amb = spec.lights.ambient
    mjcf = "\n".join(
        [
            f'<mujoco model="sfa_gym_{spec.name}_{int(world_seed)}">',
            '  <compiler angle="degree" autolimits="true"/>',
            # implicitfast keeps stiff wheel velocity servos stable at 5 ms steps; the noslip
            # pass stops a skid-steer rover from chattering (losing ground contact) in turns.
            '  <option timestep="0.005" integrator="implicitfast" noslip_iterations="5"/>',
            f'  <statistic center="0 0 0.5" extent="{_num(reach)}"/>',
            "  <visual>",
            # No shadows (40x slower on a software rasteriser); coarse tessellation of round
            # shapes and one quad per box face: the panoramas are small.
            '    <quality shadowsize="0" numslices="16" numstacks="8" numquads="1"/>',
            '    <global offwidth="1024" offheight="1024"/>',
            f'    <headlight ambient="{_vec(amb, amb, amb)}" diffuse="0 0 0" specular="0 0 0"/>',
            '    <map znear="0.005" zfar="10"/>',
            "  </visual>",
            "  <asset>",
            *(f"    {a}" for a in b.assets),
            robot.assets,
            "  </asset>",
            "  <worldbody>",
            *(f"    {g}" for g in b.body),
            robot.worldbody,
            "  </worldbody>",
            f"  <actuator>{robot.actuators}</actuator>",
            f"  <sensor>{robot.sensors}</sensor>",
            f"  <contact>{robot.contacts}</contact>",
            "</mujoco>",
        ]
    )
    layout = WorldLayout(
        bounds=arena.bounds,
        obstacles=tuple(obstacles),
        landmarks=tuple(landmarks),
    )
    return World(mjcf=mjcf, layout=layout)
