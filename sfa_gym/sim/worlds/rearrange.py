"""Parked objects that change from day to day.

An outdoor world's surroundings are drawn from its seed once, but outside, what stands still
from one hour to the next changes between days: cars park elsewhere, wheelie bins are put out
for collection, benches are set up, a building site fences off a strip of grass. With a
dynamics ``arrangement`` day other than 0
(:class:`~sfa_gym.sim.worlds.dynamics.DynamicsSpec`), the world is built as its seed says,
then, with ``share`` = the dynamics' ``rearrange_share``:

* each parked car has left with probability ``share``; its place stays empty unless a newcomer
  takes it;
* newcomers park in the free places of the row, as many as left on average (Poisson, mean
  ``share`` times the row's cars), in the row's sizes and colours;
* wheelie bins (Poisson, mean ``4 share``) and benches (mean ``2 share``) stand on the grass
  just beyond the pavement;
* with probability ``share``, a building-site fence (2-4 mesh panels on concrete feet) stands
  beyond the pavement.

All of it draws from a generator of its own, seeded by the world seed and the day, after the
rest of the scene: everything else is exactly as built (the same MJCF), the same day always
looks the same, and day 0 is the world as built. Nothing of it collides: like the rest of the
surroundings it stands outside the arena.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from sfa_gym.sim.worlds.outdoor import CAR_LENGTH, Rect, Scene, Side, box_geom, park_car

if TYPE_CHECKING:
    from sfa_gym.sim.worlds.dynamics import DynamicsSpec

__all__ = ["Rearranged", "rearranged_for"]

_STREAM = 0x0DA7  # keeps this generator apart from every other one seeded by the world seed
_BIN = (0.58, 0.74, 1.07)  # a 240-litre wheelie bin: width, depth, height (m)
_BIN_COLOURS = ((0.1, 0.28, 0.14), (0.28, 0.28, 0.3), (0.1, 0.2, 0.48), (0.36, 0.23, 0.1))
_BENCH = (1.8, 0.5, 0.45, 0.85)  # length, depth, seat height, backrest top (m)
_WOOD, _STEEL = (0.45, 0.3, 0.18), (0.2, 0.2, 0.21)
_PANEL = (3.5, 2.0)  # a building-site fence panel: length, height (m)
_MESH, _CONCRETE = (0.72, 0.72, 0.74), (0.55, 0.55, 0.52)
_MESH_ALPHA = 0.35  # a wire mesh hides about a third of what lies behind it


def rearranged_for(dynamics: DynamicsSpec | None, world_seed: int) -> Rearranged | None:
    """The day's rearrangement of a world under ``dynamics`` (a
    :class:`~sfa_gym.sim.worlds.dynamics.DynamicsSpec` or None); None on day 0 or without
    dynamics."""
    if dynamics is None or dynamics.arrangement == 0:
        return None
    return Rearranged(dynamics.arrangement, dynamics.rearrange_share, world_seed)


class Rearranged:
    """One day's changes to a scene's parked objects (see the module docstring)."""

    def __init__(self, day: int, share: float, world_seed: int) -> None:
        self.day, self.share = int(day), float(share)
        self.rng = np.random.default_rng([int(world_seed), self.day, _STREAM])
        self.left: list[Rect] = []  # the places of the cars that left
        self.row = 0  # cars the world parks in its row

    def stays(self, place: Rect) -> bool:
        """Whether the car the world parks at ``place`` is there on this day."""
        self.row += 1
        if self.rng.random() < self.share:
            self.left.append(place)
            return False
        return True

    def arrive(self, s: Scene, car_side: Side) -> None:
        """Add the day's newcomers to the finished scene ``s`` (the row of parked cars along
        ``car_side``)."""
        for place in self.left:
            s.taken.remove(place)
        rng = self.rng
        for _ in range(rng.poisson(self.share * self.row)):
            self._car(s, car_side)
        for _ in range(rng.poisson(4 * self.share)):
            self._bin(s)
        for _ in range(rng.poisson(2 * self.share)):
            self._bench(s)
        if rng.random() < self.share:
            self._site_fence(s)

    def _near_pavement(self, s: Scene, depth: float, length: float, near: float, far: float):
        """A free footprint ``depth`` x ``length`` between ``near`` and ``far`` metres beyond
        the pavement on a random side, taken, and its side; None where none was found."""
        rng = self.rng
        side = s.sides[int(rng.integers(4))]
        edge = side.edge + s.spec.pavement_width
        reach = side.half + s.spec.pavement_width + far  # along the side, past its corners

        def draw() -> Rect:
            out = edge + rng.uniform(near, far) + depth / 2
            return side.rect(out, rng.uniform(-reach, reach), depth, length)

        place = s.try_place(draw, attempts=60)
        return None if place is None else (place, side)

    def _car(self, s: Scene, side: Side) -> None:
        spec, rng = s.spec.cars, self.rng
        width, height = rng.uniform(*spec.width), rng.uniform(*spec.height)
        length = CAR_LENGTH * width
        out = side.edge + s.spec.pavement_width + 0.5 + width / 2
        body = s.material(spec.colours.draw(rng))

        def draw() -> Rect:
            return side.rect(out, rng.uniform(-side.half - 2.0, side.half + 2.0), width, length)

        place = s.try_place(draw, attempts=30)
        if place is not None:
            park_car(s, place, (length, width, height), body, side.normal[0] == 0.0)

    def _bin(self, s: Scene) -> None:
        width, depth, height = _BIN
        found = self._near_pavement(s, depth, width, 0.2, 1.0)
        if found is None:
            return
        place, _ = found
        colour = s.material(_BIN_COLOURS[int(self.rng.integers(len(_BIN_COLOURS)))])
        name = s.name("bin")
        s.geoms.append(box_geom(name, place, 0.0, height - 0.08, colour))
        lid = (place[0] - 0.02, place[1] + 0.02, place[2] - 0.02, place[3] + 0.02)
        s.geoms.append(box_geom(f"{name}_lid", lid, height - 0.08, height, colour))
        s.landmarks.append(("bin", *_centre(place), height))

    def _bench(self, s: Scene) -> None:
        length, depth, seat, top = _BENCH
        found = self._near_pavement(s, depth, length, 0.3, 1.5)
        if found is None:
            return
        place, side = found
        wood, steel = s.material(_WOOD), s.material(_STEEL)
        name = s.name("bench")
        s.geoms.append(box_geom(name, place, seat - 0.05, seat, wood))
        # the backrest on the far side: the bench faces the arena
        nx, ny = side.normal
        back = _strip(place, nx, ny, 0.06)
        s.geoms.append(box_geom(f"{name}_back", back, seat + 0.05, top, wood))
        for k, end in enumerate(_ends(place, nx, 0.06)):
            s.geoms.append(box_geom(f"{name}_leg{k}", end, 0.0, seat - 0.05, steel))
        s.landmarks.append(("bench", *_centre(place), top))

    def _site_fence(self, s: Scene) -> None:
        panels = int(self.rng.integers(2, 5))
        length, height = _PANEL
        found = self._near_pavement(s, 0.25, panels * length, 0.5, 5.0)
        if found is None:
            return
        place, side = found
        nx, _ = side.normal
        mesh = s.b.plain_material(_MESH, alpha=_MESH_ALPHA)
        concrete, steel = s.material(_CONCRETE), s.material(_STEEL)
        name = s.name("site_fence")
        line = _strip(place, *side.normal, 0.03, centred=True)
        s.geoms.append(box_geom(f"{name}_mesh", line, 0.15, 0.15 + height, mesh))
        for k, z in enumerate((0.15, 0.15 + height - 0.04)):
            s.geoms.append(box_geom(f"{name}_tube{k}", line, z, z + 0.04, steel))
        for k, foot in enumerate(_joints(place, nx, panels)):
            s.geoms.append(box_geom(f"{name}_foot{k}", foot, 0.0, 0.15, concrete))
        s.landmarks.append(("site_fence", *_centre(place), 0.15 + height))


def _centre(r: Rect) -> tuple[float, float]:
    return (r[0] + r[1]) / 2, (r[2] + r[3]) / 2


def _strip(r: Rect, nx: float, ny: float, thickness: float, centred: bool = False) -> Rect:
    """A strip ``thickness`` deep along the length of the footprint ``r``: on its side
    farthest along the normal ``(nx, ny)``, or through its middle (``centred``)."""
    x0, x1, y0, y1 = r
    if nx:  # the length runs along y
        c = (x0 + x1) / 2 if centred else (x1 - thickness / 2 if nx > 0 else x0 + thickness / 2)
        return (c - thickness / 2, c + thickness / 2, y0, y1)
    c = (y0 + y1) / 2 if centred else (y1 - thickness / 2 if ny > 0 else y0 + thickness / 2)
    return (x0, x1, c - thickness / 2, c + thickness / 2)


def _ends(r: Rect, nx: float, thickness: float) -> tuple[Rect, Rect]:
    """Strips ``thickness`` long across both ends of the footprint ``r`` (its length along y
    when ``nx``, else along x)."""
    x0, x1, y0, y1 = r
    if nx:
        return (x0, x1, y0, y0 + thickness), (x0, x1, y1 - thickness, y1)
    return (x0, x0 + thickness, y0, y1), (x1 - thickness, x1, y0, y1)


def _joints(r: Rect, nx: float, panels: int) -> list[Rect]:
    """The concrete feet (0.7 m along the fence) at the ends and joints of ``panels`` equal
    panels over the footprint ``r``."""
    x0, x1, y0, y1 = r
    feet = []
    for k in range(panels + 1):
        f = k / panels
        if nx:
            y = y0 + f * (y1 - y0)
            feet.append((x0, x1, max(y0, y - 0.35), min(y1, y + 0.35)))
        else:
            x = x0 + f * (x1 - x0)
            feet.append((max(x0, x - 0.35), min(x1, x + 0.35), y0, y1))
    return feet
