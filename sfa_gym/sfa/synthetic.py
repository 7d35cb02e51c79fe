"""Synthetic panoramas for testing and timing the SFA engine without rendering."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.ndimage import gaussian_filter

__all__ = ["synthetic_panoramas"]


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
