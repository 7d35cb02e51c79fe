"""Pose sets the navigation protocol renders (through a render cache) in worlds with obstacles.

The env's ``reset`` refuses a pose where the rover does not fit
(:meth:`~sfa_gym.sim.env.OmniRoverEnv.rover_fits`: closer to an obstacle or an interior wall
than its footprint radius), so a grid through an obstacle world cannot be recorded
as a whole. Both classes here are :class:`~sfa_gym.recording.drivers.GridPositions` to the
recorder (one ``reset`` per pose) and keep only the poses where the rover fits:

- :class:`FreeGridPositions`: the ``n x n`` training grid with its random yaws (or one yaw) and
  visiting order, minus the cells where the rover does not fit (the order of the others is
  kept);
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

__all__ = ["FieldNodes", "FreeGridPositions", "field_axes"]


def _rover_fits(source: Any, points: NDArray[np.float64]) -> NDArray[np.bool_]:
    """``source``'s (an env, possibly wrapped) :meth:`~sfa_gym.sim.env.OmniRoverEnv.rover_fits`
    of ``points (n, 2)``."""
    fits = env_attribute(source, "rover_fits")
    if fits is None:
        raise TypeError(f"source must be an OmniRoverEnv (with rover_fits), got {source!r}")
    return fits(points)


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
    rover does not fit. In a world without obstacles it is the whole grid, pose for pose.

    Args:
        yaw: one heading (rad) for every pose instead of the random ones (None: random).
        hilbert_axes: with ``order="hilbert"``, the grid axes the curve's coordinates follow:
            ``"yx"`` (row, column: :class:`GridPositions`'s) or ``"xy"`` (the same curve
            mirrored across the diagonal; ``sfa-gym navigate`` has always visited its
            training grid so).
    """

    def __init__(
        self,
        n: int = 30,
        *,
        seed: int = 0,
        order: Literal["raster", "serpentine", "hilbert"] = "raster",
        yaw: float | None = None,
        hilbert_axes: Literal["yx", "xy"] = "yx",
    ) -> None:
        super().__init__(n, seed=seed, order=order)
        if yaw is not None and not (isinstance(yaw, int | float) and math.isfinite(yaw)):
            raise ValueError(f"yaw must be None or a finite number of radians, got {yaw!r}")
        if hilbert_axes not in ("yx", "xy"):
            raise ValueError(f"hilbert_axes must be 'yx' or 'xy', got {hilbert_axes!r}")
        self.yaw = None if yaw is None else float(yaw)
        self.hilbert_axes = hilbert_axes

    def describe(self) -> dict[str, Any]:
        """``{"type": "FreeGridPositions", n, seed, order}``, with ``yaw`` and
        ``hilbert_axes`` when they are not the defaults."""
        out = {**super().describe(), "type": type(self).__name__}
        if self.yaw is not None:
            out["yaw"] = self.yaw
        if self.hilbert_axes != "yx":
            out["hilbert_axes"] = self.hilbert_axes
        return out

    def poses(self, source: Any) -> NDArray[np.float64]:
        """The free poses ``(m, 3)`` ``(x, y, yaw)`` of the grid in ``source`` (an env), in
        visiting order."""
        from sfa_gym.recording.ordering import grid_order

        poses = super().poses(source)
        if self.order == "hilbert" and self.hilbert_axes == "xy":
            ranks = [np.unique(poses[:, a], return_inverse=True)[1] for a in (0, 1)]
            poses = poses[grid_order(np.stack(ranks, axis=1).astype(np.int64), "hilbert")]
        if self.yaw is not None:
            poses[:, 2] = self.yaw
        return poses[_rover_fits(source, poses[:, :2])]


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
        return nodes, _rover_fits(source, nodes)

    def poses(self, source: Any) -> NDArray[np.float64]:
        """The poses ``(m, 3)`` ``(x, y, 0.0)`` of the nodes where the rover fits."""
        nodes, fits = self.nodes(source)
        return np.column_stack([nodes[fits], np.zeros(int(fits.sum()))])
