"""Procedural surface textures for the outdoor world: images of physical surfaces, from numpy.

Flat-shaded surfaces put almost no energy at fine scales, so panoramas of a flat world have an
amplitude spectrum that falls much faster than a photograph's (``1/f^alpha`` with ``alpha``
near 1.5 instead of about 1; :mod:`sfa_gym.image_statistics`). Real surfaces have structure at
every scale, and each generator here models where a surface's comes from:

* **asphalt**: stones of the aggregate (a few mm: texel-sized grain, a few light ones), wear
  and patching (brightness that varies as ``1/f``) and cracks (random walks that turn a
  little at every step and sometimes branch);
* **grass**: blades and the gaps between them (fine dark and light grain), drier and lusher
  patches (``1/f`` variation of hue and brightness) and a few bare patches of soil;
* **paving**: concrete slabs of 0.4 m with joints, each slab a little lighter or darker than
  its neighbours, stained by the same ``1/f`` wear as asphalt;
* **concrete** (curbs): fine grain and ``1/f`` stains;
* **facade**: one window bay of a storey, brick (German normal format, 0.24 x 0.071 m plus
  1 cm joints, in running bond, each brick's colour jittered) or plaster (render with ``1/f``
  blotches and dirt streaks under the sill), around a framed window whose glass reflects a
  brighter sky at the top;
* **bark**: vertical furrows (noise stretched along the trunk);
* **foliage** and **bush**: clumps of lit leaves over the dark inside of the crown. Holes
  would need a texture's alpha channel, and MuJoCo loads the cube textures that map onto
  round crowns with three channels only ("cube and skybox textures loaded from files must have
  3 channels"), so the gaps between clumps are dark, as the shaded inside of a crown looks from
  outside.

All noise is synthesised in the Fourier domain, so every texture tiles seamlessly. A texture
is a pure function of its generator's arguments and a ``numpy`` generator: the world seed
fixes every byte (see :mod:`sfa_gym.sim.worlds.texturing`, which puts them into the MJCF).
"""

from __future__ import annotations

import colorsys
import struct
import zlib
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from sfa_gym._checks import check_int_in, is_number

RGB = tuple[float, float, float]

__all__ = ["GENERATORS", "TexturesSpec", "png_bytes", "to_uint8"]


@dataclass(frozen=True)
class TexturesSpec:
    """Generated textures of an outdoor world (a world spec's ``textures`` block).

    Attributes:
        resolution: texels per side of the ground and facade textures (a power of two, so that
            every mip level halves evenly); foliage and bark use half of it.
        tile_m: metres covered by one tile of the ground textures (asphalt, grass, paving).
        cracks: cracks per asphalt tile.
        canopy_gaps: the fraction of a tree crown's surface where the dark inside shows
            between the leaf clumps (bushes: half of it).
    """

    resolution: int = 256
    tile_m: float = 2.0
    cracks: int = 4
    canopy_gaps: float = 0.3

    def __post_init__(self) -> None:
        r = self.resolution
        if isinstance(r, bool) or not isinstance(r, int) or not 32 <= r <= 2048 or r & (r - 1):
            raise ValueError(
                f"textures resolution must be a power of two in [32, 2048] texels, got {r!r}"
            )
        if not (is_number(self.tile_m) and 0.4 <= self.tile_m <= 20.0):
            raise ValueError(
                f"textures tile_m must lie in [0.4, 20] metres (one paving slab to a few "
                f"metres of ground), got {self.tile_m!r}"
            )
        check_int_in("textures cracks", self.cracks, 0)
        if not (is_number(self.canopy_gaps) and 0.0 <= self.canopy_gaps <= 0.9):
            raise ValueError(f"textures canopy_gaps must lie in [0, 0.9], got {self.canopy_gaps!r}")


def png_bytes(image: NDArray[np.uint8]) -> bytes:
    """An ``(h, w, 3)`` uint8 image as PNG bytes (fixed compression: same image, same bytes)."""
    if image.dtype != np.uint8 or image.ndim != 3 or image.shape[2] != 3:
        raise ValueError(f"image must be (h, w, 3) uint8, got {image.shape} {image.dtype}")
    h, w, _ = image.shape
    rows = np.concatenate([np.zeros((h, 1), np.uint8), image.reshape(h, 3 * w)], axis=1)

    def chunk(kind: bytes, data: bytes) -> bytes:
        crc = zlib.crc32(kind + data) & 0xFFFFFFFF
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", crc)

    header = struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0)  # 8-bit RGB, no interlace
    return (
        b"\x89PNG\r\n\x1a\n"
        + chunk(b"IHDR", header)
        + chunk(b"IDAT", zlib.compress(rows.tobytes(), 1))
        + chunk(b"IEND", b"")
    )


def to_uint8(rgb: NDArray[np.float64]) -> NDArray[np.uint8]:
    return np.round(np.clip(rgb, 0.0, 1.0) * 255.0).astype(np.uint8)


def noise(
    rng: np.random.Generator, n: int, exponent: float = 1.0, stretch: float = 1.0
) -> NDArray[np.float64]:
    """``(n, n)`` tileable noise with an amplitude spectrum ``1/f^exponent``, mean 0, std 1.

    ``stretch > 1`` elongates the structures along the rows' axis (axis 0) by that factor.
    """
    fy = np.fft.fftfreq(n)[:, None] * stretch
    fx = np.fft.rfftfreq(n)[None, :]
    f = np.hypot(fx, fy)
    f[0, 0] = np.inf  # no mean
    shape = f.shape
    spectrum = (rng.standard_normal(shape) + 1j * rng.standard_normal(shape)) / f**exponent
    field = np.fft.irfft2(spectrum, s=(n, n))
    return (field - field.mean()) / max(field.std(), 1e-12)


def _grain(rng: np.random.Generator, n: int) -> NDArray[np.float64]:
    """Texel-sized white grain, std 1."""
    return rng.standard_normal((n, n))


def _hsv_shift(rgb: RGB, dh: float = 0.0, ds: float = 0.0, dv: float = 0.0) -> RGB:
    h, s, v = colorsys.rgb_to_hsv(*rgb)
    s, v = min(1.0, max(0.0, s + ds)), min(1.0, max(0.0, v + dv))
    return colorsys.hsv_to_rgb((h + dh) % 1.0, s, v)


def _paint(base: RGB, light: NDArray[np.float64]) -> NDArray[np.float64]:
    """``base`` times the brightness field ``light`` scaled to mean 1, ``(n, n, 3)``: the
    surface keeps the mean colour of the flat world's material."""
    return (light / light.mean())[..., None] * np.asarray(base)


def _cracks(rng: np.random.Generator, n: int, count: int) -> NDArray[np.bool_]:
    """Texels on ``count`` cracks: random walks of 0.2-0.6 tile lengths that turn by a few
    degrees per texel and branch now and then; they wrap round the tile's edges."""
    mask = np.zeros((n, n), bool)
    walks = [
        (rng.uniform(0, n), rng.uniform(0, n), rng.uniform(0, 2 * np.pi), rng.uniform(0.2, 0.6) * n)
        for _ in range(count)
    ]
    while walks:
        y, x, heading, length = walks.pop()
        for _ in range(int(length)):
            mask[int(y) % n, int(x) % n] = True
            heading += rng.normal(0.0, 0.25)
            y, x = y + np.sin(heading), x + np.cos(heading)
            if rng.random() < 0.01 and length > 0.1 * n:
                walks.append((y, x, heading + rng.choice((-1, 1)) * 0.8, length / 3))
    return mask


def asphalt(rng: np.random.Generator, n: int, base: RGB, cracks: int) -> NDArray[np.float64]:
    """Worn asphalt: grey stones of the aggregate (a quarter of the surface, each 1.3-2.2 times
    as bright as the black binder), ``1/f`` wear and patches, dark cracks."""
    stones = rng.random((n, n)) < 0.25
    light = np.where(stones, rng.uniform(1.3, 2.2, (n, n)), 1.0)
    light *= np.exp(0.2 * noise(rng, n))
    light[_cracks(rng, n, cracks)] *= 0.3
    return _paint(base, light)


def grass(rng: np.random.Generator, n: int, base: RGB) -> NDArray[np.float64]:
    """Blades (lit tips against dark gaps, a little longer along one axis: mown rows), lusher
    and drier patches, a few bare patches of soil."""
    lush, dry = _hsv_shift(base, 0.02, 0.1, -0.05), _hsv_shift(base, -0.06, -0.1, 0.12)
    mix = np.clip(0.5 + 0.35 * noise(rng, n), 0.0, 1.0)[..., None]
    colour = mix * np.asarray(lush) + (1 - mix) * np.asarray(dry)
    light = np.exp(0.35 * noise(rng, n, 0.3, 2.0) + 0.3 * _grain(rng, n) + 0.2 * noise(rng, n))
    soil = noise(rng, n, 1.5) > 2.2
    colour[soil] = (0.36, 0.28, 0.2)
    return colour * (light / light.mean())[..., None]


def paving(rng: np.random.Generator, n: int, base: RGB, tile_m: float) -> NDArray[np.float64]:
    """Concrete slabs of 0.4 m, each a little lighter or darker, with dark joints."""
    slabs = max(1, round(tile_m / 0.4))
    edge = np.floor(np.arange(n) * slabs / n).astype(int)
    which = edge[:, None] * slabs + edge[None, :]
    light = 1.0 + rng.normal(0.0, 0.08, slabs * slabs)[which]
    light *= np.exp(0.12 * noise(rng, n) + 0.1 * _grain(rng, n))
    joint = np.diff(edge, prepend=edge[-1] - slabs) != 0  # first texel of each slab
    light[joint, :] *= 0.45
    light[:, joint] *= 0.45
    return _paint(base, light)


def concrete(rng: np.random.Generator, n: int, base: RGB) -> NDArray[np.float64]:
    return _paint(base, np.exp(0.1 * noise(rng, n) + 0.1 * _grain(rng, n)))


_WINDOW = (1.3, 0.9, 2.1)  # a window's width, its sill and its top above the floor (m)
_COURSE, _BRICK, _JOINT = 0.0833, 0.25, 0.01  # brick course height, brick pitch, joint (m)


def facade(
    rng: np.random.Generator,
    n: int,
    wall: RGB,
    glass: RGB,
    bays: tuple[int, int],
    bay_m: tuple[float, float],
    brick: bool,
) -> NDArray[np.float64]:
    """One face of a building, ``bays = (columns, storeys)`` window bays of ``bay_m = (width,
    height)`` metres (row 0 is the top): brick or plaster around framed windows, each window
    with its own reflection and blind, over a concrete plinth and under a coping."""
    columns, storeys = bays
    width, height = bay_m
    y = (np.arange(n)[:, None] + 0.5) / n * storeys  # storeys from the top
    x = (np.arange(n)[None, :] + 0.5) / n * columns  # bays from the left
    bx, by = np.broadcast_to(x, (n, n)), np.broadcast_to(y, (n, n))
    col, row = bx.astype(int), by.astype(int)
    u, v = (bx % 1.0 - 0.5) * width, (1.0 - by % 1.0) * height  # m from the bay's axis, floor
    if brick and n / (storeys * height / _COURSE) >= 3:  # courses resolved: draw the bond
        course = np.floor(v / _COURSE).astype(int) + row * 1000
        shift = 0.5 * (course % 2)
        brick_id = np.floor(bx * width / _BRICK + shift).astype(int)
        jitter = np.random.default_rng(rng.integers(2**32)).normal(size=(2, 4096))
        key = (course * 7919 + brick_id) % 4096
        light = 1.0 + 0.12 * jitter[0][key]
        joint = ((v % _COURSE) < _JOINT) | (((bx * width / _BRICK + shift) % 1.0) < _JOINT / _BRICK)
        light[joint] = 1.25
    elif brick:  # courses smaller than the texels: their jitter as grain
        light = 1.0 + 0.12 * _grain(rng, n)
    else:
        light = np.exp(0.1 * noise(rng, n) + 0.05 * _grain(rng, n))
        light[(v < 0.05) | (v > height - 0.05)] *= 1.15  # a band at every floor
    light *= np.exp(0.08 * noise(rng, n))  # weathering
    colour = _paint(wall, light)
    half, sill, top = _WINDOW[0] / 2, _WINDOW[1], _WINDOW[2]
    in_window = (np.abs(u) < half) & (v > sill) & (v < top)
    if not brick:  # rain washes dirt off the sills onto the render below them
        below = (np.abs(u) < half) & (v < sill)
        colour[below] *= (1.0 - 0.15 * np.exp(-(sill - v[below]) / 0.5))[:, None]
    frame_rgb = (0.85, 0.85, 0.82) if rng.random() < 0.6 else (0.22, 0.2, 0.19)
    colour[in_window] = frame_rgb
    f = 0.07
    pane = in_window & (np.abs(u) < half - f) & (v > sill + f) & (v < top - f) & (np.abs(u) > f / 2)
    # per window: how bright the sky it reflects, how far its blind is down
    reflect = rng.uniform(0.6, 1.5, (storeys, columns))[row, col]
    blind = np.where(
        rng.random((storeys, columns)) < 0.4, rng.uniform(0.1, 0.8, (storeys, columns)), 0.0
    )
    sky = reflect * (0.6 + 0.8 * (v - sill) / (top - sill)) * np.exp(0.2 * noise(rng, n))
    glass_rgb = _paint(glass, sky) * sky.mean()
    down = top - (top - sill) * blind[row, col]
    glass_rgb[v > down] = (0.75, 0.72, 0.66)
    colour[pane] = glass_rgb[pane]
    colour[(v < sill) & (v > sill - 0.06) & (np.abs(u) < half + 0.05)] = 0.8  # the sill
    ground = row == storeys - 1
    # rain splashes dirt onto the lowest metre; a concrete plinth; a coping along the roof
    colour[ground & (v < 1.0)] *= (0.88 + 0.12 * v[ground & (v < 1.0)])[:, None]
    plinth = ground & (v < 0.4)
    colour[plinth] = _paint((0.5, 0.49, 0.47), np.exp(0.1 * noise(rng, n)))[plinth]
    colour[(row == 0) & (v > height - 0.2)] = (0.78, 0.77, 0.74)
    return colour


def bark(rng: np.random.Generator, n: int, base: RGB) -> NDArray[np.float64]:
    """Vertical furrows: noise stretched along the trunk."""
    return _paint(base, np.exp(0.4 * noise(rng, n, 1.0, 6.0) + 0.1 * _grain(rng, n)))


def _domes(rng: np.random.Generator, n: int, count: int) -> NDArray[np.float64]:
    """Shading of ``count`` round clumps that tile the texture (the cells of random centres,
    distances wrapped round its edges): 1 at a clump's centre, falling to 0 where it meets its
    neighbours (the shaded creases between them)."""
    centres = rng.uniform(0, n, (count, 2)).astype(np.float32)
    grid = np.arange(n, dtype=np.float32)
    dy = grid[:, None, None] - centres[None, None, :, 0]
    dx = grid[None, :, None] - centres[None, None, :, 1]
    dy -= n * np.round(dy / n)
    dx -= n * np.round(dx / n)
    distance = np.sqrt(dy * dy + dx * dx)
    nearest = np.partition(distance, 1, axis=2)[..., :2]
    # the crease lies where the two nearest centres are equally far
    return np.clip((nearest[..., 1] - nearest[..., 0]) / (nearest[..., 1] + 1e-6), 0.0, 1.0)


def foliage(rng: np.random.Generator, n: int, base: RGB, gaps: float) -> NDArray[np.float64]:
    """Leaf clumps over the dark inside of a crown: round clumps of leaves (about 12 texels
    apart) lit at their middles and shaded where they meet, larger groups of them lit and
    shaded (by a factor of up to about two, as between sunlit and shaded leaves), single
    leaves jittered in brightness and the clumps in hue; where the larger groups part, the
    crown's dark inside (a quarter of the leaves' brightness) shows."""
    groups = noise(rng, n, 1.0)
    threshold = np.quantile(groups, gaps) if gaps > 0 else -np.inf
    hue = noise(rng, n, 0.5)
    colour = np.empty((n, n, 3))
    for k, (dh, ds, dv) in enumerate(((0.03, 0.05, -0.05), (-0.03, -0.05, 0.08))):
        part = (hue > 0) == (k == 0)
        colour[part] = np.asarray(_hsv_shift(base, dh, ds, dv))
    domes = _domes(rng, n, max(4, (n // 12) ** 2))
    light = (0.35 + 0.65 * np.sqrt(domes)) * np.exp(0.25 * _grain(rng, n) + 0.35 * np.tanh(groups))
    light[groups < threshold] *= 0.25  # the shaded inside of the crown
    return colour * (light / light.mean())[..., None]


GENERATORS = ("asphalt", "grass", "paving", "concrete", "facade", "bark", "foliage", "bush")
"""The surfaces this module draws, as :mod:`~sfa_gym.sim.worlds.texturing` names them."""
