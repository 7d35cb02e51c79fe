"""Pose sets the leaderboard renders through the shared cache in worlds with obstacles.

The env's ``reset`` refuses a pose where the rover does not fit (closer to an obstacle or an
interior wall than its footprint radius), so a grid through an obstacle world cannot be recorded
as a whole. Both classes here are :class:`~sfa_gym.recording.drivers.GridPositions` to the
recorder (one ``reset`` per pose) and keep only the poses where the rover fits:

- :class:`FreeGridPositions`: the ``n x n`` training grid with its random yaws and visiting
  order, minus the cells where the rover does not fit (the order of the others is kept);
- :class:`FieldNodes`: the nodes of the feature-field grid of
  :meth:`~sfa_gym.navigation.field.FeatureField.build` (same spacing rule), facing yaw 0.

Which poses remain depends on the world (spec and seed) and on the rover, both part of the
cache key (world spec hash, world seed, env id), so a pose set's ``describe()`` only needs its
own arguments.
"""

from __future__ import annotations

import math
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

from sfa_gym.recording.drivers import GridPositions, env_attribute

__all__ = ["FieldNodes", "FreeGridPositions", "field_axes", "rover_fits"]


def rover_fits(env: Any, points: NDArray[np.float64]) -> NDArray[np.bool_]:
    """``(n,)`` whether the rover fits at each of ``points`` ``(n, 2)`` (m): the condition the
    env's ``reset`` checks (clearance from obstacles and interior walls larger than the rover's
    footprint radius).

    Raises:
        TypeError: ``env`` has no ``layout`` or ``rover`` (not an OmniRoverEnv).
    """
    layout, rover = env_attribute(env, "layout"), env_attribute(env, "rover")
    if layout is None or rover is None:
        raise TypeError(f"env must be an OmniRoverEnv (with layout and rover), got {env!r}")
    points = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    return np.asarray(layout.clearance(points) > rover.footprint_radius, dtype=bool)


def field_axes(
    bounds: tuple[float, float, float, float], spacing: float
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The node coordinates ``xs (nx,)`` and ``ys (ny,)`` (m) of a feature field over
    ``bounds = (xmin, xmax, ymin, ymax)`` at most ``spacing`` m apart, edges included: the grid
    :meth:`~sfa_gym.navigation.field.FeatureField.build` renders."""
    spacing = float(spacing)
    if not (math.isfinite(spacing) and spacing > 0):
        raise ValueError(f"spacing must be a positive number of metres, got {spacing!r}")
    axes = []
    for lo, hi in ((bounds[0], bounds[1]), (bounds[2], bounds[3])):
        # the tolerance keeps 6.0 / 0.1 = 60.00000000000001 from adding a node
        n = math.ceil((hi - lo) / spacing - 1e-9) + 1
        axes.append(np.linspace(lo, hi, n))
    return axes[0], axes[1]


class FreeGridPositions(GridPositions):
    """The grid of :class:`~sfa_gym.recording.drivers.GridPositions` (``n x n`` cell centres,
    a random yaw per cell drawn with ``seed``, visiting ``order``) without the cells where the
    rover does not fit. In a world without obstacles it is the whole grid, pose for pose."""

    def __init__(
        self,
        n: int = 30,
        *,
        seed: int = 0,
        order: Literal["raster", "serpentine", "hilbert"] = "raster",
    ) -> None:
        super().__init__(n, seed=seed, order=order)

    def describe(self) -> dict[str, Any]:
        """``{"type": "FreeGridPositions", n, seed, order}``."""
        return {**super().describe(), "type": type(self).__name__}

    def poses(self, source: Any) -> NDArray[np.float64]:
        """The free poses ``(m, 3)`` ``(x, y, yaw)`` of the grid in ``source`` (an env), in
        visiting order."""
        poses = super().poses(source)
        return poses[rover_fits(source, poses[:, :2])]


class FieldNodes(GridPositions):
    """The nodes of a feature field at ``spacing`` m (see :func:`field_axes`) where the rover
    fits, in the field's order (x fastest), each facing yaw 0.

    Args:
        spacing: largest node spacing, m (> 0).
    """

    def __init__(self, spacing: float) -> None:
        super().__init__(1)
        if isinstance(spacing, bool) or not isinstance(spacing, int | float):
            raise TypeError(f"spacing must be a number of metres, got {spacing!r}")
        if not (math.isfinite(spacing) and spacing > 0):
            raise ValueError(f"spacing must be a positive number of metres, got {spacing!r}")
        self.spacing = float(spacing)

    def describe(self) -> dict[str, Any]:
        """``{"type": "FieldNodes", "spacing": metres, "yaw": 0.0}``."""
        return {"type": type(self).__name__, "spacing": self.spacing, "yaw": 0.0}

    def nodes(self, source: Any) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
        """All nodes ``(ny * nx, 2)`` of the grid over ``source.arena_bounds`` (x fastest) and
        ``(ny * nx,)`` whether the rover fits at each."""
        bounds = env_attribute(source, "arena_bounds")
        if bounds is None:
            raise TypeError(f"source must be an OmniRoverEnv, got {source!r}")
        xs, ys = field_axes(tuple(float(b) for b in bounds), self.spacing)
        gx, gy = np.meshgrid(xs, ys)
        nodes = np.stack([gx.ravel(), gy.ravel()], axis=1)
        return nodes, rover_fits(source, nodes)

    def poses(self, source: Any) -> NDArray[np.float64]:
        """The poses ``(m, 3)`` ``(x, y, 0.0)`` of the nodes where the rover fits."""
        nodes, fits = self.nodes(source)
        return np.column_stack([nodes[fits], np.zeros(int(fits.sum()))])
