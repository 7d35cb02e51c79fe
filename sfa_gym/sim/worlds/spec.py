"""Worlds as data: a JSON world spec plus a world seed -> a MuJoCo model (MJCF text).

A world is a walled, flat arena that the rover drives in, surrounded by landmarks (trees,
coloured pillars, blocks) standing outside the walls, under a gradient sky; navigation worlds
add obstacles and interior walls inside the arena. The spec (see
``envs/paper_sim.json``) fixes the geometry and the *ranges* of colours, textures, sizes and
counts; the world seed draws one world from those ranges with ``np.random.default_rng``:
the same spec and seed give the identical MJCF string, another seed gives another world.

Outdoor worlds (``envs/paper_outdoor.json``) replace the walls by curbs or painted markings
(``arena.boundary``) and add an ``outdoor`` block: pavement, grass, building facades, trees,
parked cars, fences, lamp posts and bushes around the area (drawn by
:mod:`sfa_gym.sim.worlds.outdoor`), lit by a light named ``"sun"`` (``lights.sun``). A
``dynamics`` block declares what changes while the rover drives (the sun over the day,
clouds, moving people and cars; see
:mod:`sfa_gym.sim.worlds.dynamics`).

Lighting is chosen for an omnidirectional camera made of several pinhole cameras: the
headlight (which MuJoCo attaches to whichever camera renders) carries ambient light only,
because a directional headlight would light a surface differently in each pinhole camera
and leave seams in the panorama; fixed directional lights from several azimuths make sure
that no wall face is black. Materials are matte (no specular highlights) for the same reason.
Shadows are off (``shadowsize=0``, ``castshadow="false"``): they make software rendering
about 40 times slower.

This module does not import ``mujoco``: it produces text, which the env compiles. It is
longer than most because every block of a world spec's JSON has its validated dataclass here
(read by :func:`sfa_gym._json_types.dataclass_from_json`).
"""

from __future__ import annotations

import colorsys
import json
import math
import os
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any

import numpy as np

from sfa_gym._checks import check_int_in
from sfa_gym._json_types import dataclass_from_json
from sfa_gym.sim.worlds.data import envs_dir
from sfa_gym.sim.worlds.dynamics import DynamicsSpec
from sfa_gym.sim.worlds.textures import TexturesSpec

TEXTURE_KINDS = ("checker", "gradient", "flat")
LANDMARK_KINDS = ("tree", "pillar", "box")
BOUNDARY_KINDS = ("walls", "curbs", "markings")
OBSTACLE_KINDS = ("box", "cylinder")


def _check_range(value: tuple[float, float], name: str, *, low: float | None = None) -> None:
    if len(value) != 2 or value[0] > value[1]:
        raise ValueError(f"{name} must be a [min, max] pair with min <= max, got {list(value)}")
    if low is not None and value[0] < low:
        raise ValueError(f"{name} must be >= {low}, got {list(value)}")


def _check_items(spec: Any, what: str) -> None:
    """The ``count``, ``height`` and ``width`` of a spec of ``what`` (items of drawn sizes)."""
    if spec.count < 0:
        raise ValueError(f"{what} count must be >= 0, got {spec.count}")
    _check_range(spec.height, f"{what} height", low=1e-3)
    _check_range(spec.width, f"{what} width", low=1e-3)


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


MAX_ARENA_SIZE = 2000.0
"""The largest side of an arena, metres."""


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
        boundary: what bounds the arena: "walls" (panels of ``wall_height``), "curbs" (low
            concrete boxes of ``curb_height`` that the rover collides with) or "markings" (a
            painted line on the floor, visual only). Curbs stand just outside ``size`` like
            the walls, the line just inside it; the wall fields only apply to "walls".
        curb_height: height of the curbs (m).
        border_width: width of a curb or of the painted line (m).
    """

    size: tuple[float, float] = (7.0, 7.0)
    margin: float = 0.5
    wall_height: float = 0.8
    wall_thickness: float = 0.1
    panels_per_wall: int = 4
    boundary: str = "walls"
    curb_height: float = 0.12
    border_width: float = 0.15

    def __post_init__(self) -> None:
        if self.boundary not in BOUNDARY_KINDS:
            raise ValueError(
                f"arena boundary must be one of {BOUNDARY_KINDS}, got {self.boundary!r}"
            )
        for name in ("curb_height", "border_width"):
            _check_positive(getattr(self, name), f"arena {name}")
        for i, s in enumerate(self.size):
            _check_positive(s, f"arena size[{i}]")
            if s > MAX_ARENA_SIZE:
                raise ValueError(
                    f"arena size[{i}] = {s} m is larger than {MAX_ARENA_SIZE:g} m: the walls, the "
                    "grids and the fields scale with it (a campus is a few hundred metres)"
                )
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
        _check_items(self, "landmark")


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
        _check_items(self, "obstacle")
        if not self.kinds or any(k not in OBSTACLE_KINDS for k in self.kinds):
            raise ValueError(
                f"obstacle kinds must be a subset of {OBSTACLE_KINDS}, got {self.kinds}"
            )


@dataclass(frozen=True)
class InteriorWallsSpec:
    """Straight walls inside the arena (for navigation worlds; none by default).

    They are textured like the arena walls (panels drawn from the ``walls`` surface) and
    collide with the rover like them. Their panels are drawn after everything else in the
    world, so adding interior walls to a spec leaves the rest of its worlds unchanged.

    Attributes:
        segments: centre lines ``[x0, y0, x1, y1]`` (m, world frame); each end must lie within
            the arena's inner area. A wall is a box of the segment's length and ``thickness``;
            walls that meet at an end leave a notch of ``thickness / 2`` at the outer corner.
        thickness: thickness of every wall (m).
        height: height of every wall (m).
        panel_length: each wall is split into equal panels no longer than this (m), each with
            its own texture.
    """

    segments: tuple[tuple[float, float, float, float], ...] = ()
    thickness: float = 0.1
    height: float = 0.8
    panel_length: float = 1.75

    def __post_init__(self) -> None:
        for name in ("thickness", "height", "panel_length"):
            _check_positive(getattr(self, name), f"interior_walls {name}")
        for i, segment in enumerate(self.segments):
            if not all(math.isfinite(v) for v in segment):
                raise ValueError(
                    f"interior_walls segments[{i}] must be finite numbers, got {list(segment)}"
                )
            x0, y0, x1, y1 = segment
            if math.hypot(x1 - x0, y1 - y0) < 1e-6:
                raise ValueError(f"interior_walls segments[{i}] has zero length: {list(segment)}")


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
        sun: an optional light named ``"sun"`` in the model, for worlds whose sun moves over
            the day (the dynamics turn and tint it at run time); with a sun, the
            ``directional`` lights are named ``"sky0"``, ``"sky1"``, ... (light from the sky),
            without one ``"sun0"``, ``"sun1"``, ...
    """

    ambient: float = 0.35
    directional: tuple[DirectionalLight, ...] = ()
    jitter_deg: float = 0.0
    sun: DirectionalLight | None = None

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
class ItemsSpec:
    """One kind of object of an outdoor world's surroundings: how many, how big, what colour.

    Attributes:
        count: how many (for fences: how many fence runs); fewer where there is no room,
            e.g. cars whose places in the row fall on a neighbouring side's buildings.
        height: range of heights (m).
        width: range of widths (m): crown diameter of a tree or bush, a car's width (its length
            is about 2.3 times that), the spread of a lamp post's head, a fence run's length.
        colours: range of colours (crowns, car bodies, lamp posts, fence rails and posts).
    """

    count: int = 0
    height: tuple[float, float] = (1.0, 2.0)
    width: tuple[float, float] = (0.5, 1.0)
    colours: ColourRange = ColourRange()

    def __post_init__(self) -> None:
        _check_items(self, "outdoor item")


@dataclass(frozen=True)
class BuildingsSpec:
    """Rows of building facades along some sides of an outdoor area.

    Attributes:
        sides: range ``[min, max]`` of how many of the four sides get a row of buildings; the
            world seed picks how many and which.
        distance: range of distances from the asphalt's edge to a facade (m).
        length: range of a building's length along its side (m).
        depth: range of a building's depth (m).
        storeys: range ``[min, max]`` of storeys.
        storey_height: height of one storey (m); the windows repeat at this pitch.
        window_pitch: horizontal distance between windows (m).
        colours: range of facade colours.
        windows: range of window (glass) colours.
        designs: 0: every building drawn anew; ``n`` >= 1: the world draws ``n`` designs
            (length, depth, storeys, facade and window colours, the facade's texture) and
            every building, and every block inside the arena, repeats one of them: the
            repeated facades of a campus, where places look alike.
    """

    sides: tuple[int, int] = (2, 3)
    distance: tuple[float, float] = (4.0, 12.0)
    length: tuple[float, float] = (6.0, 14.0)
    depth: tuple[float, float] = (6.0, 10.0)
    storeys: tuple[int, int] = (2, 5)
    storey_height: float = 3.0
    window_pitch: float = 2.5
    colours: ColourRange = ColourRange((0.0, 0.15), (0.1, 0.5), (0.5, 0.9))
    windows: ColourRange = ColourRange((0.55, 0.65), (0.2, 0.5), (0.15, 0.35))
    designs: int = 0

    def __post_init__(self) -> None:
        _check_range(self.sides, "buildings sides", low=0)
        check_int_in("buildings designs", self.designs, 0)
        if self.sides[1] > 4:
            raise ValueError(f"buildings sides must lie in [0, 4], got {list(self.sides)}")
        _check_range(self.storeys, "buildings storeys", low=1)
        for name in ("distance", "length", "depth"):
            _check_range(getattr(self, name), f"buildings {name}", low=1e-3)
        for name in ("storey_height", "window_pitch"):
            _check_positive(getattr(self, name), f"buildings {name}")


@dataclass(frozen=True)
class OutdoorSpec:
    """The surroundings of an outdoor world, drawn from the world seed (see
    :mod:`sfa_gym.sim.worlds.outdoor`): a pavement around the asphalt (the arena's ``floor``),
    grass beyond (the ``ground``), building facades, trees in clusters, parked cars along one
    side, fences, lamp posts and bushes. Everything stands outside the arena and is visual only.

    Attributes:
        pavement: the pavement's surface.
        pavement_width: width of the pavement around the asphalt (m).
        buildings: the building rows.
        trees: trees (trunk and crown); ``tree_clusters`` groups of them.
        tree_clusters: number of tree clusters.
        cars: parked cars (body, cabin, wheels).
        fences: fence runs (posts and two rails).
        lamp_posts: lamp posts along the pavement.
        bushes: bushes along the pavement.
        blocks: building blocks standing inside the arena, ``(xmin, xmax, ymin, ymax)`` (m,
            world frame): buildings of the ``buildings``' designs that the rover collides with
            (a campus's wings between its drivable areas). The only things of this block that
            stand inside the arena.
    """

    pavement: SurfaceSpec = SurfaceSpec()
    pavement_width: float = 1.5
    buildings: BuildingsSpec = BuildingsSpec()
    trees: ItemsSpec = ItemsSpec()
    tree_clusters: int = 3
    cars: ItemsSpec = ItemsSpec()
    fences: ItemsSpec = ItemsSpec()
    lamp_posts: ItemsSpec = ItemsSpec()
    bushes: ItemsSpec = ItemsSpec()
    blocks: tuple[tuple[float, float, float, float], ...] = ()

    def __post_init__(self) -> None:
        _check_positive(self.pavement_width, "outdoor pavement_width")
        if self.blocks and not self.buildings.designs:
            raise ValueError(
                "outdoor blocks look like the buildings' designs: set buildings.designs >= 1"
            )
        for i, (x0, x1, y0, y1) in enumerate(self.blocks):
            if not (x0 < x1 and y0 < y1):
                raise ValueError(
                    f"outdoor blocks[{i}] must be (xmin, xmax, ymin, ymax) with xmin < xmax and "
                    f"ymin < ymax, got {[x0, x1, y0, y1]}"
                )
        if self.tree_clusters < 1:
            raise ValueError(f"outdoor tree_clusters must be >= 1, got {self.tree_clusters}")


@dataclass(frozen=True)
class WorldSpec:
    """Everything that defines a family of worlds; one world seed picks one member.

    Load one with :func:`load_world_spec`. Lengths in metres, angles in degrees. The
    ``name`` is any text without control characters (it is escaped in the MJCF). A
    ``textures`` block (outdoor worlds only; off by default) textures the surfaces with
    generated images (:mod:`sfa_gym.sim.worlds.textures`).
    """

    name: str
    description: str = ""
    arena: ArenaSpec = ArenaSpec()
    floor: SurfaceSpec = SurfaceSpec()
    ground: SurfaceSpec = SurfaceSpec()
    walls: SurfaceSpec = SurfaceSpec()
    landmarks: LandmarksSpec = LandmarksSpec()
    obstacles: ObstaclesSpec = ObstaclesSpec()
    interior_walls: InteriorWallsSpec = InteriorWallsSpec()
    lights: LightsSpec = LightsSpec()
    sky: SkySpec = SkySpec()
    outdoor: OutdoorSpec | None = None
    dynamics: DynamicsSpec | None = None
    textures: TexturesSpec | None = None

    def __post_init__(self) -> None:
        if self.textures is not None and self.outdoor is None:
            raise ValueError(
                f"world {self.name!r}: textures need an outdoor block (the generated surfaces "
                "are the outdoor world's: asphalt, grass, paving, facades, trees, bushes)"
            )
        if not isinstance(self.name, str) or not self.name:
            raise ValueError(f"world name must be a non-empty string, got {self.name!r}")
        # XML cannot carry control characters, even escaped
        if any(ord(ch) < 32 or ord(ch) == 127 for ch in self.name):
            raise ValueError(f"world name must not contain control characters, got {self.name!r}")
        hx, hy = self.arena.size[0] / 2, self.arena.size[1] / 2
        for i, (x0, y0, x1, y1) in enumerate(self.interior_walls.segments):
            if max(abs(x0), abs(x1)) > hx + 1e-9 or max(abs(y0), abs(y1)) > hy + 1e-9:
                raise ValueError(
                    f"interior_walls segments[{i}] {[x0, y0, x1, y1]} reaches outside the "
                    f"arena: its ends must satisfy |x| <= {hx} and |y| <= {hy}"
                )
        for i, block in enumerate(() if self.outdoor is None else self.outdoor.blocks):
            if max(abs(v) for v in block[:2]) > hx + 1e-9 or max(abs(v) for v in block[2:]) > hy:
                raise ValueError(
                    f"outdoor blocks[{i}] {list(block)} reaches outside the arena: it must "
                    f"satisfy |x| <= {hx} and |y| <= {hy}"
                )


def world_spec_from_dict(data: dict[str, Any]) -> WorldSpec:
    """Build a validated :class:`WorldSpec` from parsed JSON; errors name the bad key."""
    return dataclass_from_json(WorldSpec, data, "world", noun="key")


def available_worlds() -> list[str]:
    """Names of the world specs shipped with the package (``envs/*.json``)."""
    return sorted(p.stem for p in envs_dir().glob("*.json"))


def load_world_spec(world: str | os.PathLike[str]) -> WorldSpec:
    """Load a world spec by name (``"paper_sim"``) or from a path to a JSON file.

    Raises:
        ValueError: no such world, or the file is not valid JSON or not a valid spec; the
            message names the file and where in it (line and column, or the key).
    """
    path = Path(world)
    if path.suffix != ".json":
        path = envs_dir() / f"{world}.json"
        if not path.is_file():
            raise ValueError(f"unknown world {str(world)!r}; available: {available_worlds()}")
    elif not path.is_file():
        raise ValueError(f"world spec file {str(path)!r} does not exist")
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except json.JSONDecodeError as error:
        raise ValueError(
            f"world spec file {str(path)!r} is not valid JSON: {error.msg} at line "
            f"{error.lineno}, column {error.colno}"
        ) from None
    except UnicodeDecodeError as error:
        raise ValueError(
            f"world spec file {str(path)!r} is not UTF-8 text: byte {error.start} is "
            f"{error.object[error.start : error.start + 1]!r}"
        ) from None
    try:
        return world_spec_from_dict(data)
    except ValueError as error:
        raise ValueError(f"world spec file {str(path)!r}: {error}") from None
