"""The surroundings of an outdoor world: pavement, buildings, trees, cars, fences, lamps, bushes.

:func:`build_outdoor` draws one set of surroundings from an :class:`OutdoorSpec` and the world's
random generator and appends the geoms to a world under construction (see
:func:`sfa_gym.sim.worlds.build.build_world`, which calls it for specs with an ``outdoor``
block). The arena (the asphalt, ``arena.size``) is centred on the origin; its sides are named
by their outward direction: north +y, east +x, south -y, west -x.

Around the asphalt lies a pavement ring, then grass (the world's ground plane). With dynamics,
a straight road (a cycle path and car lanes, :class:`~sfa_gym.sim.worlds.dynamics.Lanes`)
passes the area on one side beyond a verge; its band is taken before anything else is placed,
so no parked car, fence, tree, bush or building stands on it, and the building row on that
side stands beyond it. Building rows stand along some sides, a row of parked cars along one
side without the road, fence runs and bushes beyond the pavement, lamp posts on the
pavement's outer part (the pedestrians walk between them and the curb) and trees in clusters
wherever there is room; trees whose crowns reach over the pavement or the road carry them above
the movers' heads. Everything is axis aligned and placed so that footprints do not overlap
(rectangles kept ``_GAP`` apart); all of it is visual only (``contype="0"``): the rover cannot
reach it past the curbs, and visual-only geoms cost nothing in collision detection.

Facades and their window grids: :mod:`sfa_gym.sim.worlds.facades`.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Protocol

from sfa_gym.sim.worlds._mjcf import Builder as _Builder
from sfa_gym.sim.worlds._mjcf import vec as _vec
from sfa_gym.sim.worlds.dynamics import FOOTPRINT, Lanes
from sfa_gym.sim.worlds.facades import Designs, window_material
from sfa_gym.sim.worlds.spec import ColourRange, ItemsSpec, OutdoorSpec

if TYPE_CHECKING:
    from sfa_gym.sim.worlds.seasons import Foliage

Rect = tuple[float, float, float, float]
"""``(xmin, xmax, ymin, ymax)`` of an axis-aligned footprint, metres."""

Landmark = tuple[str, float, float, float]
"""``(kind, x, y, height)`` as in :attr:`WorldLayout.landmarks`."""

_GAP = 0.3  # free space kept between footprints (m)
CAR_LENGTH = 2.3  # a parked car's length / its width
_CAR_WHEEL = 0.32  # car wheel radius (m)
_GLASS = (0.14, 0.17, 0.22)
_RUBBER = (0.06, 0.06, 0.06)
_LAMP = (0.95, 0.93, 0.8)
_BARK = ColourRange((0.05, 0.1), (0.4, 0.7), (0.2, 0.35))
_LAMP_INSET = 0.3  # lamp posts stand this far inside the pavement's outer edge (m)
_LAMP_RADIUS = 0.05
_CROWN_CLEAR = 2.2  # lowest point of a tree crown over the movers' lanes (m)
_ROAD = (0.16, 0.16, 0.17)  # asphalt of the road
_CYCLE_PATH = (0.45, 0.22, 0.2)  # red-brown cycle path
_PAINT = (0.92, 0.92, 0.88)  # lane markings


class DayChanges(Protocol):
    """Another day's parked objects (:class:`sfa_gym.sim.worlds.rearrange.Rearranged`, which
    draws with this module's helpers)."""

    def stays(self, place: Rect) -> bool: ...

    def arrive(self, s: Scene, car_side: Side) -> None: ...


@dataclass(frozen=True)
class Side:
    """One side of the asphalt: its outward normal, tangent, the distance of its edge from the
    centre and its half length along the tangent (m)."""

    name: str
    normal: tuple[float, float]
    tangent: tuple[float, float]
    edge: float
    half: float

    def point(self, out: float, along: float) -> tuple[float, float]:
        """The point ``out`` metres from the centre along the normal and ``along`` metres
        along the tangent."""
        return (
            self.normal[0] * out + self.tangent[0] * along,
            self.normal[1] * out + self.tangent[1] * along,
        )

    def rect(self, out: float, along: float, depth: float, length: float) -> Rect:
        """Footprint centred at :meth:`point` ``(out, along)``, ``depth`` along the normal and
        ``length`` along the tangent."""
        x, y = self.point(out, along)
        hx, hy = (depth / 2, length / 2) if self.normal[0] else (length / 2, depth / 2)
        return (x - hx, x + hx, y - hy, y + hy)


def _sides(hx: float, hy: float) -> list[Side]:
    return [
        Side("north", (0.0, 1.0), (1.0, 0.0), hy, hx),
        Side("east", (1.0, 0.0), (0.0, 1.0), hx, hy),
        Side("south", (0.0, -1.0), (1.0, 0.0), hy, hx),
        Side("west", (-1.0, 0.0), (0.0, 1.0), hx, hy),
    ]


def _overlaps(a: Rect, b: Rect, gap: float = _GAP) -> bool:
    return not (
        a[1] + gap <= b[0] or b[1] + gap <= a[0] or a[3] + gap <= b[2] or b[3] + gap <= a[2]
    )


def box_geom(name: str, rect: Rect, z0: float, z1: float, material: str) -> str:
    """An axis-aligned box over ``rect`` from height ``z0`` to ``z1``."""
    x0, x1, y0, y1 = rect
    return (
        f'<geom name="{name}" type="box" pos="{_vec((x0 + x1) / 2, (y0 + y1) / 2, (z0 + z1) / 2)}" '
        f'size="{_vec((x1 - x0) / 2, (y1 - y0) / 2, (z1 - z0) / 2)}" material="{material}" '
        f'contype="0" conaffinity="0"/>'
    )


class Scene:
    """Footprints taken so far, the geoms and the landmarks, while drawing from one generator."""

    def __init__(self, b: _Builder, spec: OutdoorSpec):
        self.b = b
        self.rng = b.rng
        self.spec = spec
        arena = b.spec.arena
        self.hx, self.hy = arena.size[0] / 2, arena.size[1] / 2
        self.sides = _sides(self.hx, self.hy)
        pw = spec.pavement_width
        # the asphalt and the pavement around it stay free of everything but lamp posts
        self.taken: list[Rect] = [(-self.hx - pw, self.hx + pw, -self.hy - pw, self.hy + pw)]
        self.geoms: list[str] = []
        self.landmarks: list[Landmark] = []
        self.materials: dict[tuple[tuple[float, float, float], float], str] = {}
        # where the movers go (the pavement and the road): tree crowns above them are lifted
        self.lanes: list[Rect] = []
        # another day's parked objects (sfa_gym.sim.worlds.rearrange); None: as built
        self.rearranged: DayChanges | None = None
        self.foliage: Foliage | None = None  # the trees' crowns by the date; None: as drawn
        self.facades: Designs | None = None  # repeated designs; None: every building anew

    def free(self, rect: Rect) -> bool:
        return not any(_overlaps(rect, t) for t in self.taken)

    def try_place(self, draw: Callable[[], Rect], attempts: int) -> Rect | None:
        """The first of up to ``attempts`` footprints ``draw()`` that is free; it is taken."""
        for _ in range(attempts):
            rect = draw()
            if self.free(rect):
                self.taken.append(rect)
                return rect
        return None

    def material(self, rgb: tuple[float, float, float], alpha: float = 1.0) -> str:
        """A matte material of colour ``rgb`` (and opacity ``alpha``), shared by every geom of
        that colour."""
        if (rgb, alpha) not in self.materials:
            self.materials[rgb, alpha] = self.b.plain_material(rgb, alpha)
        return self.materials[rgb, alpha]

    def name(self, kind: str) -> str:
        return f"{kind}{sum(1 for k, *_ in self.landmarks if k == kind)}"


def _pavement(s: Scene) -> None:
    pw = s.spec.pavement_width
    mat = s.b.textured("paving", s.b.surface_material(s.spec.pavement))
    # half a millimetre under the asphalt tile and above the grass plane: no depth fighting
    s.geoms.append(
        f'<geom name="pavement" type="box" pos="0 0 -0.0045" '
        f'size="{_vec(s.hx + pw, s.hy + pw, 0.005)}" material="{mat}" contype="0" '
        f'conaffinity="0"/>'
    )


def _buildings(s: Scene, car_side: Side, car_band: float, lanes: Lanes | None) -> None:
    spec, rng = s.spec.buildings, s.rng
    lo, hi = spec.storeys
    n = int(rng.integers(spec.sides[0], spec.sides[1] + 1))
    order = rng.permutation(len(s.sides))
    for side in (s.sides[i] for i in sorted(order[:n])):
        # the row runs past the corners so that the street looks closed from inside
        reach = side.half + s.spec.pavement_width + spec.distance[1]
        along = -reach
        while along < reach:
            # a design repeats its footprint, storeys and facade; else all are drawn anew
            design = None if s.facades is None else s.facades.draw(s.b)
            length = design.length if design else rng.uniform(*spec.length)
            depth = design.depth if design else rng.uniform(*spec.depth)
            distance = rng.uniform(*spec.distance)
            if side is car_side:
                distance = max(distance, car_band)
            if lanes is not None and side.name == lanes.road_side:
                distance = max(distance, lanes.road[1] + _GAP)  # across the road
            storeys = design.storeys if design else int(rng.integers(lo, hi + 1))
            out = side.edge + distance + depth / 2
            rect = side.rect(out, along + length / 2, depth, length)
            along += length + rng.uniform(0.5, 4.0)
            colours = None if design else (spec.colours.draw(rng), spec.windows.draw(rng))
            if not s.free(rect):
                continue  # a corner already built up by the neighbouring row
            s.taken.append(rect)
            columns = max(1, round(length / spec.window_pitch))
            mat = (
                design.material
                if design
                else window_material(s.b, spec, *colours, columns, storeys)
            )
            height = storeys * spec.storey_height
            cx, cy = (rect[0] + rect[1]) / 2, (rect[2] + rect[3]) / 2
            s.geoms.append(box_geom(s.name("building"), rect, 0.0, height, mat))
            s.landmarks.append(("building", cx, cy, height))


def _cars(s: Scene, side: Side) -> None:
    spec, rng = s.spec.cars, s.rng
    out0 = side.edge + s.spec.pavement_width + 0.5
    # the row is centred on the side, give or take a car; cars that would stand in a
    # neighbouring side's buildings are left out
    mean_pitch = CAR_LENGTH * sum(spec.width) / 2 + 1.55
    along = -spec.count * mean_pitch / 2 + rng.uniform(-2.0, 2.0)
    for _ in range(spec.count):
        width, height = rng.uniform(*spec.width), rng.uniform(*spec.height)
        length = CAR_LENGTH * width
        rect = side.rect(out0 + width / 2, along + length / 2, width, length)
        along += length + rng.uniform(0.6, 2.5)
        body = s.material(spec.colours.draw(rng))
        s.material(_GLASS)
        if not s.free(rect):
            continue
        s.taken.append(rect)
        if s.rearranged is not None and not s.rearranged.stays(rect):
            continue  # parked elsewhere today: its place stays empty
        park_car(s, rect, (length, width, height), body, lengthwise_x=side.normal[0] == 0.0)


def park_car(
    s: Scene, rect: Rect, size: tuple[float, float, float], body: str, lengthwise_x: bool
) -> None:
    """A parked car over the footprint ``rect`` (lengthwise along x or y) of ``size`` (length,
    width, height, m): body, cabin and two axles, the body in the material ``body``."""
    name = s.name("car")
    cx, cy = (rect[0] + rect[1]) / 2, (rect[2] + rect[3]) / 2
    length, width, height = size
    z_body = 0.55 * height
    s.geoms.append(box_geom(name, rect, 0.22, z_body, body))
    # the cabin: shorter and narrower than the body, shifted a little to the rear
    ux, uy = (1.0, 0.0) if lengthwise_x else (0.0, 1.0)
    shrink = (0.22 * length, 0.08 * width) if lengthwise_x else (0.08 * width, 0.22 * length)
    cab = (
        rect[0] + shrink[0] - 0.1 * length * ux,
        rect[1] - shrink[0] - 0.1 * length * ux,
        rect[2] + shrink[1] - 0.1 * length * uy,
        rect[3] - shrink[1] - 0.1 * length * uy,
    )
    s.geoms.append(box_geom(f"{name}_cabin", cab, z_body, height, s.material(_GLASS)))
    # one cylinder per axle, a little wider than the body: two dark wheels seen from a side
    wheels = s.material(_RUBBER)
    euler = "90 0 0" if lengthwise_x else "0 90 0"
    for k, f in enumerate((-0.32, 0.32)):
        wx, wy = cx + f * length * ux, cy + f * length * uy
        s.geoms.append(
            f'<geom name="{name}_axle{k}" type="cylinder" pos="{_vec(wx, wy, _CAR_WHEEL)}" '
            f'size="{_vec(_CAR_WHEEL, width / 2 + 0.03)}" euler="{euler}" '
            f'material="{wheels}" contype="0" conaffinity="0"/>'
        )
    s.landmarks.append(("car", cx, cy, height))


def _fences(s: Scene, car_side: Side) -> None:
    spec, rng = s.spec.fences, s.rng
    others = [side for side in s.sides if side is not car_side]
    for _ in range(spec.count):
        side = others[int(rng.integers(len(others)))]
        length, height = rng.uniform(*spec.width), rng.uniform(*spec.height)
        colour = s.material(spec.colours.draw(rng))

        def draw(side=side, length=length) -> Rect:
            out = side.edge + s.spec.pavement_width + rng.uniform(1.0, 4.0)
            along = rng.uniform(-side.half - 2.0, side.half + 2.0)
            return side.rect(out, along, 0.06, length)

        rect = s.try_place(draw, attempts=20)
        if rect is None:
            continue
        name = s.name("fence")
        along_x = side.normal[0] == 0.0
        n_posts = max(2, math.ceil(length / 2.0) + 1)
        for k in range(n_posts):
            f = k / (n_posts - 1)
            if along_x:
                px, py = rect[0] + f * (rect[1] - rect[0]), (rect[2] + rect[3]) / 2
            else:
                px, py = (rect[0] + rect[1]) / 2, rect[2] + f * (rect[3] - rect[2])
            post = (px - 0.04, px + 0.04, py - 0.04, py + 0.04)
            s.geoms.append(box_geom(f"{name}_post{k}", post, 0.0, height, colour))
        for k, z in enumerate((0.35 * height, 0.85 * height)):
            s.geoms.append(box_geom(f"{name}_rail{k}", rect, z - 0.03, z + 0.03, colour))
        cx, cy = (rect[0] + rect[1]) / 2, (rect[2] + rect[3]) / 2
        s.landmarks.append(("fence", cx, cy, height))


def _lamp_posts(s: Scene) -> None:
    spec, rng = s.spec.lamp_posts, s.rng
    if spec.count == 0:
        return
    # evenly round the pavement's outer part, starting at a random point of its perimeter
    inset = s.spec.pavement_width - _LAMP_INSET
    hx, hy = s.hx + inset, s.hy + inset
    perimeter = 4 * (hx + hy)
    start = rng.uniform(0.0, perimeter)
    for k in range(spec.count):
        p = (start + k * perimeter / spec.count) % perimeter
        if p < 2 * hx:
            x, y = -hx + p, -hy
        elif p < 2 * hx + 2 * hy:
            x, y = hx, -hy + p - 2 * hx
        elif p < 4 * hx + 2 * hy:
            x, y = hx - (p - 2 * hx - 2 * hy), hy
        else:
            x, y = -hx, hy - (p - 4 * hx - 2 * hy)
        height, head = rng.uniform(*spec.height), rng.uniform(*spec.width)
        pole = s.material(spec.colours.draw(rng))
        name = s.name("lamp_post")
        s.geoms.append(
            f'<geom name="{name}" type="cylinder" pos="{_vec(x, y, height / 2)}" '
            f'size="{_vec(_LAMP_RADIUS, height / 2)}" material="{pole}" contype="0" '
            f'conaffinity="0"/>'
        )
        s.geoms.append(
            f'<geom name="{name}_head" type="ellipsoid" pos="{_vec(x, y, height + 0.08)}" '
            f'size="{_vec(head / 2, head / 2, 0.12)}" material="{s.material(_LAMP)}" '
            f'contype="0" conaffinity="0"/>'
        )
        s.landmarks.append(("lamp_post", x, y, height))


def _round_items(s: Scene, kind: str, spec: ItemsSpec, centres: list[tuple[float, float]]) -> None:
    """Trees (trunk and crown) or bushes, ``spec.count`` of them, near the ``centres`` in turn
    (within ``3 + width`` metres of them)."""
    rng = s.rng
    for k in range(spec.count):
        cx, cy = centres[k % len(centres)]
        height, width = rng.uniform(*spec.height), rng.uniform(*spec.width)
        r = width / 2
        spread = 3.0 + width

        def draw(cx=cx, cy=cy, r=r, spread=spread) -> Rect:
            x, y = cx + rng.uniform(-spread, spread), cy + rng.uniform(-spread, spread)
            # trees' footprints are their trunks plus a little: crowns may overlap
            rt = r if kind == "bush" else 0.4
            return (x - rt, x + rt, y - rt, y + rt)

        colour = spec.colours.draw(rng)
        rect = s.try_place(draw, attempts=30)
        if rect is None:
            continue
        x, y = (rect[0] + rect[1]) / 2, (rect[2] + rect[3]) / 2
        name = s.name(kind)
        alpha = 1.0
        if kind == "tree" and s.foliage is not None:
            colour, alpha = s.foliage.crown(colour)
        surface = "bush" if kind == "bush" else "foliage"
        crown = s.b.textured(surface, s.material(colour, alpha), alpha=alpha)
        if kind == "bush":
            s.geoms.append(
                f'<geom name="{name}" type="ellipsoid" pos="{_vec(x, y, height * 0.45)}" '
                f'size="{_vec(r, r, height / 2)}" material="{crown}" contype="0" '
                f'conaffinity="0"/>'
            )
        else:
            trunk_h = height * rng.uniform(0.3, 0.45)
            crown_rect = (x - r, x + r, y - r, y + r)
            if any(_overlaps(crown_rect, lane, 0.0) for lane in s.lanes):
                # a street tree: its crown (which starts a tenth of its height below the
                # trunk's top) clears the heads of the people, bikes and cars beneath
                trunk_h = max(trunk_h, (_CROWN_CLEAR + 0.1 * height) / 1.1)
            bark = s.b.textured("bark", s.material(_BARK.draw(rng)))
            s.geoms.append(
                f'<geom name="{name}" type="cylinder" pos="{_vec(x, y, trunk_h / 2)}" '
                f'size="{_vec(max(0.06, width * 0.05), trunk_h / 2)}" material="{bark}" '
                f'contype="0" conaffinity="0"/>'
            )
            crown_h = height - trunk_h
            s.geoms.append(
                f'<geom name="{name}_crown" type="ellipsoid" '
                f'pos="{_vec(x, y, trunk_h + crown_h * 0.45)}" '
                f'size="{_vec(r, r, crown_h * 0.55)}" material="{crown}" contype="0" '
                f'conaffinity="0"/>'
            )
        s.landmarks.append((kind, x, y, height))


def _ring_points(s: Scene, n: int, near: float, far: float) -> list[tuple[float, float]]:
    """``n`` points at random azimuths, ``near`` .. ``far`` metres beyond the pavement."""
    rng = s.rng
    pw = s.spec.pavement_width
    out = []
    for _ in range(n):
        side = s.sides[int(rng.integers(4))]
        d = side.edge + pw + rng.uniform(near, far)
        out.append(side.point(d, rng.uniform(-side.half - far, side.half + far)))
    return out


def _check_lanes(s: Scene, lanes: Lanes) -> None:
    """A ValueError when the movers' lanes would run into the scene: the pedestrians' loops
    must fit between the arena's boundary and the lamp posts, the road must lie beyond the
    pavement."""
    arena = s.b.spec.arena
    boundary = {"curbs": arena.border_width, "walls": arena.wall_thickness}.get(arena.boundary, 0.0)
    lamps = s.spec.pavement_width - _LAMP_INSET - _LAMP_RADIUS
    radius = FOOTPRINT["pedestrian"][0]
    if lanes.walk is not None and not (
        boundary < lanes.walk[0] - radius and lanes.walk[1] + radius < lamps
    ):
        raise ValueError(
            f"pedestrian offsets {list(lanes.walk)} m put them on the {arena.boundary} or the "
            f"lamp posts: a pedestrian ({radius} m round) walks between {boundary} m (the "
            f"{arena.boundary}) and {lamps:.3f} m (the lamp posts) from the arena's edge, so "
            f"its offset must lie in ({boundary + radius:.3f}, {lamps - radius:.3f})"
        )
    if lanes.road[0] < s.spec.pavement_width + _GAP:
        raise ValueError(
            f"dynamics road distance {lanes.road[0]} m puts the road on the pavement: it must "
            f"be >= pavement_width + {_GAP} = {s.spec.pavement_width + _GAP} m"
        )


def _road(s: Scene, lanes: Lanes) -> None:
    """The road's band, taken before anything else is placed, and its surface: asphalt, the
    cycle path on its near side, a line between them and a centre line between the car
    lanes (flat, just above the grass)."""
    rect = lanes.road_rect()
    s.taken.append(rect)
    near = lanes.road[0]
    # the cycle path's two lanes lie a quarter and three quarters across it
    cycle_edge = lanes.cycle[1][0] + (lanes.cycle[1][0] - lanes.cycle[0][0]) / 2
    half_length = lanes.length / 2

    def band(a: float, b: float) -> Rect:
        (x0, y0), (x1, y1) = lanes.road_point(a, -half_length), lanes.road_point(b, half_length)
        return min(x0, x1), max(x0, x1), min(y0, y1), max(y0, y1)

    # the cycle path sits on the asphalt and the paint on both, a millimetre apart: no depth
    # fighting
    road, cycle_path = (s.b.textured("asphalt", s.material(c)) for c in (_ROAD, _CYCLE_PATH))
    s.geoms.append(box_geom("road", rect, -0.009, 0.0005, road))
    s.geoms.append(box_geom("cycle_path", band(near, cycle_edge), -0.009, 0.0015, cycle_path))
    lines = [cycle_edge] + [
        (a + b) / 2 for (a, _), (b, _) in zip(lanes.cars, lanes.cars[1:], strict=False)
    ]
    for k, d in enumerate(lines):
        s.geoms.append(
            box_geom(f"road_line{k}", band(d - 0.06, d + 0.06), -0.009, 0.0025, s.material(_PAINT))
        )


def outer_reach(spec: OutdoorSpec, size: tuple[float, float]) -> float:
    """Largest distance (m) from the centre at which the surroundings may stand: for the
    model's extent (near and far clipping planes) and the size of the ground plane."""
    b = spec.buildings
    half = max(size) / 2 + spec.pavement_width + b.distance[1]
    return math.hypot(half + b.depth[1], half + b.length[1])


def build_outdoor(
    b: _Builder,
    lanes: Lanes | None = None,
    rearranged: DayChanges | None = None,
    foliage: Foliage | None = None,
    facades: Designs | None = None,
) -> list[Landmark]:
    """Draw the surroundings of ``b.spec.outdoor`` with ``b.rng`` into ``b``'s assets and body,
    keeping the movers' ``lanes`` (from :func:`~sfa_gym.sim.worlds.dynamics.mover_lanes`,
    None: no movers) free; ``rearranged``: another day's parked objects
    (:mod:`sfa_gym.sim.worlds.rearrange`), None: the world as built; ``foliage``: the trees'
    crowns by the date (:mod:`sfa_gym.sim.worlds.seasons`), None: as drawn; ``facades``:
    repeated building designs and the blocks inside the arena
    (:mod:`sfa_gym.sim.worlds.facades`), None: every building drawn anew.

    The order of the draws is fixed (pavement, car side, buildings, cars, fences, lamp posts,
    tree clusters, bushes), so the same world seed gives the same surroundings. Another day's
    parked objects draw from their own generator, after everything else.

    Raises:
        ValueError: the world has no outdoor block, or the lanes run into the scene (see
            :func:`_check_lanes`).

    Returns:
        The landmarks ``(kind, x, y, height)``: kinds "building", "car", "fence", "lamp_post",
        "tree", "bush" (another day also "bin", "bench", "site_fence"); ``(x, y)`` the
        footprint's centre (m, world frame).
    """
    spec = b.spec.outdoor
    if spec is None:
        raise ValueError(f"world {b.spec.name!r} has no outdoor block")
    s = Scene(b, spec)
    s.rearranged, s.foliage, s.facades = rearranged, foliage, facades
    if lanes is not None:
        _check_lanes(s, lanes)
    _pavement(s)
    if lanes is not None:
        _road(s, lanes)
        pw = spec.pavement_width
        s.lanes = [(-s.hx - pw, s.hx + pw, -s.hy - pw, s.hy + pw), lanes.road_rect()]
    # the parked cars stand on a side without the road: seen across it, they would hide the
    # passing cars
    sides = [side for side in s.sides if lanes is None or side.name != lanes.road_side]
    car_side = sides[int(s.rng.integers(len(sides)))]
    car_band = spec.pavement_width + 1.5 + 2 * (spec.cars.width[1] if spec.cars.count else 0.0)
    _buildings(s, car_side, car_band, lanes)
    if facades is not None:
        geoms, blocks = facades.blocks(s.b, spec.blocks)
        s.geoms += geoms
        s.landmarks += blocks
    _cars(s, car_side)
    _fences(s, car_side)
    _lamp_posts(s)
    _round_items(s, "tree", spec.trees, _ring_points(s, spec.tree_clusters, 1.0, 6.0))
    _round_items(s, "bush", spec.bushes, _ring_points(s, max(1, spec.bushes.count), 0.3, 1.5))
    if rearranged is not None:
        rearranged.arrive(s, car_side)
    b.body.extend(s.geoms)
    return s.landmarks


__all__ = ["Scene", "Side", "box_geom", "build_outdoor", "outer_reach", "park_car"]
