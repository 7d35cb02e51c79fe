"""The ground by the date and the weather: the lawn's colour through the year, wet ground after
rain, lying snow.

A :class:`GroundLook` changes how the ground surfaces look (``grass``, ``asphalt``,
``paving``: the lawn, the asphalt and roads, the pavements); nothing else of the world moves or
changes colour, and without one the world is built as before, byte for byte. It comes from the
dynamics (:class:`~sfa_gym.sim.worlds.dynamics.DynamicsSpec`): its ``ground`` (``"dry"``,
``"wet"``, ``"snow"``) and, with ``grass_seasons`` and a ``day_of_year``, the lawn's season.
The world builder applies it where it emits a ground surface's material
(:meth:`sfa_gym.sim.worlds._mjcf.Builder.textured`): to the colours of a flat world's
material, or to every texel of a generated texture.

The physical effects modelled:

* **The lawn through the year** (a cool-season lawn of central Europe, about 50 degrees
  north): green and growing from May to October; frost and short days make it dormant, a
  dull straw-olive, from late November to early March. Its greenness ``v`` is 1 from day 120
  to day 300, falls to 0 by day 350, stays there to day 60 and rises to 1 by day 120; the
  colour is ``v * summer + (1 - v) * dormant``, where ``dormant`` is a straw tint of the
  summer colour's own luminance. In the southern hemisphere the calendar is shifted by half a
  year, as for the trees (:mod:`sfa_gym.sim.worlds.seasons`).
* **Wet ground** after rain: water fills a porous surface's pores and its film on top lowers
  the light scattered back out (Lekner & Dorf 1988, "Why some things are darker when wet",
  Applied Optics 27: 1278): asphalt and concrete about halve their reflectance, a lawn loses
  a fifth. The water film reflects the sun as a specular highlight (the material's
  ``specular`` and ``shininess``).
* **Lying snow**: fresh snow reflects 80-90 % of visible light, a little more in the blue. It
  covers the lawn almost wholly, the pavements mostly (trodden paths show the slabs), and the
  asphalt the rover drives on is cleared to wet slush. A generated texture's cover varies
  across the surface with ``1/f`` noise (drifts and thin spots); a flat world's material takes
  the mean cover.

The rover's physics does not change (no lower friction on wet or snowy ground).
"""

from __future__ import annotations

from typing import Any, Literal, get_args

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sfa_gym.sim.worlds.textures import noise

__all__ = [
    "GROUNDS",
    "GROUND_SURFACES",
    "Ground",
    "GroundLook",
    "check_ground",
    "grass_greenness",
    "ground_look_for",
]

Ground = Literal["dry", "wet", "snow"]
GROUNDS: tuple[str, ...] = get_args(Ground)
"""The states of the ground: dry, wet after rain, snow lying."""
GROUND_SURFACES = ("grass", "asphalt", "paving")
"""The surfaces a :class:`GroundLook` changes (the texture generators' names)."""

_GREEN_UP = (60.0, 120.0)  # days of the year: the lawn greens from dormant to summer
_DORMANCY = (300.0, 350.0)  # the lawn goes dormant
_LUMA = np.array([0.299, 0.587, 0.114])
_STRAW = np.array([1.25, 1.12, 0.62])  # a dormant lawn's tint, times its summer luminance
_STRAW /= _STRAW @ _LUMA  # of luminance 1
# wet / dry reflectance of each surface, and the water film's highlight (specular, shininess)
_WET_DARKENING = {"grass": 0.8, "asphalt": 0.55, "paving": 0.6}
_WET_FINISH = {"grass": (0.15, 0.3), "asphalt": (0.5, 0.8), "paving": (0.4, 0.7)}
_SNOW = np.array([0.84, 0.87, 0.92])  # fresh snow: 80-90 % reflectance, bluish
_SNOW_COVER = {"grass": 0.95, "asphalt": 0.2, "paving": 0.75}  # mean cover of each surface
_SNOW_PATCHINESS = 0.25  # standard deviation of a texture's cover across the surface


def check_ground(value: object) -> None:
    """Raise ValueError unless ``value`` is one of :data:`GROUNDS`."""
    if not (isinstance(value, str) and value in GROUNDS):
        raise ValueError(f"ground must be one of {list(GROUNDS)}, got {value!r}")


def _ramp(x: float, start: float, end: float) -> float:
    return float(np.clip((x - start) / (end - start), 0.0, 1.0))


def grass_greenness(day_of_year: int, latitude_deg: float) -> float:
    """The lawn's greenness ``v`` in [0, 1] on ``day_of_year`` at ``latitude_deg`` (1: summer
    green, 0: dormant; see the module docstring)."""
    day = float(day_of_year) if latitude_deg >= 0 else (day_of_year + 182.5 - 1) % 365.0 + 1
    return _ramp(day, *_GREEN_UP) * (1.0 - _ramp(day, *_DORMANCY))


def ground_look_for(dynamics: Any) -> GroundLook | None:
    """The ground's look under ``dynamics`` (a :class:`~sfa_gym.sim.worlds.dynamics.DynamicsSpec`
    or None, which imports this module); None for dry ground and a lawn as drawn (the world as
    built)."""
    if dynamics is None:
        return None
    greenness = 1.0
    if dynamics.grass_seasons:
        greenness = grass_greenness(dynamics.day_of_year, dynamics.latitude)
    if dynamics.ground == "dry" and greenness == 1.0:
        return None
    return GroundLook(dynamics.ground, greenness)


class GroundLook:
    """How the ground surfaces look on one day.

    Args:
        ground: one of :data:`GROUNDS`.
        greenness: the lawn's greenness in [0, 1] (:func:`grass_greenness`; 1: as drawn).
    """

    def __init__(self, ground: str, greenness: float = 1.0) -> None:
        check_ground(ground)
        if not 0.0 <= greenness <= 1.0:
            raise ValueError(f"greenness must lie in [0, 1], got {greenness!r}")
        self.ground, self.greenness = ground, float(greenness)

    def __repr__(self) -> str:
        return f"GroundLook({self.ground!r}, greenness={self.greenness:.3f})"

    def colour(
        self, surface: str, rgb: ArrayLike, cover: ArrayLike | None = None
    ) -> NDArray[np.float64]:
        """The colours ``rgb`` (``(..., 3)`` in [0, 1]) of ``surface`` on this day.

        Args:
            surface: one of :data:`GROUND_SURFACES`.
            rgb: the colours as built.
            cover: the snow's cover at each colour (``(...)`` in [0, 1]; with snow only);
                None: the surface's mean cover.
        """
        if surface not in GROUND_SURFACES:
            raise ValueError(f"surface must be one of {GROUND_SURFACES}, got {surface!r}")
        out = np.asarray(rgb, dtype=np.float64)
        if surface == "grass" and self.greenness < 1.0:
            dormant = (out @ _LUMA)[..., None] * _STRAW
            out = self.greenness * out + (1.0 - self.greenness) * dormant
        if self.ground == "wet" or (self.ground == "snow" and surface == "asphalt"):
            out = out * _WET_DARKENING[surface]  # slush on the cleared asphalt is wet too
        if self.ground == "snow":
            c = _SNOW_COVER[surface] if cover is None else np.asarray(cover, dtype=np.float64)
            c = np.asarray(c)[..., None]
            out = (1.0 - c) * out + c * _SNOW
        return np.clip(out, 0.0, 1.0)

    def texture(
        self, surface: str, image: NDArray[np.float64], rng: np.random.Generator
    ) -> NDArray[np.float64]:
        """A generated ``(n, n, 3)`` texture of ``surface`` on this day; ``rng`` draws the
        snow's drifts (tileable ``1/f`` noise around the surface's mean cover)."""
        if self.ground != "snow":
            return self.colour(surface, image)
        mean = _SNOW_COVER[surface]
        cover = np.clip(mean + _SNOW_PATCHINESS * noise(rng, image.shape[0]), 0.0, 1.0)
        return self.colour(surface, image, cover)

    def finish(self, surface: str) -> tuple[float, float]:
        """The material's ``specular`` and ``shininess`` for ``surface``: a water film's
        highlight on wet ground (and the cleared asphalt in snow), else matte (0, 0)."""
        if self.ground == "wet" or (self.ground == "snow" and surface == "asphalt"):
            return _WET_FINISH[surface]
        return 0.0, 0.0
