"""Wheel odometry: the rover's own estimate of how it moved, from its wheel encoders.

A controller may use it (a real rover has it); it never sees the ground truth. The estimate
integrates the turned wheel angles with the skid-steer model the drive uses
(:meth:`sfa_gym.sim.rover.RoverSpec.wheel_speeds`): ``ds = r (dl + dr) / 2`` and
``dyaw = r (dr - dl) / b`` with the effective track ``b``. The wheels really slip (turning a
skid-steer vehicle drags them sideways; they spin when the rover pushes against a wall), so the
estimate drifts from the truth the way a real rover's does.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["WheelOdometry"]


class WheelOdometry:
    """Dead reckoning from the four wheel angles (front-left, rear-left, front-right, rear-right).

    The pose starts at ``(0, 0, 0)`` at :meth:`reset`: the odometry frame is the rover's start
    pose, not the world frame.

    Args:
        wheel_radius: wheel radius ``r`` (m).
        effective_track: track of the equivalent differential drive ``b`` (m).
    """

    def __init__(self, wheel_radius: float, effective_track: float) -> None:
        if not (wheel_radius > 0 and effective_track > 0):
            raise ValueError(
                f"wheel_radius and effective_track must be positive, got {wheel_radius!r} "
                f"and {effective_track!r}"
            )
        self.wheel_radius = float(wheel_radius)
        self.effective_track = float(effective_track)
        self.pose = np.zeros(3)
        self._angles = np.zeros(4)

    def reset(self, wheel_angles: ArrayLike) -> NDArray[np.float64]:
        """Start at ``(0, 0, 0)`` with the encoders at ``wheel_angles (4,)`` (rad)."""
        self._angles = self._check(wheel_angles)
        self.pose = np.zeros(3)
        return self.pose.copy()

    def update(self, wheel_angles: ArrayLike) -> NDArray[np.float64]:
        """Advance by the wheel turns since the last call; returns ``(x, y, yaw)`` (m, m, rad)."""
        angles = self._check(wheel_angles)
        # plain floats: this runs every env step, where numpy's per-call cost on four numbers
        # would dominate
        fl, rl, fr, rr = angles.tolist()
        pfl, prl, pfr, prr = self._angles.tolist()
        self._angles = angles
        left = (fl - pfl + rl - prl) * self.wheel_radius / 2
        right = (fr - pfr + rr - prr) * self.wheel_radius / 2
        distance = (left + right) / 2
        dyaw = (right - left) / self.effective_track
        x, y, yaw = self.pose.tolist()
        # integrate along the arc's mid heading: exact for a constant-curvature step to 2nd order
        mid = yaw + dyaw / 2
        yaw = math.remainder(yaw + dyaw, math.tau)
        self.pose = np.array([x + distance * math.cos(mid), y + distance * math.sin(mid), yaw])
        return self.pose.copy()

    @staticmethod
    def _check(wheel_angles: ArrayLike) -> NDArray[np.float64]:
        angles = np.asarray(wheel_angles, dtype=np.float64)
        if angles.shape != (4,) or not math.isfinite(angles.sum()):
            raise ValueError(f"wheel_angles must be 4 finite angles (rad), got {angles!r}")
        return angles
