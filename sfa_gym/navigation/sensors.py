"""What a navigation controller plug-in knows of the rover and what it is allowed to see.

A controller plug-in (:mod:`sfa_gym.plugins`) is made for a :class:`Rover` (speed limits, control
period, range-sensor directions) and drives it through :class:`SensorsOnly`, which hands it an
``info`` that holds only :data:`ROVER_SENSORS`: a controller that reads the ground-truth pose
fails with a ``KeyError`` instead of scoring with it.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

if TYPE_CHECKING:
    from sfa_gym.navigation.controllers import Controller

__all__ = ["ROVER_SENSORS", "Rover", "SensorsOnly"]

ROVER_SENSORS = ("odometry", "range")
"""The ``info`` keys a controller sees: wheel odometry ``(x, y, yaw)`` in the frame of the start
pose, and the range sensor's distances (m)."""


@dataclass(frozen=True)
class Rover:
    """What a controller knows about the rover it drives.

    Attributes:
        v_max: largest forward speed, m/s.
        w_max: largest yaw rate, rad/s.
        dt: control period, s.
        range_angles: directions of the range sensor's rays relative to the heading, rad.
    """

    v_max: float
    w_max: float
    dt: float
    range_angles: tuple[float, ...]

    @classmethod
    def of(cls, env: Any) -> Rover:
        """The rover of a navigation env (``sfa_gym/OmniRoverNav-v0`` and its variants)."""
        u = env.unwrapped
        return cls(
            float(u.v_max), float(u.w_max), float(u.dt), tuple(float(a) for a in u.range_angles)
        )


class SensorsOnly:
    """A controller that sees of ``info`` only the rover's own sensors (:data:`ROVER_SENSORS`)."""

    def __init__(self, controller: Controller) -> None:
        from sfa_gym.capabilities import get_capabilities

        self.controller = controller
        self.name = controller.name
        self.capabilities = get_capabilities(controller)  # what the episode runner reads

    @staticmethod
    def sensors(info: Mapping[str, Any]) -> dict[str, Any]:
        return {key: info[key] for key in ROVER_SENSORS if key in info}

    def reset(self, obs: Mapping[str, Any], info: Mapping[str, Any]) -> None:
        self.controller.reset(obs, self.sensors(info))

    def act(self, obs: Mapping[str, Any], info: Mapping[str, Any]) -> NDArray[np.float32]:
        return self.controller.act(obs, self.sensors(info))
