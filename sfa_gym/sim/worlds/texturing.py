"""Generated textures in a world's MJCF: one texture and material per textured surface.

With a world spec's ``textures`` block, the world builder asks a :class:`Texturer` for a
textured version of a surface's material (:meth:`sfa_gym.sim.worlds._mjcf.Builder.textured`):
the texture is drawn in the material's mean colour by a generator of
:mod:`sfa_gym.sim.worlds.textures`, encoded as PNG and named in the MJCF by a file name that
the model compiles from (``mujoco.MjModel.from_xml_string(mjcf, assets)``; the env passes
:attr:`World.assets <sfa_gym.sim.worlds.build.World>`). MuJoCo samples every 2-d and cube
texture trilinearly from mipmaps it makes at upload, so distant textures average out instead
of aliasing.

Each texture draws from its own generator, seeded by the world seed, the surface and the
material it replaces, never from the world's generator: turning textures on leaves every
position, size and colour of the world as it was, and the same world seed gives the same bytes.
"""

from __future__ import annotations

import zlib
from typing import Any

import numpy as np

from sfa_gym.sim.worlds import textures as _tx
from sfa_gym.sim.worlds.ground import GroundLook
from sfa_gym.sim.worlds.textures import RGB, TexturesSpec

__all__ = ["CUBE_SURFACES", "SURFACES", "Texturer"]

SURFACES = _tx.GENERATORS
"""The surfaces that can be textured."""
CUBE_SURFACES = ("bark", "foliage", "bush")
"""Surfaces of round geoms (trunks, crowns): cube textures, which MuJoCo maps onto ellipsoids
and cylinders by direction, without the stripes a 2-d texture leaves on their sides."""
_STREAM = 35  # keeps the textures' generators apart from any other use of the world seed


def _fmt(x: float) -> str:
    s = f"{x:.4f}".rstrip("0").rstrip(".")
    return "0" if s in ("-0", "") else s


class Texturer:
    """Draws the textures of one world and collects their PNG files.

    Args:
        spec: the textures' settings.
        world_seed: the world's seed.
    """

    def __init__(self, spec: TexturesSpec, world_seed: int) -> None:
        self.spec = spec
        self.world_seed = int(world_seed)
        self.files: dict[str, bytes] = {}
        self._made: dict[tuple[str, str], str] = {}

    def _rng(self, surface: str, source: str) -> np.random.Generator:
        return np.random.default_rng(
            [self.world_seed, _STREAM, SURFACES.index(surface), zlib.crc32(source.encode())]
        )

    def image(
        self, surface: str, source: str, rgb: RGB, look: GroundLook | None = None, **extra: Any
    ) -> np.ndarray:
        """The ``(n, n, 3)`` uint8 texture of ``surface`` replacing material ``source`` of
        mean colour ``rgb``, under the ground ``look`` (None: as generated); ``extra`` for
        facades: ``glass`` (RGB), ``bays`` (columns, storeys) and ``bay_m`` (width,
        height)."""
        if surface not in SURFACES:
            raise ValueError(f"surface must be one of {SURFACES}, got {surface!r}")
        rng, spec = self._rng(surface, source), self.spec
        n = spec.resolution // 2 if surface in CUBE_SURFACES else spec.resolution
        if surface == "asphalt":
            out = _tx.asphalt(rng, n, rgb, spec.cracks)
        elif surface == "grass":
            out = _tx.grass(rng, n, rgb)
        elif surface == "paving":
            out = _tx.paving(rng, n, rgb, spec.tile_m)
        elif surface == "concrete":
            out = _tx.concrete(rng, n, rgb)
        elif surface == "facade":
            brick = bool(rng.random() < 0.5)
            out = _tx.facade(rng, n, rgb, extra["glass"], extra["bays"], extra["bay_m"], brick)
        elif surface == "bark":
            out = _tx.bark(rng, n, rgb)
        else:
            gaps = spec.canopy_gaps * (0.5 if surface == "bush" else 1.0)
            out = _tx.foliage(rng, n, rgb, gaps)
        if look is not None:  # drawn after the texture: the texture stays as it was
            out = look.texture(surface, out, rng)
        return _tx.to_uint8(out)

    def material(
        self,
        surface: str,
        source: str,
        rgb: RGB,
        assets: list[str],
        repeat: tuple[float, float] | None = None,
        alpha: float = 1.0,
        look: GroundLook | None = None,
        **extra: Any,
    ) -> str:
        """The name of a textured material for ``surface`` in place of material ``source``;
        its texture and material go into ``assets`` the first time (a material shared by
        several geoms stays shared).

        Args:
            surface: one of :data:`SURFACES`.
            source: the material it replaces.
            rgb: that material's mean colour.
            assets: the builder's asset list.
            repeat: texture repeats per face (facades: windows and storeys per face); None:
                one tile per ``tile_m`` metres (ground surfaces) or a cube texture.
            alpha: the material's opacity (below 1: see-through).
            look: the day's ground look (a ground surface's; None: as generated).
            extra: the facade's ``glass`` colour and ``bay_m`` (width, height).
        """
        key = (surface, source)
        if key in self._made:
            return self._made[key]
        name = f"gen_{surface}{len(self._made)}"
        self._made[key] = name
        image = self.image(surface, source, rgb, look, **extra)
        self.files[f"{name}.png"] = _tx.png_bytes(image)
        specular, shininess = (0.0, 0.0) if look is None else look.finish(surface)
        plain = f'specular="{_fmt(specular)}" shininess="{_fmt(shininess)}"'
        if alpha != 1.0:
            plain += f' rgba="1 1 1 {_fmt(alpha)}"'
        if surface in CUBE_SURFACES:
            assets.append(f'<texture name="tex_{name}" type="cube" file="{name}.png"/>')
            assets.append(f'<material name="{name}" texture="tex_{name}" {plain}/>')
            return name
        assets.append(f'<texture name="tex_{name}" type="2d" file="{name}.png"/>')
        if repeat is None:
            per_metre = 1.0 / self.spec.tile_m
            mapping = f'texrepeat="{_fmt(per_metre)} {_fmt(per_metre)}" texuniform="true"'
        else:
            mapping = f'texrepeat="{_fmt(repeat[0])} {_fmt(repeat[1])}" texuniform="false"'
        assets.append(f'<material name="{name}" texture="tex_{name}" {mapping} {plain}/>')
        return name
