"""Array aliases shared across the package (shapes are in the docstrings that use them)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

Panorama = NDArray[np.uint8]
"""One panorama, ``(H, W, 3)`` uint8 RGB; column 0 looks along the heading."""

Panoramas = NDArray[np.uint8]
"""A stack of panoramas, ``(N, H, W, 3)`` uint8."""

FloatArray = NDArray[np.floating]
Pose = tuple[float, float, float]
"""Ground-plane pose ``(x, y, yaw)`` in metres and radians, MuJoCo world frame."""
