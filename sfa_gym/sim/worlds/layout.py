"""Where things stand in a generated world: the drivable area, the obstacles, the interior walls
and blocks the rover must keep clear of, and the landmarks around (:class:`WorldLayout`)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["WorldLayout"]


@dataclass(frozen=True)
class WorldLayout:
    """Where things are in one generated world (metres, world frame).

    Attributes:
        bounds: drivable area ``(xmin, xmax, ymin, ymax)``.
        obstacles: ``(x, y, radius)`` of each obstacle's bounding circle inside the arena.
        landmarks: ``(kind, x, y, height)`` of each landmark outside the walls.
        walls: ``(x0, y0, x1, y1, half_thickness)`` of each interior wall: its centre line and
            half its thickness. The set of points within ``half_thickness`` of the centre line
            (a capsule) contains the wall's box.
        blocks: ``(xmin, xmax, ymin, ymax)`` of each building block standing inside the arena
            (an axis-aligned box the rover collides with).
    """

    bounds: tuple[float, float, float, float]
    obstacles: tuple[tuple[float, float, float], ...]
    landmarks: tuple[tuple[str, float, float, float], ...]
    walls: tuple[tuple[float, float, float, float, float], ...] = ()
    blocks: tuple[tuple[float, float, float, float], ...] = ()

    def __post_init__(self) -> None:
        for i, wall in enumerate(self.walls):
            if len(wall) != 5 or not all(math.isfinite(v) for v in wall):
                raise ValueError(
                    f"layout walls[{i}] must be 5 finite numbers (x0, y0, x1, y1, "
                    f"half_thickness), got {wall!r}"
                )
            if not wall[4] > 0:
                raise ValueError(f"layout walls[{i}] half_thickness must be positive, got {wall!r}")
        for i, obstacle in enumerate(self.obstacles):
            if len(obstacle) != 3 or not obstacle[2] >= 0:
                raise ValueError(
                    f"layout obstacles[{i}] must be (x, y, radius) with radius >= 0, "
                    f"got {obstacle!r}"
                )
        for i, block in enumerate(self.blocks):
            if len(block) != 4 or not all(math.isfinite(v) for v in block):
                raise ValueError(
                    f"layout blocks[{i}] must be 4 finite numbers (xmin, xmax, ymin, ymax), "
                    f"got {block!r}"
                )
            if not (block[0] < block[1] and block[2] < block[3]):
                raise ValueError(
                    f"layout blocks[{i}] must have xmin < xmax and ymin < ymax, got {block!r}"
                )

    def clearance(self, points: ArrayLike) -> NDArray[np.float64]:
        """Distance (m) from each point to the nearest obstacle, interior wall or block surface.

        Obstacles count as their bounding circles, walls as capsules around their centre lines
        (see :attr:`walls`), blocks as their boxes; negative inside one. The arena's bounds do
        not count.

        Args:
            points: ``(n, 2)`` positions ``(x, y)`` in metres, world frame.

        Returns:
            ``(n,)`` distances; ``inf`` where the world has no obstacles, walls or blocks.
        """
        p = np.asarray(points, dtype=np.float64)
        if p.ndim != 2 or p.shape[1] != 2:
            raise ValueError(f"points must have shape (n, 2), got {p.shape}")
        out = np.full(len(p), np.inf)
        if self.obstacles:
            c = np.asarray(self.obstacles, dtype=np.float64)
            d = np.hypot(p[:, None, 0] - c[:, 0], p[:, None, 1] - c[:, 1]) - c[:, 2]
            out = np.minimum(out, d.min(axis=1))
        if self.walls:
            w = np.asarray(self.walls, dtype=np.float64)
            a, ab = w[:, 0:2], w[:, 2:4] - w[:, 0:2]
            ap = p[:, None, :] - a  # (n, k, 2)
            length2 = np.maximum((ab**2).sum(axis=1), 1e-300)
            t = np.clip((ap * ab).sum(axis=2) / length2, 0.0, 1.0)
            d = np.linalg.norm(ap - t[..., None] * ab, axis=2) - w[:, 4]
            out = np.minimum(out, d.min(axis=1))
        if self.blocks:
            b = np.asarray(self.blocks, dtype=np.float64)
            # per axis: how far outside the box (0 inside), and how deep inside (< 0 outside)
            dx = np.maximum(b[:, 0] - p[:, None, 0], p[:, None, 0] - b[:, 1])
            dy = np.maximum(b[:, 2] - p[:, None, 1], p[:, None, 1] - b[:, 3])
            outside = np.hypot(np.maximum(dx, 0.0), np.maximum(dy, 0.0))
            d = np.where((dx < 0) & (dy < 0), np.maximum(dx, dy), outside)
            out = np.minimum(out, d.min(axis=1))
        return out
