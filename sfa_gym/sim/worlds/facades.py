"""Building facades: their window grids, and a campus's buildings that repeat a few designs.

A facade's window grid is a MuJoCo builtin texture (``builtin="flat"`` with ``mark="edge"``:
glass coloured tiles framed by facade-coloured edges) repeated once per window pitch and
storey, or, with generated textures, a facade image of brick or plaster around its windows.

With ``outdoor.buildings.designs`` = ``n`` >= 1, a world draws ``n`` building designs (length,
depth, storeys, facade and window colours) and every building of its rows repeats one of
them, facade texture and all: the places of a campus look alike, as a method that localizes
by appearance must learn to tell apart. ``outdoor.blocks`` stands buildings of the same
designs inside the arena (axis-aligned boxes the rover collides with): the wings of a campus,
between which the drivable areas are joined by paths, so that a straight line between two
places often runs into a building. Designs and the picks of the building rows draw from a
generator of their own, seeded by the world seed; a world without designs draws its
buildings as before, each anew.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sfa_gym.sim.worlds._mjcf import Builder
from sfa_gym.sim.worlds._mjcf import vec as _vec
from sfa_gym.sim.worlds.spec import BuildingsSpec

__all__ = ["Building", "Design", "Designs", "designs_for", "window_material"]

_STREAM = 0xCA4B  # keeps this generator apart from every other one seeded by the world seed

Rgb = tuple[float, float, float]


def window_material(
    b: Builder, spec: BuildingsSpec, facade: Rgb, glass: Rgb, columns: int, storeys: int
) -> str:
    """A facade with ``columns`` x ``storeys`` windows on every face of a box."""
    name = f"mat{b.n_materials}"
    b.n_materials += 1
    # An 8-texel tile whose edge texels take the facade colour: one window per tile, framed.
    # The repeat counts windows per face (texuniform="false"): MuJoCo's uniform mapping
    # stretches the tiles over some faces of a box.
    b.assets.append(
        f'<texture name="tex_{name}" type="2d" builtin="flat" rgb1="{_vec(*glass)}" '
        f'rgb2="{_vec(*glass)}" mark="edge" markrgb="{_vec(*facade)}" width="8" height="8"/>'
    )
    b.assets.append(
        f'<material name="{name}" texture="tex_{name}" texrepeat="{columns} {storeys}" '
        f'texuniform="false" specular="0" shininess="0"/>'
    )
    bay = (spec.window_pitch, spec.storey_height)
    bays = (columns, storeys)  # one texture per face: every window its own
    return b.textured("facade", name, rgb=facade, glass=glass, bays=bays, bay_m=bay, repeat=(1, 1))


@dataclass(frozen=True)
class Design:
    """One building design: its footprint (m), storeys and colours."""

    length: float
    depth: float
    storeys: int
    facade: Rgb
    glass: Rgb


@dataclass(frozen=True)
class Building:
    """A building of a row: its design's footprint and storeys, and its facade's material."""

    length: float
    depth: float
    storeys: int
    material: str


def designs_for(spec: BuildingsSpec, world_seed: int) -> Designs | None:
    """The designs of a world with ``spec.designs`` >= 1 (None: every building its own)."""
    return Designs(spec, world_seed) if spec.designs else None


class Designs:
    """A world's building designs, and the materials made for them (one per design and window
    count, so that repeated facades are the same image)."""

    def __init__(self, spec: BuildingsSpec, world_seed: int) -> None:
        rng = np.random.default_rng([int(world_seed), _STREAM])
        self.spec = spec
        self.designs = [
            Design(
                length=float(rng.uniform(*spec.length)),
                depth=float(rng.uniform(*spec.depth)),
                storeys=int(rng.integers(spec.storeys[0], spec.storeys[1] + 1)),
                facade=spec.colours.draw(rng),
                glass=spec.windows.draw(rng),
            )
            for _ in range(spec.designs)
        ]
        self.rng = rng
        self._materials: dict[tuple[int, int], str] = {}

    def material(self, b: Builder, k: int, length: float) -> str:
        """The facade material of design ``k`` on a face ``length`` m long."""
        d = self.designs[k]
        columns = max(1, round(length / self.spec.window_pitch))
        if (k, columns) not in self._materials:
            material = window_material(b, self.spec, d.facade, d.glass, columns, d.storeys)
            self._materials[k, columns] = material
        return self._materials[k, columns]

    def draw(self, b: Builder) -> Building:
        """The next building of a row, one of the designs."""
        k = int(self.rng.integers(len(self.designs)))
        d = self.designs[k]
        return Building(d.length, d.depth, d.storeys, self.material(b, k, d.length))

    def blocks(
        self, b: Builder, rects: tuple[tuple[float, float, float, float], ...]
    ) -> tuple[list[str], list[tuple[str, float, float, float]]]:
        """The geoms and landmarks (``("block", x, y, height)``) of building blocks over
        ``rects`` (``(xmin, xmax, ymin, ymax)``, m), the designs taken in turn."""
        geoms, landmarks = [], []
        for i, (x0, x1, y0, y1) in enumerate(rects):
            k = i % len(self.designs)
            mat = self.material(b, k, max(x1 - x0, y1 - y0))
            height = self.designs[k].storeys * self.spec.storey_height
            cx, cy = (x0 + x1) / 2, (y0 + y1) / 2
            # a geom that collides (the default contype): the rover drives round it
            geoms.append(
                f'<geom name="block{i}" type="box" pos="{_vec(cx, cy, height / 2)}" '
                f'size="{_vec((x1 - x0) / 2, (y1 - y0) / 2, height / 2)}" material="{mat}"/>'
            )
            landmarks.append(("block", cx, cy, height))
        return geoms, landmarks
