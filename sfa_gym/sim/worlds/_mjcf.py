"""The MJCF text builder that the world generators share: fixed-precision numbers and an
accumulator of assets and geoms that draws from one random generator in a fixed order."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from sfa_gym.sim.worlds.ground import GROUND_SURFACES, GroundLook
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
        # the day's ground (wet, snow, the lawn's season); None: the ground as built
        self.ground: GroundLook | None = None
        self.colours: dict[str, tuple[float, float, float]] = {}  # material -> mean colour
        # material -> how it was made (its emitter and arguments), so a ground look can remake it
        self._recipes: dict[str, tuple[Callable[..., None], dict[str, Any]]] = {}
        self._looked: dict[str, str] = {}  # material -> its version under ``ground``

    def textured(self, surface: str, material: str, **extra: Any) -> str:
        """``material``; with generated textures on, a material of the ``surface``'s texture
        (:data:`~sfa_gym.sim.worlds.texturing.SURFACES`) in ``material``'s mean colour
        instead (``extra``: see :meth:`Texturer.material`). A ground surface
        (:data:`~sfa_gym.sim.worlds.ground.GROUND_SURFACES`) takes the day's ``ground`` look."""
        look = self.ground if surface in GROUND_SURFACES else None
        if self.textures is None:
            return material if look is None else self._remade(material, surface, look)
        rgb = extra.pop("rgb", None) or self.colours[material]
        return self.textures.material(surface, material, rgb, self.assets, look=look, **extra)

    def plain_material(self, rgb: tuple[float, float, float], alpha: float = 1.0) -> str:
        """A matte material of colour ``rgb`` (``alpha`` < 1: see-through)."""
        name = f"mat{self.n_materials}"
        self.n_materials += 1
        self.colours[name] = rgb
        self._recipes[name] = (self._emit_plain, {"rgb": rgb, "alpha": alpha})
        self._emit_plain(name, rgb, alpha)
        return name

    def _emit_plain(
        self, name: str, rgb: Any, alpha: float, finish: tuple[float, float] = (0.0, 0.0)
    ) -> None:
        self.assets.append(
            f'<material name="{name}" rgba="{vec(*rgb, alpha)}" specular="{num(finish[0])}" '
            f'shininess="{num(finish[1])}"/>'
        )

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
        recipe = {
            "kind": kind,
            "rgb1": rgb1,
            "rgb2": rgb2,
            "mark_rgb": mark_rgb,
            "marks": surface.marks,
            "repeat": repeat,
        }
        self._recipes[name] = (self._emit_surface, recipe)
        self._emit_surface(name, **recipe)
        return name

    def _emit_surface(
        self,
        name: str,
        kind: str,
        rgb1: Any,
        rgb2: Any,
        mark_rgb: Any,
        marks: float,
        repeat: float,
        finish: tuple[float, float] = (0.0, 0.0),
    ) -> None:
        mark = ""
        if marks > 0:
            mark = f' mark="random" random="{num(marks)}" markrgb="{vec(*mark_rgb)}"'
        self.assets.append(
            f'<texture name="tex_{name}" type="2d" builtin="{kind}" rgb1="{vec(*rgb1)}" '
            f'rgb2="{vec(*rgb2)}" width="128" height="128"{mark}/>'
        )
        self.assets.append(
            f'<material name="{name}" texture="tex_{name}" texrepeat="{vec(repeat, repeat)}" '
            f'texuniform="true" specular="{num(finish[0])}" shininess="{num(finish[1])}"/>'
        )

    def _remade(self, material: str, surface: str, look: GroundLook) -> str:
        """``material`` (of this builder) remade under the ground ``look``: its colours
        changed as ``surface``'s, its finish the look's; made once, then shared."""
        if material not in self._looked:
            name = f"{material}_{look.ground}"
            emit, recipe = self._recipes[material]
            recipe = dict(recipe)
            for key in ("rgb", "rgb1", "rgb2", "mark_rgb"):
                if key in recipe:
                    recipe[key] = tuple(float(v) for v in look.colour(surface, recipe[key]))
            emit(name, **recipe, finish=look.finish(surface))
            self._looked[material] = name
        return self._looked[material]
