"""The MJCF text builder that the world generators share: fixed-precision numbers and an
accumulator of assets and geoms that draws from one random generator in a fixed order."""

from __future__ import annotations

from typing import Any

import numpy as np

from sfa_gym.sim.worlds.spec import SurfaceSpec, WorldSpec
from sfa_gym.sim.worlds.texturing import Texturer

__all__ = ["Builder", "num", "vec"]


def num(x: float) -> str:
    # Fixed precision keeps the MJCF text identical for identical seeds on every platform.
    s = f"{x:.4f}".rstrip("0").rstrip(".")
    return "0" if s in ("-0", "") else s


def vec(*xs: float) -> str:
    return " ".join(num(x) for x in xs)


class Builder:
    """Accumulates assets and geoms while drawing from one random generator, in a fixed order."""

    def __init__(self, spec: WorldSpec, rng: np.random.Generator):
        self.spec = spec
        self.rng = rng
        self.assets: list[str] = []
        self.body: list[str] = []
        self.n_materials = 0
        # generated textures (a spec's ``textures`` block), drawn apart from ``rng``; None: off
        self.textures: Texturer | None = None
        self.colours: dict[str, tuple[float, float, float]] = {}  # material -> mean colour

    def textured(self, surface: str, material: str, **extra: Any) -> str:
        """``material``; with generated textures on, a material of the ``surface``'s texture
        (:data:`~sfa_gym.sim.worlds.texturing.SURFACES`) in ``material``'s mean colour
        instead (``extra``: see :meth:`Texturer.material`)."""
        if self.textures is None:
            return material
        rgb = extra.pop("rgb", None) or self.colours[material]
        return self.textures.material(surface, material, rgb, self.assets, **extra)

    def plain_material(self, rgb: tuple[float, float, float], alpha: float = 1.0) -> str:
        """A matte material of colour ``rgb`` (``alpha`` < 1: see-through)."""
        name = f"mat{self.n_materials}"
        self.n_materials += 1
        self.colours[name] = rgb
        self.assets.append(
            f'<material name="{name}" rgba="{vec(*rgb, alpha)}" specular="0" shininess="0"/>'
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
        # the mean colour the texture shows: its two colours (one for "flat"), then the marks
        mean = np.asarray(rgb1) if kind == "flat" else (np.asarray(rgb1) + np.asarray(rgb2)) / 2
        mean = (1 - surface.marks) * mean + surface.marks * np.asarray(mark_rgb)
        self.colours[name] = (float(mean[0]), float(mean[1]), float(mean[2]))
        marks = ""
        if surface.marks > 0:
            marks = f' mark="random" random="{num(surface.marks)}" markrgb="{vec(*mark_rgb)}"'
        self.assets.append(
            f'<texture name="tex_{name}" type="2d" builtin="{kind}" rgb1="{vec(*rgb1)}" '
            f'rgb2="{vec(*rgb2)}" width="128" height="128"{marks}/>'
        )
        self.assets.append(
            f'<material name="{name}" texture="tex_{name}" texrepeat="{vec(repeat, repeat)}" '
            f'texuniform="true" specular="0" shininess="0"/>'
        )
        return name
