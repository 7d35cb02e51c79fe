"""A world spec plus a world seed -> MJCF text (no ``mujoco`` import: the env compiles it)."""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from xml.sax.saxutils import quoteattr

import numpy as np

from sfa_gym._checks import check_world_seed
from sfa_gym.sim.worlds._mjcf import Builder as _Builder
from sfa_gym.sim.worlds._mjcf import num as _num
from sfa_gym.sim.worlds._mjcf import vec as _vec
from sfa_gym.sim.worlds.dynamics import DynamicsSpec, Lanes, mover_lanes, movers_mjcf
from sfa_gym.sim.worlds.facades import designs_for
from sfa_gym.sim.worlds.ground import ground_look_for
from sfa_gym.sim.worlds.layout import WorldLayout
from sfa_gym.sim.worlds.outdoor import build_outdoor, outer_reach
from sfa_gym.sim.worlds.rearrange import rearranged_for
from sfa_gym.sim.worlds.seasons import foliage_for
from sfa_gym.sim.worlds.sky import sky_faces, skybox_mjcf
from sfa_gym.sim.worlds.spec import ColourRange, WorldSpec
from sfa_gym.sim.worlds.textures import png_bytes
from sfa_gym.sim.worlds.texturing import Texturer


@dataclass(frozen=True)
class MJCFParts:
    """Pieces of MJCF that a robot contributes to a world model (XML text, possibly empty)."""

    assets: str = ""
    worldbody: str = ""
    actuators: str = ""
    sensors: str = ""
    contacts: str = ""


@dataclass(frozen=True)
class World:
    """A generated world: the full MJCF text and its layout; with dynamics, the lanes its
    movers keep to (:func:`~sfa_gym.sim.worlds.dynamics.mover_lanes`: the scene keeps them
    free; pass them on to :class:`~sfa_gym.sim.worlds.dynamics.Dynamics`); with generated
    textures, the files the MJCF names (``{file name: PNG bytes}``: compile with
    ``mujoco.MjModel.from_xml_string(world.mjcf, world.assets)``)."""

    mjcf: str
    layout: WorldLayout
    lanes: Lanes | None = None
    assets: dict[str, bytes] = field(default_factory=dict, hash=False)


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


_CURB_RGB = (0.62, 0.62, 0.6)
_MARKING_RGB = (0.92, 0.92, 0.86)


def _boundary(b: _Builder) -> None:
    """The arena's boundary: wall panels, curbs (low boxes the rover collides with, just outside
    ``size``) or a painted line (visual only, just inside ``size`` on the floor)."""
    arena = b.spec.arena
    if arena.boundary == "walls":
        _wall_panels(b)
        return
    hx, hy, w = arena.size[0] / 2, arena.size[1] / 2, arena.border_width
    if arena.boundary == "curbs":
        mat = b.textured("concrete", b.plain_material(_CURB_RGB))
        # the x curbs are long enough to close the corners
        sides = [(hx + w, w / 2, 0.0, hy + w / 2), (w / 2, hy, hx + w / 2, 0.0)]
        z, half_z, contact = arena.curb_height / 2, arena.curb_height / 2, ""
    else:
        mat = b.plain_material(_MARKING_RGB)
        sides = [(hx, w / 2, 0.0, hy - w / 2), (w / 2, hy - w, hx - w / 2, 0.0)]
        # a paint layer a millimetre above the floor tile, which lies a millimetre above the ground
        z, half_z, contact = 0.0015, 0.0005, ' contype="0" conaffinity="0"'
    for k, (sx, sy, px, py) in enumerate(s for s in sides for _ in range(2)):
        sign = 1 if k % 2 == 0 else -1
        b.body.append(
            f'<geom name="{arena.boundary[:-1]}{k}" type="box" '
            f'pos="{_vec(sign * px, sign * py, z)}" size="{_vec(sx, sy, half_z)}" '
            f'material="{mat}"{contact}/>'
        )


def _square_distance(azimuth: float, hx: float, hy: float) -> float:
    """Distance from the centre to the rectangle ``|x| <= hx, |y| <= hy`` along ``azimuth``."""
    c, s = abs(math.cos(azimuth)), abs(math.sin(azimuth))
    return min(hx / c if c > 1e-9 else math.inf, hy / s if s > 1e-9 else math.inf)


Circle = tuple[float, float, float]
"""``(x, y, radius)`` of a footprint's bounding circle, metres."""


Wall = tuple[float, float, float, float, float]
"""``(x0, y0, x1, y1, half_thickness)`` of an interior wall, metres."""


def _segment_distance(x: float, y: float, wall: Wall) -> float:
    """Distance from ``(x, y)`` to the wall's centre line."""
    x0, y0, x1, y1, _ = wall
    dx, dy = x1 - x0, y1 - y0
    t = min(1.0, max(0.0, ((x - x0) * dx + (y - y0) * dy) / (dx * dx + dy * dy)))
    return math.hypot(x - x0 - t * dx, y - y0 - t * dy)


def _place(
    draw: Callable[[], tuple[float, float]],
    radius: float,
    placed: list[Circle],
    min_gap: float,
    attempts: int,
    walls: tuple[Wall, ...] = (),
) -> tuple[float, float] | None:
    """The first of up to ``attempts`` points ``draw()`` whose circle of ``radius`` keeps
    ``min_gap`` from every circle in ``placed`` and every wall in ``walls``; ``None`` if none
    does. The caller appends it."""
    for _ in range(attempts):
        x, y = draw()
        if all(
            math.hypot(x - px, y - py) >= radius + pr + min_gap for px, py, pr in placed
        ) and all(_segment_distance(x, y, w) >= radius + w[4] + min_gap for w in walls):
            return x, y
    return None


def _landmarks(b: _Builder) -> list[tuple[str, float, float, float]]:
    spec, rng = b.spec.landmarks, b.rng
    kinds = [k for k in spec.kinds for _ in range(k.count)]
    order = rng.permutation(len(kinds))
    n = len(kinds)
    hx = b.spec.arena.size[0] / 2 + b.spec.arena.wall_thickness
    hy = b.spec.arena.size[1] / 2 + b.spec.arena.wall_thickness
    offset = rng.uniform(0, 2 * math.pi)
    placed: list[Circle] = []
    out = []
    for slot, idx in enumerate(order):
        kind = kinds[idx]
        height = rng.uniform(*kind.height)
        width = rng.uniform(*kind.width)
        radius = width / 2 if kind.kind != "box" else width / math.sqrt(2)

        # One landmark per azimuth sector so that every viewing direction sees some; within
        # its sector the landmark moves until it clears the others.
        def in_sector(
            slot: int = slot, radius: float = radius, depth: float = spec.depth
        ) -> tuple[float, float]:
            az = offset + (slot + rng.uniform(0.1, 0.9)) * 2 * math.pi / n
            r = _square_distance(az, hx, hy) + spec.clearance + radius
            r += rng.uniform(0, depth)
            return r * math.cos(az), r * math.sin(az)

        point = _place(in_sector, radius, placed, spec.min_gap, attempts=100)
        # A crowded sector (wide neighbours drawn close) gets a deeper band to move back into;
        # worlds whose landmarks fit the first time are not changed by it.
        for widen in (2.0, 4.0):
            if point is None:
                deeper = functools.partial(in_sector, depth=spec.depth * widen)
                point = _place(deeper, radius, placed, spec.min_gap, attempts=100)
        if point is None:
            raise ValueError(
                f"cannot place {n} landmarks apart by min_gap {spec.min_gap}: "
                "increase landmarks depth or reduce their counts or widths"
            )
        x, y = point
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


def _walls(spec: WorldSpec) -> tuple[Wall, ...]:
    half = spec.interior_walls.thickness / 2
    return tuple((*segment, half) for segment in spec.interior_walls.segments)


# Rejection draws per obstacle, the step (m) of the grid then searched for room, and fresh
# starts of the whole placement when the first obstacles leave no room for the rest.
_OBSTACLE_ATTEMPTS, _ROOM_STEP, _OBSTACLE_ROUNDS = 1000, 0.01, 20


def _room(radius: float, placed: list[Circle], gap: float, walls: tuple[Wall, ...], half: tuple):
    """``(m, 2)`` the points of a grid of :data:`_ROOM_STEP` over ``|x| <= hx, |y| <= hy``
    (``half``) where a circle of ``radius`` keeps ``gap`` from the ``placed`` circles and the
    walls: all the room there is, up to the grid step."""
    xs, ys = (np.linspace(-h, h, math.ceil(2 * h / _ROOM_STEP) + 1) for h in half)
    p = np.stack(np.meshgrid(xs, ys), axis=-1).reshape(-1, 2)
    layout = WorldLayout((-1.0, 1.0, -1.0, 1.0), tuple(placed), (), walls)
    # clearance counts from the circles' edges and the walls' faces
    return p[layout.clearance(p) >= radius + gap] if min(half) >= 0 else np.zeros((0, 2))


def _obstacles(b: _Builder) -> list[Circle]:
    """Place the spec's obstacles, ``min_gap`` apart and from the arena and interior walls.

    Each is drawn uniformly over the arena until it clears those before it. Early obstacles
    can leave a later one only slivers of room, too small for random draws to hit (world seed
    100 of ``paper_sim_obstacles`` left three points of the 1 cm grid; also 351, 658, 693, 775
    of the first 1000): then it is drawn from :func:`_room`. When they leave no room at all
    (461, 950), the placement starts afresh with the generator moved on. Worlds placed by
    random draws alone are unchanged by these fallbacks.
    """
    spec, rng = b.spec.obstacles, b.rng
    walls = _walls(b.spec)
    for _ in range(_OBSTACLE_ROUNDS):
        drawn = _draw_obstacles(b, walls)
        if drawn is not None:
            break
    else:
        seed = getattr(rng.bit_generator.seed_seq, "entropy", "?")  # the world seed
        raise ValueError(
            f"world seed {seed}: cannot place {spec.count} obstacles {spec.width} m wide "
            f"apart by min_gap {spec.min_gap} m in the arena"
            + (" around its interior walls" if walls else "")
            + f" in {_OBSTACLE_ROUNDS} tries: reduce the obstacles' count, width or min_gap"
        )
    for i, (kind, x, y, width, height, colour) in enumerate(drawn):
        mat = b.plain_material(colour)
        shape = (
            f'type="cylinder" size="{_vec(width / 2, height / 2)}"'
            if kind == "cylinder"
            else f'type="box" size="{_vec(width / 2, width / 2, height / 2)}"'
        )
        b.body.append(
            f'<geom name="obstacle{i}" {shape} pos="{_vec(x, y, height / 2)}" material="{mat}"/>'
        )
    return [(x, y, width / 2 if kind == "cylinder" else width / math.sqrt(2))
            for kind, x, y, width, _, _ in drawn]  # fmt: skip


def _draw_obstacles(b: _Builder, walls: tuple[Wall, ...]) -> list[tuple] | None:
    """One round of :func:`_obstacles`: ``(kind, x, y, width, height, colour)`` of each
    obstacle, or None when one finds no room."""
    spec, rng = b.spec.obstacles, b.rng
    placed: list[Circle] = []
    drawn = []
    for _ in range(spec.count):
        kind = spec.kinds[int(rng.integers(len(spec.kinds)))]
        width, height = rng.uniform(*spec.width), rng.uniform(*spec.height)
        radius = width / 2 if kind == "cylinder" else width / math.sqrt(2)
        hx = b.spec.arena.size[0] / 2 - radius - spec.min_gap
        hy = b.spec.arena.size[1] / 2 - radius - spec.min_gap

        def in_arena(hx: float = hx, hy: float = hy) -> tuple[float, float]:
            return rng.uniform(-hx, hx), rng.uniform(-hy, hy)

        point = _place(in_arena, radius, placed, spec.min_gap, _OBSTACLE_ATTEMPTS, walls)
        if point is None:
            room = _room(radius, placed, spec.min_gap, walls, (hx, hy))
            if not len(room):
                return None
            point = tuple(float(v) for v in room[rng.integers(len(room))])
        x, y = point
        placed.append((x, y, radius))
        # the colour is drawn between positions, as worlds always drew it
        drawn.append((kind, x, y, width, height, spec.colours.draw(rng)))
    return drawn


def _interior_walls(b: _Builder) -> list[str]:
    """Geoms of the interior walls, split into panels textured like the arena walls."""
    spec = b.spec.interior_walls
    t, h = spec.thickness, spec.height
    geoms = []
    for w, (x0, y0, x1, y1) in enumerate(spec.segments):
        length = math.hypot(x1 - x0, y1 - y0)
        n = max(1, math.ceil(length / spec.panel_length - 1e-9))
        # thin along the local x axis, like the arena's panels (see _wall_panels)
        yaw = math.degrees(math.atan2(y1 - y0, x1 - x0)) - 90.0
        for p in range(n):
            f = (p + 0.5) / n
            mat = b.surface_material(b.spec.walls)
            pos = (x0 + f * (x1 - x0), y0 + f * (y1 - y0), h / 2)
            geoms.append(
                f'<geom name="iwall{w}_{p}" type="box" pos="{_vec(*pos)}" '
                f'size="{_vec(t / 2, length / n / 2, h / 2)}" euler="0 0 {_num(yaw)}" '
                f'material="{mat}"/>'
            )
    return geoms


def _light(name: str, az: float, el: float, diffuse: float) -> str:
    """A directional light shining from azimuth ``az`` and elevation ``el`` (radians)."""
    # The light shines *from* (az, el), so its direction points the other way.
    d = (-math.cos(el) * math.cos(az), -math.cos(el) * math.sin(az), -math.sin(el))
    return (
        f'<light name="{name}" type="directional" dir="{_vec(*d)}" '
        f'diffuse="{_vec(*(diffuse,) * 3)}" specular="0 0 0" ambient="0 0 0" '
        f'castshadow="false"/>'
    )


def _lights(b: _Builder) -> None:
    lights = b.spec.lights
    # with a sun (moved over the day at run time) the other lights are the sky's fill light
    prefix = "sun" if lights.sun is None else "sky"
    if lights.sun is not None:
        sun = lights.sun
        az, el = math.radians(sun.azimuth_deg), math.radians(sun.elevation_deg)
        b.body.append(_light("sun", az, el, sun.diffuse))
    for i, light in enumerate(lights.directional):
        az = math.radians(light.azimuth_deg + b.rng.uniform(-1, 1) * lights.jitter_deg)
        el = light.elevation_deg + b.rng.uniform(-1, 1) * lights.jitter_deg
        el = math.radians(min(90.0, max(1.0, el)))
        b.body.append(_light(f"{prefix}{i}", az, el, light.diffuse))


def build_world(
    spec: WorldSpec,
    world_seed: int = 0,
    robot: MJCFParts | None = None,
    dynamics: DynamicsSpec | None = None,
) -> World:
    """Generate one world of ``spec`` from ``world_seed``, optionally with a robot in it.

    Args:
        spec: the world spec.
        world_seed: seed of ``np.random.default_rng``; same seed -> identical MJCF text.
        robot: the robot's MJCF pieces (its bodies go into the worldbody).
        dynamics: the dynamics it runs under (an env's; None: the spec's): an outdoor world's
            parked objects of their ``arrangement`` day, its trees of their date (``seasons``),
            the ground's state and the lawn's season (``ground``, ``grass_seasons``).

    Returns:
        The MJCF text of the whole model and the world's layout. The model contains a fixed
        camera ``"overhead"`` looking straight down on the arena.
    """
    check_world_seed("world_seed", world_seed)
    robot = robot or MJCFParts()
    rng = np.random.default_rng(int(world_seed))
    b = _Builder(spec, rng)
    if spec.textures is not None:
        b.textures = Texturer(spec.textures, int(world_seed))
    day = spec.dynamics if dynamics is None else dynamics
    # the day's ground (wet, snow, the lawn's season); None: as built
    b.ground = ground_look_for(day)
    arena = spec.arena
    hx, hy = arena.size[0] / 2, arena.size[1] / 2
    zenith, horizon = spec.sky.zenith.draw(rng), spec.sky.horizon.draw(rng)
    files: dict[str, bytes] = {}  # generated images the MJCF names, besides the textures'
    if day is not None and day.cloud_cover is not None:
        clouds = sky_faces(
            world_seed, day.day, day.start_hour, zenith, horizon, day.cloud_cover, day.overcast
        )
        files["sky.png"] = png_bytes(clouds)
        b.assets.append(skybox_mjcf("sky", "sky.png"))
    else:
        b.assets.append(
            f'<texture name="sky" type="skybox" builtin="gradient" rgb1="{_vec(*zenith)}" '
            f'rgb2="{_vec(*horizon)}" width="256" height="1536"/>'
        )
    ground = b.textured("grass", b.surface_material(spec.ground))
    floor = b.textured("asphalt", b.surface_material(spec.floor))
    reach = max(hx, hy) + arena.wall_thickness + spec.landmarks.clearance + spec.landmarks.depth
    if spec.outdoor is not None:
        reach = max(reach, outer_reach(spec.outdoor, arena.size))
    ground_half = 4 * reach
    _boundary(b)
    # The rover drives on the ground plane (exact, cheap contacts); the floor is a visual tile.
    b.body.append(
        f'<geom name="floor" type="box" pos="0 0 -0.004" size="{_vec(hx, hy, 0.005)}" '
        f'material="{floor}" contype="0" conaffinity="0"/>'
    )
    obstacles = _obstacles(b)
    landmarks = _landmarks(b)
    # the movers' lanes come from the world seed alone (not from b.rng): one function for the
    # scene, which keeps them free, and the movers, which keep to them
    seed = int(world_seed)
    lanes = None if spec.dynamics is None else mover_lanes(spec.dynamics, arena.size, seed)
    if spec.outdoor is not None:
        # the day's parked objects and trees
        facades = designs_for(spec.outdoor.buildings, seed)
        changes = rearranged_for(day, seed), foliage_for(day, seed), facades
        landmarks += build_outdoor(b, lanes, *changes)
    if spec.dynamics is not None and lanes is not None and spec.dynamics.n_movers:
        # the movers draw from their own generator: the world around them stays the same
        mover_assets, mover_bodies = movers_mjcf(spec.dynamics, lanes, seed)
        b.assets.append(mover_assets)
        b.body.append(mover_bodies)
    # Geoms are drawn in model order: the ground last lets the depth test discard its hidden
    # pixels early (about 10 % faster on llvmpipe). The plane's third size is its rendering
    # grid: under directional and ambient light a coarse one looks like a fine one, faster.
    ground_index = len(b.body)
    b.body.append(
        f'<geom name="ground" type="plane" size="{_vec(ground_half, ground_half, ground_half)}" '
        f'material="{ground}"/>'
    )
    _lights(b)
    # Drawn last so that a spec without interior walls builds the worlds it built before they
    # existed; placed before the ground for the draw order above.
    b.body[ground_index:ground_index] = _interior_walls(b)

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
            # the name is free text: quoted and escaped, it cannot end the attribute
            f"<mujoco model={quoteattr(f'sfa_gym_{spec.name}_{int(world_seed)}')}>",
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
        walls=_walls(spec),
        blocks=() if spec.outdoor is None else spec.outdoor.blocks,
    )
    assets = files if b.textures is None else {**b.textures.files, **files}
    return World(mjcf=mjcf, layout=layout, lanes=lanes, assets=assets)
