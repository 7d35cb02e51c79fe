"""The trees' foliage by the date: leaf-out in spring, autumn colours, bare crowns in winter.

With the dynamics' ``seasons`` on and a ``day_of_year``
(:class:`~sfa_gym.sim.worlds.dynamics.DynamicsSpec`), an outdoor world's deciduous trees follow
the phenology of a temperate broad-leaved tree in central Europe (about 50 degrees north;
beech, oak and lime leaf out from late April, colour from late September and are bare by mid
November):

* **leaf cover** ``c``: 0 until day 105, rising to 1 by day 135, 1 through the summer, falling
  from day 295 to 0 by day 320;
* **autumn tint** ``a``: 0 until day 260, rising to 1 by day 295 (the crown's colour moves to
  a yellow, orange or brown of its own, drawn per tree).

A crown shows its leaves' colour over bare branches in proportion to ``c``: colour
``c * leaves + (1 - c) * branches`` (each tree its own shades of both) and opacity
``0.4 + 0.6 c`` (a bare crown is a see-through grey-brown tangle of twigs). In the southern
hemisphere (negative latitude) the calendar is shifted by half a year. Bushes are evergreen
(hedges, shrubs) and keep their colour; the grass and the ground are left as they are. The
colours draw from a generator of their own, so every position and size of the world stays as
its seed built it.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from sfa_gym.sim.worlds.dynamics import DynamicsSpec

__all__ = ["Foliage", "foliage_for", "leaf_state"]

RGB = tuple[float, float, float]

_STREAM = 0x5EA5  # keeps this generator apart from every other one seeded by the world seed
_LEAF_OUT = (105.0, 135.0)  # days of the year: leaf cover rises from 0 to 1
_TINT = (260.0, 295.0)  # the autumn colours come
_LEAF_FALL = (295.0, 320.0)  # leaf cover falls from 1 to 0
_AUTUMN = ((0.85, 0.65, 0.12), (0.85, 0.4, 0.08), (0.55, 0.28, 0.1))  # yellow, orange, brown
_BRANCHES = (0.24, 0.2, 0.17)
_BARE_OPACITY = 0.4  # a bare crown's twigs hide some of what lies behind (a branch area of 1)


def _ramp(x: float, start: float, end: float) -> float:
    return float(np.clip((x - start) / (end - start), 0.0, 1.0))


def leaf_state(day_of_year: int, latitude_deg: float) -> tuple[float, float]:
    """The leaf cover ``c`` and autumn tint ``a`` (both in [0, 1]) on ``day_of_year`` at
    ``latitude_deg`` (see the module docstring)."""
    day = float(day_of_year) if latitude_deg >= 0 else (day_of_year + 182.5 - 1) % 365.0 + 1
    cover = _ramp(day, *_LEAF_OUT) * (1.0 - _ramp(day, *_LEAF_FALL))
    return cover, _ramp(day, *_TINT)


def foliage_for(dynamics: DynamicsSpec | None, world_seed: int) -> Foliage | None:
    """The trees' foliage under ``dynamics``; None without seasons (the crowns as drawn)."""
    if dynamics is None or not dynamics.seasons:
        return None
    cover, tint = leaf_state(dynamics.day_of_year, dynamics.latitude)
    return Foliage(cover, tint, world_seed)


class Foliage:
    """The crowns of one date: :meth:`crown` turns a tree's summer colour into its colour and
    opacity on that date."""

    def __init__(self, cover: float, tint: float, world_seed: int) -> None:
        self.cover, self.tint = float(cover), float(tint)
        self.rng = np.random.default_rng([int(world_seed), _STREAM])

    def crown(self, summer: RGB) -> tuple[RGB, float]:
        """The colour and opacity of the next tree's crown, green as ``summer`` in July."""
        # drawn for every tree in turn, whatever the date: a tree keeps its autumn colour
        autumn = np.asarray(_AUTUMN[int(self.rng.integers(len(_AUTUMN)))])
        autumn = autumn * self.rng.uniform(0.8, 1.1)
        branches = np.asarray(_BRANCHES) * self.rng.uniform(0.85, 1.15)
        leaves = (1.0 - self.tint) * np.asarray(summer) + self.tint * autumn
        rgb = self.cover * leaves + (1.0 - self.cover) * branches
        colour = tuple(float(v) for v in np.clip(rgb, 0.0, 1.0))
        return colour, _BARE_OPACITY + (1.0 - _BARE_OPACITY) * self.cover  # type: ignore[return-value]
