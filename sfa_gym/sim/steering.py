"""Closed-loop steering of the rover along waypoints: the one controller that the recording
drivers (:mod:`sfa_gym.recording.drivers`) and the navigation oracle
(:class:`~sfa_gym.navigation.controllers.OracleController`) drive with.

A plan is a list of :class:`Goto` (drive to a point) and :class:`Spin` (rotate on the spot)
segments; :class:`WaypointFollower` turns the latest ground-truth pose into the next action
``(v, w)`` under the limits of one :class:`Steering`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from sfa_gym._checks import check_positive
from sfa_gym.geometry import wrap_angle

__all__ = ["DEFAULT_STEERING", "Goto", "Spin", "Steering", "WaypointFollower", "action"]


def action(v: float, w: float) -> NDArray[np.float32]:
    """The action ``(v, w)`` as the rover takes it: ``(2,)`` float32, m/s and rad/s."""
    return np.array([v, w], dtype=np.float32)


@dataclass(frozen=True)
class Goto:
    """Drive to the point ``(x, y)`` (metres)."""

    x: float
    y: float


@dataclass(frozen=True)
class Spin:
    """Rotate on the spot by ``angle`` radians (counter-clockwise if positive)."""

    angle: float


@dataclass(frozen=True)
class Steering:
    """Limits and tolerances of the waypoint controller.

    With heading error ``e`` towards the next point, the rover turns on the spot while
    ``|e| > turn_in_place``, otherwise drives at ``v = speed * cos(e)`` (slowing down to a
    quarter of that in the last ``speed / 2`` metres) and steers with
    ``w = clip(2 e, -turn_rate, turn_rate)``.
    """

    speed: float = 0.4
    """cruise speed (m/s); never exceeded"""
    turn_rate: float = 1.0
    """largest turn rate (rad/s); never exceeded"""
    tolerance: float = 0.1
    """reach radius of a point (m)"""
    turn_in_place: float = 0.5
    """heading error (rad) above which the rover stops and turns"""

    def validate(self) -> Steering:
        """Raise ValueError naming the first setting that is not a positive finite number."""
        for name in ("speed", "turn_rate", "tolerance", "turn_in_place"):
            check_positive(name, getattr(self, name))
        return self


DEFAULT_STEERING = Steering()
"""The drivers' default steering (a frozen dataclass: one shared instance is safe)."""


class WaypointFollower:
    """Follows ``plan`` in closed loop, one :meth:`act` per control period ``dt`` (s).

    A point counts as reached within ``steering.tolerance`` metres, or when the rover has passed
    it (closer than three tolerances and beyond it along the segment), so that lag in the
    dynamics never makes it circle a waypoint. A segment not finished within three times its
    nominal duration plus 5 s (the rover is stuck, e.g. against an obstacle) is given up and
    counted in :attr:`skipped`, so that every drive ends.
    """

    def __init__(self, plan: Sequence[Goto | Spin], steering: Steering, dt: float) -> None:
        self.plan = list(plan)
        self.steering = steering.validate()
        self.dt = check_positive("dt", dt)
        self.index = 0
        """the segment being driven; ``len(plan)`` when done"""
        self.skipped = 0
        """segments given up"""
        self._steps = 0
        self._budget = math.inf
        self._spun = 0.0
        self._last_yaw: float | None = None
        self._origin: tuple[float, float] | None = None

    @property
    def done(self) -> bool:
        return self.index >= len(self.plan)

    def act(self, x: float, y: float, yaw: float) -> NDArray[np.float32]:
        """The next action from the pose ``(x, y, yaw)``; ``(0, 0)`` once done."""
        while self.index < len(self.plan):
            segment = self.plan[self.index]
            if self._steps == 0:
                self._budget = self._nominal_seconds(segment, x, y) * 3.0 + 5.0
            self._steps += 1
            if self._steps * self.dt > self._budget:
                self.skipped += 1
                self._advance(x, y)
                continue
            found = (
                self._spin(segment, yaw)
                if isinstance(segment, Spin)
                else self._goto(segment, x, y, yaw)
            )
            if found is not None:
                return found
            self._advance(x, y)
        return action(0.0, 0.0)

    def _advance(self, x: float, y: float) -> None:
        self.index += 1
        self._steps = 0
        self._spun = 0.0
        self._last_yaw = None
        self._origin = (x, y)

    def _nominal_seconds(self, segment: Goto | Spin, x: float, y: float) -> float:
        s = self.steering
        if isinstance(segment, Spin):
            return abs(segment.angle) / s.turn_rate
        return math.dist((x, y), (segment.x, segment.y)) / s.speed + math.pi / s.turn_rate

    def _spin(self, segment: Spin, yaw: float) -> NDArray[np.float32] | None:
        if self._last_yaw is not None:
            self._spun += wrap_angle(yaw - self._last_yaw)
        self._last_yaw = yaw
        remaining = abs(segment.angle) - math.copysign(1.0, segment.angle) * self._spun
        if remaining <= 0.05:
            return None
        rate = self.steering.turn_rate
        return action(
            0.0, math.copysign(min(rate, max(0.3 * rate, 2.0 * remaining)), segment.angle)
        )

    def _goto(self, segment: Goto, x: float, y: float, yaw: float) -> NDArray[np.float32] | None:
        s = self.steering
        dx, dy = segment.x - x, segment.y - y
        distance = math.hypot(dx, dy)
        if distance < s.tolerance:
            return None
        if self._origin is not None and distance < 3.0 * s.tolerance:
            ox, oy = self._origin
            if dx * (segment.x - ox) + dy * (segment.y - oy) < 0.0:
                return None  # passed it
        error = wrap_angle(math.atan2(dy, dx) - yaw)
        w = float(np.clip(2.0 * error, -s.turn_rate, s.turn_rate))
        if abs(error) > s.turn_in_place:
            # too slow a turn on the spot would never finish against friction
            return action(0.0, math.copysign(max(abs(w), 0.3 * s.turn_rate), error))
        v = s.speed * math.cos(error) * min(1.0, max(0.25, 2.0 * distance / s.speed))
        return action(v, w)
