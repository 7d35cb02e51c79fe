"""Ground-plane geometry: axis-aligned rectangles ``(xmin, xmax, ymin, ymax)`` (metres) and
headings (radians)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

Rectangle = tuple[float, float, float, float]
"""``(xmin, xmax, ymin, ymax)`` in metres, world frame."""

__all__ = ["Rectangle", "check_rectangle", "grow_rectangle", "in_rectangle", "wrap_angle"]


def check_rectangle(name: str, rect: Any) -> Rectangle:
    """``rect`` as four floats after checking ``xmin < xmax``, ``ymin < ymax``, all finite.

    Raises:
        ValueError: naming ``name`` and the value, e.g. ``exclude must be a rectangle ...``.
    """
    try:
        x0, x1, y0, y1 = (float(v) for v in rect)
    except (TypeError, ValueError):
        raise ValueError(
            f"{name} must be a rectangle (xmin, xmax, ymin, ymax) in metres, got {rect!r}"
        ) from None
    if not all(map(math.isfinite, (x0, x1, y0, y1))) or not (x0 < x1 and y0 < y1):
        raise ValueError(f"{name} must be finite with xmin < xmax and ymin < ymax, got {rect!r}")
    return x0, x1, y0, y1


def in_rectangle(positions: ArrayLike, rect: Sequence[float] | None) -> NDArray[np.bool_]:
    """Which ``positions (N, 2)`` (m) lie strictly inside ``rect``; all False for ``None``."""
    p = np.asarray(positions, dtype=np.float64).reshape(-1, 2)
    if rect is None:
        return np.zeros(len(p), dtype=bool)
    x0, x1, y0, y1 = rect
    return (p[:, 0] > x0) & (p[:, 0] < x1) & (p[:, 1] > y0) & (p[:, 1] < y1)


def grow_rectangle(rect: Rectangle, margin: float) -> Rectangle:
    """``rect`` enlarged by ``margin`` metres on every side."""
    x0, x1, y0, y1 = rect
    return x0 - margin, x1 + margin, y0 - margin, y1 + margin


def wrap_angle(angle: float) -> float:
    """Angle wrapped to ``[-pi, pi)`` (radians)."""
    return (angle + math.pi) % (2.0 * math.pi) - math.pi
