"""Navigation controllers from plug-in files, and what a controller is allowed to see.

A controller plug-in is one readable Python file, loaded by path (as feature methods are, with
:func:`~sfa_gym.localization.methods.import_plugin_file`: nothing else from its folder is
imported). At module level it defines

- ``Args``: a frozen dataclass of the controller's arguments, with a default and a docstring
  each;
- ``make_controller(rover, weights, **kwargs)``: a fresh controller for a :class:`Rover` (speed
  limits, control period, range-sensor directions) and the cost weights of the features
  ``(k,)`` (each feature's slowness to a power: see
  :func:`~sfa_gym.navigation.feature_gradient.slowness_weights`), ``kwargs`` the fields of
  ``Args``.

The controller has ``name: str``, ``reset(obs, info)`` at the start of an episode and
``act(obs, info) -> (3,) float32`` (forward speed m/s, yaw rate rad/s, stop if > 0) every step.
``obs`` holds ``"features"`` and ``"goal_features"``. A controller may use the rover's own
sensors and never the ground truth: :class:`SensorsOnly` hands it an ``info`` that holds only
:data:`ROVER_SENSORS`, so a controller that reads the pose fails with a ``KeyError`` instead of
scoring with it.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sfa_gym.localization.methods import (
    PluginError,
    check_made,
    import_plugin_file,
    plugin_arguments,
    plugin_path,
)
from sfa_gym.navigation.controllers import Controller

__all__ = [
    "ROVER_SENSORS",
    "ControllerFactory",
    "Rover",
    "SensorsOnly",
    "load_controller_file",
]

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
        self.controller = controller
        self.name = controller.name

    @staticmethod
    def sensors(info: Mapping[str, Any]) -> dict[str, Any]:
        return {key: info[key] for key in ROVER_SENSORS if key in info}

    def reset(self, obs: Mapping[str, Any], info: Mapping[str, Any]) -> None:
        self.controller.reset(obs, self.sensors(info))

    def act(self, obs: Mapping[str, Any], info: Mapping[str, Any]) -> NDArray[np.float32]:
        return self.controller.act(obs, self.sensors(info))


@dataclass(frozen=True)
class ControllerFactory:
    """A loaded controller plug-in file; call it to get a fresh controller.

    Attributes:
        name: the file's stem (e.g. ``"run_and_tumble"``).
        path: the plug-in file.
        make: the file's ``make_controller``.
        args_type: the file's ``Args`` dataclass.
    """

    name: str
    path: Path
    make: Callable[..., Any]
    args_type: type

    def arguments(self, args: Mapping[str, Any] | None = None) -> dict[str, Any]:
        """Every field of ``Args`` with ``args`` applied (what a result records).

        Raises:
            ValueError: a key that is not a field of ``Args``, or a value ``Args`` refuses.
        """
        return plugin_arguments(self.path, self.args_type, args or {})

    def __call__(
        self, rover: Rover, weights: ArrayLike, args: Mapping[str, Any] | None = None
    ) -> SensorsOnly:
        """A fresh controller for ``rover`` and cost ``weights``, seeing only the sensors.

        Raises:
            PluginError: what ``make_controller`` returned lacks ``name``, ``reset`` or ``act``.
        """
        controller = self.make(rover, np.asarray(weights, dtype=np.float64), **self.arguments(args))
        check_made(self.path, controller, ("reset", "act"), "a controller", "act(obs, info)")
        return SensorsOnly(controller)


def load_controller_file(path: str | Path) -> ControllerFactory:
    """Load a controller plug-in file by path (e.g. ``baselines/controllers/run_and_tumble.py``).

    Raises:
        FileNotFoundError: no such file.
        ValueError: not a ``.py`` file.
        PluginError: the file fails to import, or lacks ``make_controller`` or the ``Args``
            dataclass; the message names the file and what is missing.
    """
    path = plugin_path(path, "controller")
    module = import_plugin_file(path)
    make = getattr(module, "make_controller", None)
    if make is None or not callable(make):
        raise PluginError(
            f"{path} defines no make_controller(rover, weights, **kwargs) at module level"
        )
    args_type = getattr(module, "Args", None)
    if not (isinstance(args_type, type) and dataclasses.is_dataclass(args_type)):
        raise PluginError(
            f"{path} defines no Args dataclass: a controller needs `@dataclass(frozen=True) "
            f"class Args` listing its arguments (with defaults), so that results can record them"
        )
    return ControllerFactory(name=path.stem, path=path, make=make, args_type=args_type)
