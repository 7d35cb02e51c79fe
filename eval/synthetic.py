"""Synthetic panoramas for testing and timing the SFA engine without rendering.

Two kinds, both seeded and periodic in width like the env's panoramas:

- :func:`synthetic_panoramas`: smooth random images morphing along a path (no geometry; cheap,
  for timing and for the engine's invariants);
- :func:`landmark_panoramas`: coloured blocks standing around an arena, seen from given poses
  (:func:`smooth_path` makes poses along an open path), so that the views change with the
  position as a camera's do and rotate with its heading.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray
from scipy.ndimage import gaussian_filter
from tqdm.auto import tqdm

__all__ = ["landmark_panoramas", "smooth_path", "synthetic_panoramas"]


def synthetic_panoramas(
    n_locations: int, height: int, width: int, seed: int = 0, n_keyframes: int = 64
) -> NDArray[np.uint8]:
    """``(n_locations, height, width, 3)`` uint8 panoramas morphing smoothly along a path.

    ``n_keyframes`` random smooth images (Gaussian-filtered noise, periodic in width) are placed
    evenly along the path; each location blends its two neighbouring keyframes linearly.
    """
    rng = np.random.default_rng(seed)
    n_key = max(2, min(n_keyframes, n_locations))
    keys = np.empty((n_key, height, width, 3), dtype=np.float32)
    for i in range(n_key):
        z = gaussian_filter(
            rng.standard_normal((height, width, 3)), (height / 20, width / 60, 0), mode="wrap"
        )
        keys[i] = z / z.std() * 45.0 + 128.0
    out = np.empty((n_locations, height, width, 3), dtype=np.uint8)
    pos = np.linspace(0, n_key - 1, n_locations)
    for i, p in enumerate(pos):
        k0 = min(int(p), n_key - 2)
        frac = np.float32(p - k0)
        out[i] = np.clip((1 - frac) * keys[k0] + frac * keys[k0 + 1], 0, 255)
    return out


def smooth_path(
    n: int,
    seed: int,
    half_size: float = 1.0,
    *,
    frequencies: Sequence[float] = (1, 2, 3, 5, 8),
    amplitude: float = 0.45,
    limit: float = 1.0,
    turn_noise: float = 0.02,
) -> NDArray[np.float64]:
    """``(n, 3)`` poses ``(x, y, yaw)`` along an open, smooth path, in metres and radians.

    The position is a sum of sinusoids, one per frequency ``f`` (cycles over the path / 1.3)
    with a random amplitude of standard deviation ``amplitude / f`` and a random phase,
    clipped to ``[-limit, limit]`` and scaled by ``half_size``; the heading turns by half a turn
    over the path plus a random walk of steps with standard deviation ``turn_noise``, so views
    change smoothly from pose to pose.
    """
    rng = np.random.default_rng(seed)
    s = np.linspace(0.0, 1.0, n)[:, None]
    xy = np.zeros((n, 2))
    for f in frequencies:
        xy += rng.normal(0, amplitude / f, 2) * np.sin(
            1.3 * np.pi * f * s + rng.uniform(0, 2 * np.pi, 2)
        )
    xy = np.clip(xy, -limit, limit) * half_size
    yaw = np.pi * s[:, 0] + np.cumsum(rng.normal(0, turn_noise, n))
    return np.c_[xy, yaw]


def landmark_panoramas(
    poses: NDArray[np.floating],
    height: int,
    width: int,
    seed: int = 0,
    n_landmarks: int = 24,
    progress: bool = False,
) -> NDArray[np.uint8]:
    """Seeded synthetic panoramas ``(N, height, width, 3)`` uint8 at ``poses`` ``(N, 3)``.

    ``n_landmarks`` blocks of random colour, width (0.15-0.6 m) and height (0.2-1.5 m) stand
    1.8-4 m from the origin; the camera is 0.5 m above the ground with a 40 degree vertical
    field of view. A block covers the columns within its angular half-width and the rows
    between the ground and its top (soft edges, colours added) over a sky/ground gradient.
    Gaussian pixel noise (sd 2, seeded) keeps patch covariances full rank. Column ``c`` looks
    at azimuth ``yaw + 2*pi*c/width`` (periodic in width, as the env's panoramas).
    """
    poses = np.asarray(poses, dtype=np.float64)
    rng = np.random.default_rng(seed)
    ang, rad = rng.uniform(0, 2 * np.pi, n_landmarks), rng.uniform(1.8, 4.0, n_landmarks)
    xy = np.c_[rad * np.cos(ang), rad * np.sin(ang)]
    half = rng.uniform(0.15, 0.6, n_landmarks)
    top = rng.uniform(0.2, 1.5, n_landmarks)
    colour = rng.uniform(-120, 120, (n_landmarks, 3)).astype(np.float32)
    elev = np.deg2rad(np.linspace(20.0, -20.0, height))
    g = np.clip(elev / np.deg2rad(20.0), -1, 1)[:, None]
    background = np.where(g >= 0, [140.0, 170.0, 210.0] + 40 * g, [110.0, 100.0, 80.0] + 40 * g)
    soft_az, soft_el = 2 * np.pi / width, np.deg2rad(40.0) / height
    noise = np.random.default_rng(seed + 1)
    out = np.empty((len(poses), height, width, 3), dtype=np.uint8)
    batch = max(1, 2_000_000 // (height * width))
    for i0 in tqdm(range(0, len(poses), batch), desc="panoramas", disable=not progress):
        p = poses[i0 : i0 + batch]
        img = np.empty((len(p), height, width, 3), dtype=np.float32)
        img[:] = background[None, :, None, :]
        theta = p[:, 2:3] + 2 * np.pi * np.arange(width) / width
        for k in range(n_landmarks):
            d = xy[k] - p[:, :2]
            dist = np.hypot(d[:, 0], d[:, 1])[:, None]
            off = np.angle(np.exp(1j * (theta - np.arctan2(d[:, 1], d[:, 0])[:, None])))
            a_az = 1 / (1 + np.exp((np.abs(off) - np.arctan(half[k] / dist)) / soft_az))
            e_top, e_bot = np.arctan((top[k] - 0.5) / dist), np.arctan(-0.5 / dist)
            a_el = 1 / (
                (1 + np.exp((elev - e_top) / soft_el)) * (1 + np.exp((e_bot - elev) / soft_el))
            )
            alpha = a_el.astype(np.float32)[:, :, None] * a_az.astype(np.float32)[:, None, :]
            img += alpha[..., None] * colour[k]
        img += noise.normal(0, 2.0, img.shape).astype(np.float32)
        out[i0 : i0 + len(p)] = np.clip(np.rint(img), 0, 255)
    return out
