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

The mast is rigid by default. With ``RoverSpec.mast_stiffness`` set it is sprung: the mast
and the camera head hang on two hinge joints at the mast foot (pitch about the body y axis,
then roll about x) with torsion springs and dampers, so the camera pitches and rolls with the
rover's accelerations, most at stops, speed reversals and turning points, as the paper's
camera did on its pole. :meth:`RoverSpec.outdoor` is such a rover.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass, fields

from sfa_gym.sim.camera import PanoramaSpec, camera_mjcf
from sfa_gym.sim.worlds import MJCFParts

WHEELS = ("fl", "rl", "fr", "rr")
"""Wheel names in actuator order: front-left, rear-left, front-right, rear-right."""


_MAY_BE_ZERO = frozenset({"mast_stiffness", "mast_damping"})
_GRAVITY = 9.81  # m/s^2, MuJoCo's default
_MAST_TUBE_MASS = 0.3  # kg
_MAST_HEAD_GAP = 0.03  # m between the tube's top and the camera
MAST_STIFFNESS_OUTDOOR = 60.0
"""Mast hinge stiffness of :meth:`RoverSpec.outdoor` (N m/rad)."""
MAST_DAMPING_OUTDOOR = 3.5
"""Mast hinge damping of :meth:`RoverSpec.outdoor` (N m s/rad)."""


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
        mast_stiffness: torsion spring of each mast hinge (N m/rad); None or 0 for a rigid
            mast (the default, and the model of the static worlds). It must exceed the
            toppling moment of the mast and camera head under gravity
            (:attr:`mast_gravity_moment`), or the mast would fall over.
        mast_damping: damper of each mast hinge (N m s/rad); only for a sprung mast.
        camera_mass: mass of the camera head (camera and mirror) at the mast top (kg). Only
            the sprung mast carries it; the rigid model lumps it into the chassis mass.
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
    mast_stiffness: float | None = None
    mast_damping: float = 0.0
    camera_mass: float = 0.5

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            if f.name == "mast_stiffness" and value is None:
                continue
            for v in value if isinstance(value, tuple) else (value,):
                if isinstance(v, bool) or not isinstance(v, numbers.Real):
                    raise TypeError(f"RoverSpec.{f.name} must be a number, got {value!r}")
                if not math.isfinite(v):
                    raise ValueError(f"RoverSpec.{f.name} must be finite, got {value!r}")
                if f.name in _MAY_BE_ZERO:
                    if v < 0:
                        raise ValueError(
                            f"RoverSpec.{f.name} must be zero or positive, got {value!r}"
                        )
                elif not v > 0:
                    raise ValueError(f"RoverSpec.{f.name} must be positive, got {value!r}")
        if self.camera_height <= self._chassis_top + self.wheel_radius:
            raise ValueError(
                f"RoverSpec.camera_height {self.camera_height} must lie above the chassis top"
            )
        if not self.sprung_mast:
            if self.mast_damping != 0:
                raise ValueError(
                    f"RoverSpec.mast_damping={self.mast_damping!r} needs a sprung mast; set "
                    f"mast_stiffness (N m/rad) too, got mast_stiffness={self.mast_stiffness!r}"
                )
        elif self.mast_stiffness <= self.mast_gravity_moment:  # type: ignore[operator]
            raise ValueError(
                f"RoverSpec.mast_stiffness={self.mast_stiffness!r} N m/rad cannot hold the mast "
                f"up: it must exceed the toppling moment under gravity, "
                f"{self.mast_gravity_moment:.3g} N m/rad"
            )

    @classmethod
    def outdoor(cls) -> RoverSpec:
        """The default rover with a sprung mast, for the outdoor world.

        Tuned (physics timestep 0.005 s) so that a hard stop from 0.4 m/s tilts the camera
        by about 2.2 degrees (the rigid mast: 1.2, from the chassis rocking on its tyres) and
        the swing dies down within about 0.5 s (below 0.15 degrees); a reversal from 0.4 to
        -0.4 m/s tilts it by about 4.7 degrees. The mast swings at about 2 Hz, damped to about
        40 % of critical. Turning in place hardly tilts it: the mast stands on the turning
        axis.
        """
        return cls(mast_stiffness=MAST_STIFFNESS_OUTDOOR, mast_damping=MAST_DAMPING_OUTDOOR)

    @property
    def sprung_mast(self) -> bool:
        """True if the mast swings on springs (``mast_stiffness`` set and not 0)."""
        return bool(self.mast_stiffness)

    @property
    def _chassis_top(self) -> float:
        """Height of the chassis roof, the mast foot, above the wheel axles (m)."""
        return self.chassis_lift + self.chassis_size[2] / 2

    @property
    def mast_length(self) -> float:
        """Distance from the mast foot (on the chassis roof) to the camera (m)."""
        return self.camera_height - self.wheel_radius - self._chassis_top

    @property
    def mast_gravity_moment(self) -> float:
        """Gravity's toppling moment per radian of mast tilt, ``g * sum(m * h)`` over the
        mast tube and the camera head at heights ``h`` above the mast foot (N m/rad, for
        small tilts). A sprung mast stands only if its stiffness exceeds it."""
        half = (self.mast_length - _MAST_HEAD_GAP) / 2
        return _GRAVITY * (_MAST_TUBE_MASS * half + self.camera_mass * self.mast_length)

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


def _mast_geom(name: str, z: float, mast_half: float) -> str:
    return (
        f'<geom name="{name}_mast" type="cylinder" pos="0 0 {_f(z)}" '
        f'size="0.015 {_f(mast_half)}" material="{name}_mast" contype="0" conaffinity="0" '
        f'mass="{_f(_MAST_TUBE_MASS)}"/>'
    )


def _camera_body(panorama: PanoramaSpec, name: str, z: float, inertial: str = "") -> list[str]:
    return [
        f'<body name="{name}_camera" pos="0 0 {_f(z)}">',
        *((f"  {inertial}",) if inertial else ()),
        *(f"  {line}" for line in camera_mjcf(panorama).splitlines()),
        "</body>",
    ]


def _sprung_mast(spec: RoverSpec, panorama: PanoramaSpec, name: str, mast_half: float) -> list[str]:
    """Lines (indented for the rover body) of the sprung mast: a body at the mast foot on two
    spring-loaded hinges (pitch, then roll) carrying the tube and the camera head."""
    joint = (
        f'stiffness="{_f(spec.mast_stiffness or 0.0)}" damping="{_f(spec.mast_damping)}" '
        'armature="0.001"'
    )
    # The camera head's mass sits at the optical centre, without a geom that could get into
    # the camera's view; a small inertia keeps the body's inertia matrix well conditioned.
    inertial = (
        f'<inertial pos="0 0 0" mass="{_f(spec.camera_mass)}" '
        f'diaginertia="{_f(spec.camera_mass * 1e-3)} {_f(spec.camera_mass * 1e-3)} '
        f'{_f(spec.camera_mass * 1e-3)}"/>'
    )
    lines = [
        f'<body name="{name}_mast" pos="0 0 {_f(spec._chassis_top)}">',
        f'  <joint name="{name}_mast_pitch" type="hinge" axis="0 1 0" {joint}/>',
        f'  <joint name="{name}_mast_roll" type="hinge" axis="1 0 0" {joint}/>',
        f"  {_mast_geom(name, mast_half, mast_half)}",
        *(f"  {line}" for line in _camera_body(panorama, name, spec.mast_length, inertial)),
        "</body>",
    ]
    return [f"  {line}" for line in lines]


def rover_mjcf(spec: RoverSpec, panorama: PanoramaSpec, name: str = "rover") -> MJCFParts:
    """MJCF of the rover standing at the origin, to put into a world with
    :func:`sfa_gym.sim.worlds.build_world`.

    Names: body ``name`` with free joint ``f"{name}_root"``; wheel joints and actuators
    ``f"{name}_wheel_{w}"`` and ``f"{name}_drive_{w}"`` for ``w`` in :data:`WHEELS`; camera
    body ``f"{name}_camera"`` holding cameras ``omni0..`` from ``camera_mjcf(panorama)``.
    """
    length, width, height = spec.chassis_size
    r = spec.wheel_radius
    mast_top = spec.camera_height - r - _MAST_HEAD_GAP
    chassis_top = spec.chassis_lift + height / 2
    mast_half = (mast_top - chassis_top) / 2
    materials = (
        f'<material name="{name}_paint" rgba="0.75 0.1 0.08 1" specular="0" shininess="0"/>\n'
        f'<material name="{name}_tyre" rgba="0.08 0.08 0.08 1" specular="0" shininess="0"/>\n'
        f'<material name="{name}_hub" rgba="0.7 0.7 0.7 1" specular="0" shininess="0"/>\n'
        f'<material name="{name}_mark" rgba="1 0.85 0.1 1" specular="0" shininess="0"/>\n'
        f'<material name="{name}_mast" rgba="0.3 0.3 0.3 1" specular="0" shininess="0"/>'
    )
    if spec.sprung_mast:
        before_wheels: list[str] = []
        after_wheels = _sprung_mast(spec, panorama, name, mast_half)
    else:
        # the rigid mast's tube and camera body, in the order of the static worlds' model
        before_wheels = [f"  {_mast_geom(name, chassis_top + mast_half, mast_half)}"]
        after_wheels = [
            f"  {line}" for line in _camera_body(panorama, name, spec.camera_height - r)
        ]
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
            *before_wheels,
            *wheels,
            *after_wheels,
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
