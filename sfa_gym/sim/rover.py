"""The rover: a four-wheel skid-steer robot of the Pioneer 3AT class with a camera mast.

The chassis is a free body; four wheels on hinge joints are driven by velocity servos and
touch the ground through real contacts, so the rover moves by physics: it accelerates,
slips and bumps into walls. A mast in the middle of the chassis carries the omnidirectional
camera (the ``<camera>`` elements of :func:`sfa_gym.sim.camera.camera_mjcf`) at
``camera_height`` above the ground; the camera body's x axis is the rover's heading.

Body frame: x forward, y to the left, z up; the body origin lies on the wheel axles,
centred between the wheels.

Skid-steer kinematics: a command ``(v, w)`` (m/s, rad/s) sets the wheel speeds

    left = (v - w * b / 2) / r,    right = (v + w * b / 2) / r,

with wheel radius ``r`` and an *effective* track ``b = track * turn_slip``. A skid-steer
vehicle turns less than an ideal differential drive with the same track, because its wheels
must slide sideways to turn. ``turn_slip = 2.3`` was measured for the default rover on the
default ground (tyre friction 1.0): turning in place for 3 s at ``w`` in [0.1, 1] rad/s turns
0.98-1.08 ``w * t`` (including the spin-up), driving straight at 0.1-0.4 m/s covers
0.99-1.03 ``v * t``; a turn while driving (v = 0.3 m/s, w = 0.5 rad/s) turns 1.01 ``w * t``.
Recalibrate when changing the tyres, the masses or the ground.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

from sfa_gym.sim.camera import PanoramaSpec, camera_mjcf
from sfa_gym.sim.worlds import MJCFParts

WHEELS = ("fl", "rl", "fr", "rr")
"""Wheel names in actuator order: front-left, rear-left, front-right, rear-right."""


def _f(x: float) -> str:
    return f"{x:.6g}"


@dataclass(frozen=True)
class RoverSpec:
    """Geometry, masses and drive of the rover (SI units: m, kg, N m, rad/s).

    Attributes:
        chassis_size: chassis box (length, width, height).
        chassis_lift: height of the chassis centre above the wheel axles.
        chassis_mass: mass of the chassis.
        wheel_radius: wheel radius ``r``.
        wheel_width: wheel width.
        wheel_mass: mass of one wheel.
        wheelbase: distance between front and rear axles.
        track: distance between the left and right wheel centres.
        friction: sliding friction coefficient of the tyres.
        camera_height: height of the camera's optical centre above the ground.
        drive_gain: velocity servo gain (N m per rad/s of speed error).
        drive_torque: torque limit of one wheel motor.
        turn_slip: effective track / track, the skid-steer correction (see module docstring).
            The tyres have ``priority`` over the ground, so their friction and contact
            softness (``solref`` 0.04 s, softer than MuJoCo's default, which makes a skidding
            rover chatter) decide the tyre contacts.
    """

    chassis_size: tuple[float, float, float] = (0.50, 0.30, 0.18)
    chassis_lift: float = 0.05
    chassis_mass: float = 10.0
    wheel_radius: float = 0.11
    wheel_width: float = 0.08
    wheel_mass: float = 0.8
    wheelbase: float = 0.268
    track: float = 0.40
    friction: float = 1.0
    camera_height: float = 1.0
    drive_gain: float = 20.0
    drive_torque: float = 20.0
    turn_slip: float = 2.3

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            for v in value if isinstance(value, tuple) else (value,):
                if not v > 0:
                    raise ValueError(f"RoverSpec.{f.name} must be positive, got {value!r}")
        if self.camera_height <= self.wheel_radius + self.chassis_lift + self.chassis_size[2] / 2:
            raise ValueError(
                f"RoverSpec.camera_height {self.camera_height} must lie above the chassis top"
            )

    @property
    def footprint_radius(self) -> float:
        """Half the diagonal of the rover's outer footprint (m): the radius of the smallest circle
        around it, so a centre this far from every obstacle can turn on the spot. The footprint
        is the chassis or the wheels, whichever reaches farther, in length and in width."""
        length = max(self.chassis_size[0], self.wheelbase + 2 * self.wheel_radius)
        width = max(self.chassis_size[1], self.track + self.wheel_width)
        return math.hypot(length, width) / 2

    @property
    def effective_track(self) -> float:
        """Track of the ideal differential drive that turns like this skid-steer rover (m)."""
        return self.track * self.turn_slip

    def wheel_speeds(self, v: float, w: float) -> tuple[float, float]:
        """Left and right wheel angular velocities (rad/s) for forward speed ``v`` (m/s) and
        yaw rate ``w`` (rad/s, counter-clockwise positive)."""
        half = w * self.effective_track / 2
        return (v - half) / self.wheel_radius, (v + half) / self.wheel_radius


def rover_mjcf(spec: RoverSpec, panorama: PanoramaSpec, name: str = "rover") -> MJCFParts:
    """MJCF of the rover standing at the origin, to put into a world with
    :func:`sfa_gym.sim.worlds.build_world`.

    Names: body ``name`` with free joint ``f"{name}_root"``; wheel joints and actuators
    ``f"{name}_wheel_{w}"`` and ``f"{name}_drive_{w}"`` for ``w`` in :data:`WHEELS`; camera
    body ``f"{name}_camera"`` holding cameras ``omni0..`` from ``camera_mjcf(panorama)``.
    """
    length, width, height = spec.chassis_size
    r = spec.wheel_radius
    mast_top = spec.camera_height - r - 0.03
    chassis_top = spec.chassis_lift + height / 2
    mast_half = (mast_top - chassis_top) / 2
    materials = (
        f'<material name="{name}_paint" rgba="0.75 0.1 0.08 1" specular="0" shininess="0"/>\n'
        f'<material name="{name}_tyre" rgba="0.08 0.08 0.08 1" specular="0" shininess="0"/>\n'
        f'<material name="{name}_hub" rgba="0.7 0.7 0.7 1" specular="0" shininess="0"/>\n'
        f'<material name="{name}_mark" rgba="1 0.85 0.1 1" specular="0" shininess="0"/>\n'
        f'<material name="{name}_mast" rgba="0.3 0.3 0.3 1" specular="0" shininess="0"/>'
    )
    wheels = []
    for w in WHEELS:
        x = spec.wheelbase / 2 if w[0] == "f" else -spec.wheelbase / 2
        y = spec.track / 2 if w[1] == "l" else -spec.track / 2
        wheels.append(
            f'  <body name="{name}_wheel_{w}" pos="{_f(x)} {_f(y)} 0">\n'
            f'    <joint name="{name}_wheel_{w}" type="hinge" axis="0 1 0" armature="0.01"/>\n'
            f'    <geom name="{name}_tyre_{w}" type="cylinder" zaxis="0 1 0" '
            f'size="{_f(r)} {_f(spec.wheel_width / 2)}" mass="{_f(spec.wheel_mass)}" '
            f'friction="{_f(spec.friction)} 0.005 0.0001" priority="1" solref="0.04 1" '
            f'material="{name}_tyre"/>\n'
            f'    <geom type="box" size="{_f(r * 0.6)} {_f(spec.wheel_width / 2 + 0.002)} '
            f'{_f(r * 0.15)}" material="{name}_hub" contype="0" conaffinity="0" mass="0"/>\n'
            f"  </body>"
        )
    body = "\n".join(
        [
            f'<body name="{name}" pos="0 0 {_f(r)}">',
            f'  <freejoint name="{name}_root"/>',
            f'  <geom name="{name}_chassis" type="box" pos="0 0 {_f(spec.chassis_lift)}" '
            f'size="{_f(length / 2)} {_f(width / 2)} {_f(height / 2)}" '
            f'mass="{_f(spec.chassis_mass)}" material="{name}_paint"/>',
            # A yellow patch on the front of the roof shows the heading in top-down renders.
            f'  <geom type="box" pos="{_f(length / 2 - 0.06)} 0 {_f(chassis_top)}" '
            f'size="0.05 {_f(width / 2 - 0.02)} 0.004" material="{name}_mark" '
            f'contype="0" conaffinity="0" mass="0"/>',
            f'  <geom name="{name}_mast" type="cylinder" '
            f'pos="0 0 {_f(chassis_top + mast_half)}" size="0.015 {_f(mast_half)}" '
            f'material="{name}_mast" contype="0" conaffinity="0" mass="0.3"/>',
            *wheels,
            f'  <body name="{name}_camera" pos="0 0 {_f(spec.camera_height - r)}">',
            *(f"    {line}" for line in camera_mjcf(panorama).splitlines()),
            "  </body>",
            "</body>",
        ]
    )
    actuators = "\n".join(
        f'<velocity name="{name}_drive_{w}" joint="{name}_wheel_{w}" kv="{_f(spec.drive_gain)}" '
        f'forcerange="{_f(-spec.drive_torque)} {_f(spec.drive_torque)}"/>'
        for w in WHEELS
    )
    return MJCFParts(assets=materials, worldbody=body, actuators=actuators)


def yaw_of_quat(w: float, x: float, y: float, z: float) -> float:
    """Heading (rad, in (-pi, pi]) of a body with orientation quaternion ``(w, x, y, z)``."""
    yaw = math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
    return math.pi if yaw <= -math.pi else yaw
