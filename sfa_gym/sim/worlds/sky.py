"""The sky as a cube texture: a clear-sky gradient and a layer of clouds over the world.

Without a ``cloud_cover`` the world builder keeps MuJoCo's builtin gradient skybox. With one
(:class:`~sfa_gym.sim.worlds.dynamics.DynamicsSpec`), :func:`sky_faces` draws the six faces of
the skybox from these physical pieces:

* **Clear sky**: the world's horizon colour at the horizon, its zenith colour overhead, most of
  the change within the lowest 30 degrees (weight ``sqrt(sin(elevation))``), as the sky
  whitens towards the horizon through the longer path of air.
* **Cloud layer**: a flat layer at :data:`CLOUD_BASE_M` (fair-weather cumulus), seen from below:
  a direction ``d`` meets it at ``d_xy * CLOUD_BASE_M / d_z``. The cloud field is Gaussian
  noise whose amplitude falls as ``1/f^(4/3)`` (power ``f^(-8/3)`` in two dimensions, so
  ``f^(-5/3)`` along a line, the scaling measured for cloud liquid water in satellite images:
  Cahalan & Snider 1989) below an outer scale of :data:`CLOUD_SCALE_M` (the size of a field of
  fair-weather cumulus cells; beyond it the spectrum is flat, so that every few kilometres
  show the cover); the ``cloud_cover`` fraction of the layer where the field is highest is
  cloud, its optical depth growing with the field above that threshold. Thin cloud is
  white, thick cloud a grey base.
* **Aerial perspective**: distant clouds fade into the horizon's colour by Koschmieder's law
  for a clear day's visibility (:data:`VISIBILITY_M`), so the clouds vanish towards the
  horizon instead of piling up into aliased noise; each texel also samples the field
  low-passed to its footprint on the layer (a mip pyramid of the field).
* **Weather**: the field drifts with a wind drawn per day and is redrawn every hour (each hour
  blends into the next), so another hour or day shows other clouds; ``overcast`` thickens the
  cover towards a closed grey deck.

The texture is drawn once, when the world is built: for the clock's start hour of the
dynamics. The clouds do not move while the rover drives (as the gradient does not change
over the day, :mod:`sfa_gym.sim.worlds.dynamics`). Everything is a pure function of the world
seed, the day, the hour and the colours: the same arguments give the same bytes.
"""

from __future__ import annotations

import math
from statistics import NormalDist

import numpy as np
from numpy.typing import NDArray

from sfa_gym.sim.worlds.textures import RGB, to_uint8

__all__ = [
    "CLOUD_BASE_M",
    "CLOUD_SCALE_M",
    "FACE_TEXELS",
    "VISIBILITY_M",
    "face_directions",
    "sky_faces",
    "skybox_mjcf",
]

CLOUD_BASE_M = 1500.0
"""Height of the cloud layer above the ground (m): the base of fair-weather cumulus."""
CLOUD_SCALE_M = 4000.0
"""Outer scale of the cloud field (m): larger structures have no more variance than it."""
VISIBILITY_M = 30000.0
"""Meteorological visibility of a clear day (m), for the clouds' aerial perspective."""
FACE_TEXELS = 256
"""Texels per side of a cube face: 0.35 degrees at a face's centre, finer than a 600-column
panorama's 0.6 degrees per pixel."""
_TILE_M = 40960.0  # the cloud field tiles every 41 km: far beyond what the haze leaves visible
_CELLS = 1024  # 40 m cells
_WIND_M_S = (3.0, 12.0)
_STREAM = 36  # keeps the sky's generators apart from any other use of the world seed
_THICK = 2.5  # optical depth per standard deviation of the field above the cover's threshold


def face_directions(n: int) -> NDArray[np.float64]:
    """``(6, n, n, 3)`` unit world directions (z up) of the texel centres of a skybox's faces,
    in the order and orientation MuJoCo reads a skybox file with ``gridsize="6 1"
    gridlayout="RLUDFB"``: +x, -x, +z, -z, -y, +y; row ``i`` and column ``j`` of each face
    (measured by rendering a texture whose texels encode their face, row and column)."""
    c = (np.arange(n) + 0.5) / n * 2.0 - 1.0
    rows, cols = np.meshgrid(c, c, indexing="ij")
    one = np.ones_like(rows)
    faces = np.stack(
        [
            np.stack([one, cols, -rows], -1),  # R: +x
            np.stack([-one, -cols, -rows], -1),  # L: -x
            np.stack([cols, -rows, one], -1),  # U: +z (up)
            np.stack([cols, rows, -one], -1),  # D: -z
            np.stack([cols, -one, -rows], -1),  # F: -y
            np.stack([-cols, one, -rows], -1),  # B: +y
        ]
    )
    return faces / np.linalg.norm(faces, axis=-1, keepdims=True)


def _clear_sky(up: NDArray[np.float64], zenith: RGB, horizon: RGB) -> NDArray[np.float64]:
    weight = np.sqrt(np.clip(up, 0.0, 1.0))[..., None]
    return (1.0 - weight) * np.asarray(horizon) + weight * np.asarray(zenith)


def _pyramid(field: NDArray[np.float64]) -> list[NDArray[np.float64]]:
    """The tileable ``field`` and its 2 x 2 box-filtered halvings down to 4 x 4 cells."""
    levels = [field]
    while levels[-1].shape[0] > 4:
        f = levels[-1]
        levels.append(0.25 * (f[0::2, 0::2] + f[1::2, 0::2] + f[0::2, 1::2] + f[1::2, 1::2]))
    return levels


def _bilinear(field: NDArray[np.float64], u: NDArray, v: NDArray) -> NDArray[np.float64]:
    """``field`` (tileable) at fractional cell coordinates ``(u, v)`` (cell centres at
    integers)."""
    n = field.shape[0]
    u0, v0 = np.floor(u), np.floor(v)
    fu, fv = u - u0, v - v0
    i0, j0 = u0.astype(np.int64) % n, v0.astype(np.int64) % n
    i1, j1 = (i0 + 1) % n, (j0 + 1) % n
    return (1 - fu) * ((1 - fv) * field[i0, j0] + fv * field[i0, j1]) + fu * (
        (1 - fv) * field[i1, j0] + fv * field[i1, j1]
    )


def _filtered(levels: list[NDArray[np.float64]], x: NDArray, y: NDArray, level: NDArray):
    """The field at ground-plane metres ``(x, y)`` of the layer, low-passed to the fractional
    pyramid ``level`` (0: the full field) by blending the two nearest levels."""
    top = len(levels) - 1
    level = np.clip(level, 0.0, top)
    lo = np.floor(level).astype(np.int64)
    out = np.zeros_like(x)
    for k in np.unique(lo):
        sel = lo == k
        values = []
        for lev in (k, min(k + 1, top)):
            cell = _TILE_M / levels[lev].shape[0]
            values.append(_bilinear(levels[lev], x[sel] / cell - 0.5, y[sel] / cell - 0.5))
        t = level[sel] - k
        out[sel] = (1 - t) * values[0] + t * values[1]
    return out


def _cloud_noise(rng: np.random.Generator) -> NDArray[np.float64]:
    """Tileable Gaussian noise, ``(_CELLS, _CELLS)``, mean 0, std 1, amplitude spectrum
    ``(f^2 + f0^2)^(-2/3)`` with ``f0`` the outer scale's frequency."""
    fy = np.fft.fftfreq(_CELLS)[:, None]
    fx = np.fft.rfftfreq(_CELLS)[None, :]
    f0 = (_TILE_M / _CELLS) / CLOUD_SCALE_M  # cycles per cell
    amplitude = (fx**2 + fy**2 + f0**2) ** (-2.0 / 3.0)
    amplitude[0, 0] = 0.0  # no mean
    shape = amplitude.shape
    spectrum = (rng.standard_normal(shape) + 1j * rng.standard_normal(shape)) * amplitude
    field = np.fft.irfft2(spectrum, s=(_CELLS, _CELLS))
    return (field - field.mean()) / max(field.std(), 1e-12)


def _smoothstep(t: float) -> float:
    return t * t * (3.0 - 2.0 * t)


def _cloud_field(world_seed: int, day: int, hour: float) -> tuple[NDArray[np.float64], tuple]:
    """The cloud field of the hour (std 1, tileable, ``(_CELLS, _CELLS)``) and the wind's
    drift (m) at that time: the hourly fields blend into each other, so the clouds change
    continuously over the day."""
    h = math.floor(hour)
    blend = _smoothstep(hour - h)

    def drawn(k: int) -> NDArray[np.float64]:
        rng = np.random.default_rng([int(world_seed), _STREAM, int(day), k % 24, k // 24])
        return _cloud_noise(rng)

    field = (1.0 - blend) * drawn(h) + blend * drawn(h + 1)
    # two independent fields blended lose variance in between: give it back
    field /= math.hypot(1.0 - blend, blend)
    wind = np.random.default_rng([int(world_seed), _STREAM, int(day), 99])
    speed = wind.uniform(*_WIND_M_S)
    heading = wind.uniform(0.0, 2.0 * math.pi)
    seconds = hour * 3600.0
    return field, (speed * seconds * math.cos(heading), speed * seconds * math.sin(heading))


def sky_faces(
    world_seed: int,
    day: int,
    hour: float,
    zenith: RGB,
    horizon: RGB,
    cover: float,
    overcast: float = 0.0,
    n: int = FACE_TEXELS,
) -> NDArray[np.uint8]:
    """The skybox's six faces, ``(6 n, n, 3)`` uint8, for MuJoCo's ``gridsize="6 1"
    gridlayout="RLUDFB"`` (see the module docstring).

    Args:
        world_seed: which world (another world: other clouds).
        day: which day (another day: another wind and other clouds).
        hour: time of day (h, since midnight) the sky shows.
        zenith: the clear sky's colour overhead (RGB in [0, 1]).
        horizon: the clear sky's colour at the horizon (RGB in [0, 1]).
        n: texels along a face's side.
        cover: the fraction of the sky covered by cloud on a day without ``overcast``.
        overcast: 0 (as ``cover``) .. 1: the cover closes into a thick grey deck.
    """
    if not 0.0 <= cover <= 1.0:
        raise ValueError(f"cloud cover must lie in [0, 1], got {cover!r}")
    if not 0.0 <= overcast <= 1.0:
        raise ValueError(f"overcast must lie in [0, 1], got {overcast!r}")
    d = face_directions(n)
    up = d[..., 2]
    sky = _clear_sky(up, zenith, horizon)
    # an overcast sky is grey: the blue goes with the sun
    grey = float(np.mean(horizon)) * 0.85
    sky = (1.0 - overcast) * sky + overcast * grey
    cover = cover + (1.0 - cover) * overcast
    if cover > 0.0:
        above = up > 0.02  # the layer seen from below; lower, only haze
        ud = up[above]
        reach = CLOUD_BASE_M / ud
        field, (dx, dy) = _cloud_field(world_seed, day, hour)
        x = d[..., 0][above] * reach + dx
        y = d[..., 1][above] * reach + dy
        # a texel spans about (pi / 2) / n radians; on the layer that is reach * angle
        # across the line of sight and reach * angle / elevation's sine along it
        footprint = reach * (0.5 * math.pi / n) / ud
        level = np.log2(np.maximum(footprint / (_TILE_M / _CELLS), 1.0))
        value = _filtered(_pyramid(field), x, y, level)
        # the cover's fraction of a Gaussian field lies above its (1 - cover) quantile
        threshold = -math.inf if cover >= 1.0 else NormalDist().inv_cdf(1.0 - cover)
        depth = np.clip(value - threshold, 0.0, None) * _THICK * (1.0 + 2.0 * overcast)
        opacity = 1.0 - np.exp(-depth)
        # thin cloud scatters white light, a thick base is grey (a modelled look, not a
        # radiative transfer)
        shade = 0.98 - 0.4 * (1.0 - np.exp(-depth / 3.0)) - 0.15 * overcast
        haze = np.exp(-3.912 * reach / VISIBILITY_M)
        alpha = (opacity * haze)[:, None]
        sky_above = sky[above]
        sky[above] = (1.0 - alpha) * sky_above + alpha * shade[:, None]
    return to_uint8(sky.reshape(6 * n, n, 3))


def skybox_mjcf(name: str, file: str) -> str:
    """The MJCF texture element of a skybox drawn by :func:`sky_faces` into ``file``."""
    layout = 'gridsize="6 1" gridlayout="RLUDFB"'
    return f'<texture name="{name}" type="skybox" file="{file}" {layout}/>'
