"""OmniRoverEnv: a skid-steer rover with an omnidirectional camera in a MuJoCo world.

The module is longer than most because the env's class docstring is its documentation (the
Gymnasium convention: spaces, starting state, arguments, rendering in one place).
"""

from __future__ import annotations

import dataclasses
import math
import os
from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import NDArray

from sfa_gym._checks import check_positive
from sfa_gym._json_types import dataclass_from_json
from sfa_gym.sim import gl

gl.configure()

import gymnasium as gym  # noqa: E402
import mujoco  # noqa: E402  (MUJOCO_GL must be set first)
from gymnasium import spaces  # noqa: E402

from sfa_gym.sim.camera import MirrorCamera, MirrorSpec, PanoramaSpec  # noqa: E402
from sfa_gym.sim.camera.mirror import vignetting_gain  # noqa: E402
from sfa_gym.sim.camera.renderer import OmniCamera  # noqa: E402
from sfa_gym.sim.camera.sensor import Sensor, SensorSpec  # noqa: E402
from sfa_gym.sim.rover import WHEELS, RoverSpec, rover_mjcf, yaw_of_quat  # noqa: E402
from sfa_gym.sim.view import TopDownView  # noqa: E402
from sfa_gym.sim.window import Window, check_window  # noqa: E402
from sfa_gym.sim.worlds import WorldSpec, build_world, load_world_spec  # noqa: E402
from sfa_gym.sim.worlds.dynamics import Dynamics, DynamicsSpec  # noqa: E402
from sfa_gym.sim.worlds.textures import TexturesSpec  # noqa: E402

_PANORAMA_PRESETS = {
    "paper_sim": PanoramaSpec.paper_sim,
    "paper_outdoor": PanoramaSpec.paper_outdoor,
}
_MIRROR_PRESETS = {"paper_outdoor": MirrorSpec.paper_outdoor}
_ROVER_PRESETS = {"default": RoverSpec, "outdoor": RoverSpec.outdoor}
CAMERAS = ("cylindrical", "mirror", "mirror_circular")
"""What the env's observation is: the cylindrical panorama, the mirror camera's unwarped
panorama, or the mirror camera's circular image."""
_SETTLE_SECONDS = 1.0
_DAY_SECONDS = 86400.0


def resolve_effect(name: str, value: Any, cls: type, declared: Any = None) -> Any:
    """The spec of one effect an env runs (``dynamics``, ``sensor``, ``textures``): None keeps
    what the world declares (``declared``), False none, True the declared spec or else the
    default ``cls()``, a ``cls`` itself, or an object of ``cls``'s fields replacing those of
    the declared spec or else the defaults (``{"clock": False, "start_hour": 17.5}``).

    Raises:
        TypeError: ``value`` is none of those.
        ValueError: an object with a key that is not a field of ``cls`` or a bad value, named.
    """
    if value is None:
        return declared
    if value is False:
        return None
    base = cls() if declared is None else declared
    if value is True:
        return base
    if isinstance(value, cls):
        return value
    if isinstance(value, Mapping):
        return dataclass_from_json(cls, value, name, noun="field", base=base)
    raise TypeError(
        f"{name} must be None, a bool, a {cls.__name__} or an object of its fields, got {value!r}"
    )


def _from_preset(name: str, value: Any, presets: dict[str, Any], cls: type) -> Any:
    """``value`` if it is a ``cls``; the preset it names; the first preset for None."""
    if value is None:
        return next(iter(presets.values()))()
    if isinstance(value, str):
        if value not in presets:
            raise ValueError(
                f"unknown {name} preset {value!r}; expected one of {sorted(presets)} or a "
                f"{cls.__name__}"
            )
        return presets[value]()
    if not isinstance(value, cls):
        raise TypeError(f"{name} must be a {cls.__name__}, a preset name or None, got {value!r}")
    return value


class OmniRoverEnv(gym.Env[NDArray[np.uint8], NDArray[np.float32]]):
    """A rover drives on the floor of a walled arena and sees it through an omnidirectional camera.

    ## Description

    A four-wheel skid-steer rover of the Pioneer 3AT class (0.5 m x 0.48 m, 13.5 kg) carries an
    omnidirectional camera on a mast, 1.0 m above the ground, after the robot of Metka, Franzius
    and Bauer-Wersing (2013), "Outdoor self-localization of a mobile robot using slow feature
    analysis". Each step the agent sets the forward speed and yaw rate; the wheels are driven by
    velocity servos and the rover moves by MuJoCo physics (contacts, slip, collisions with the
    walls). The observation is a cylindrical panorama of the surroundings. The world (arena,
    textures, landmarks, light, sky) is generated from a world spec and a world seed and stays
    fixed for the life of the env; ``reset`` only moves the rover.

    The ``"paper_sim"`` world is a 7 m x 7 m floor inside 0.8 m high walls made of textured
    panels, surrounded by trees, coloured pillars and blocks under a gradient sky. The drivable
    area is the central 6 m x 6 m square (0.5 m from the walls, so the rover fits everywhere);
    :meth:`grid_positions` gives the paper's 30 x 30 grid over it, 0.2 m apart.

    The ``"paper_outdoor"`` world is a 6 m x 8 m asphalt area bounded by 0.12 m curbs (no
    walls; a 5 m x 7 m drivable area), with a pavement, grass, building facades, trees, parked
    cars, fences, lamp posts and bushes around it, drawn from the world seed. It declares
    dynamics (:mod:`sfa_gym.sim.worlds.dynamics`): the sun (the light ``"sun"``) moves over the
    day, clouds pass, pedestrians, a cyclist and cars come and go around the area.

    This env is for exploration and self-localization: it has no task and no reward.
    Navigation tasks are separate envs.

    ## Action Space

    ``Box([-v_max, -w_max], [v_max, w_max], (2,), float32)``:

    | index | action                                 | min    | max   | unit  |
    |-------|----------------------------------------|--------|-------|-------|
    | 0     | forward speed ``v``                    | -v_max | v_max | m/s   |
    | 1     | yaw rate ``w`` (counter-clockwise > 0) | -w_max | w_max | rad/s |

    Actions outside the box are clipped. The rover's skid-steer turns less than an ideal
    differential drive; the wheel speeds use an effective track (``RoverSpec.turn_slip``) so
    that turning in place at ``w`` changes the yaw by about ``w`` per second; turning while
    driving turns somewhat less. The command is held for ``control_dt`` seconds.

    ## Observation Space

    ``Box(0, 255, (H, W, 3), uint8)``: an RGB panorama, by default 40 x 350. Column 0 looks
    along the rover's heading and the azimuth grows counter-clockwise with the column index
    (column ``c`` looks at ``yaw + 2*pi*c/W``), so turning by ``+2*pi*k/W`` shifts the content
    by ``-k`` columns. Rows span ``vfov_deg`` (40 degrees by default) centred on the horizon.

    ## Rewards

    The reward is always 0.

    ## Starting State

    With ``options={"pose": (x, y, yaw)}`` the rover is placed at rest at that pose (metres,
    radians; ``(x, y)`` must lie in :attr:`arena_bounds`). Otherwise ``x`` and ``y`` are drawn
    uniformly from :attr:`arena_bounds` and ``yaw`` uniformly from ``[-pi, pi)``, with
    ``self.np_random``.

    ## Episode End

    The episode never terminates. The registered ids truncate it after ``max_episode_steps``
    steps (1000, i.e. 100 s at the default ``control_dt``).

    ## Info

    ``reset`` and ``step`` return the ground truth: ``"x"``, ``"y"`` (m, world frame),
    ``"yaw"`` (rad, wrapped to ``(-pi, pi]``) and ``"t"`` (simulated time since reset, s).
    With dynamics, also ``"clock"``: the time of day, hours. A reset with a ``seed`` (and the
    first reset) starts the clock at the dynamics' ``start_hour``, so a seed fixes every
    pixel; a reset without a seed lets it run on from the last episode (the paper recorded its
    test run right after the training run); ``reset(options={"time_of_day": h})`` sets it.

    ## Arguments

    * ``world`` ("paper_sim"): the world spec: a name in ``envs/``, a path to a JSON spec, or
      a ``WorldSpec``.
    * ``world_seed`` (0): seed of the world's procedural variation (textures, landmarks).
    * ``panorama`` (None): a ``PanoramaSpec``, or a preset name ("paper_sim": 40 x 350,
      "paper_outdoor": 60 x 600); None means "paper_sim".
    * ``v_max`` (0.4): largest forward speed, m/s.
    * ``w_max`` (1.0): largest yaw rate, rad/s.
    * ``control_dt`` (0.1): duration of one step, s; a multiple of the physics timestep
      (0.005 s).
    * ``rover`` (None): a ``RoverSpec`` (geometry, masses, drive, camera mast) or a preset
      name: "default" (None: a rigid mast) or "outdoor" (a sprung mast that pitches and rolls
      with the rover's accelerations, as the paper's mirror did at turning points).
    * ``render_mode`` (None): None, "rgb_array" or "human" (see Rendering).
    * ``render_size`` (256): side of the square top-down render, pixels.
    * ``camera`` ("cylindrical"): the observation: the cylindrical panorama; "mirror", the
      mirror camera's circular image unwarped to a panorama; or "mirror_circular", the
      circular image itself (:mod:`sfa_gym.sim.camera.mirror`).
    * ``mirror`` (None): the mirror camera, a ``MirrorSpec`` or a preset name
      ("paper_outdoor", the default); a given ``panorama`` sets the unwarped size.
    * ``dynamics`` (None): the sun, clouds, movers and shadows
      (:class:`~sfa_gym.sim.worlds.dynamics.DynamicsSpec`): None runs what the world spec
      declares; False none; True the world's or the default ``DynamicsSpec``; a
      ``DynamicsSpec``; or an object of its fields replacing the world's (else the defaults'),
      e.g. ``{"movers": False, "start_hour": 17.5}`` or ``{"cloud_cover": 0.4}`` (clouds drawn
      into the sky: :mod:`sfa_gym.sim.worlds.sky`).
    * ``sensor`` (None): the camera's auto-exposure and noise: None or False for none, True
      for the default ``SensorSpec``, a ``SensorSpec`` (which also switches on auto white
      balance, a mirror camera's vignetting and motion blur while turning), or an object of
      its fields replacing the defaults (``{"noise": False}``). Noise is drawn from a
      generator seeded from ``np_random`` on each reset (same seed, same noise).
    * ``textures`` (None): generated surface textures (outdoor worlds), set as ``dynamics`` is
      (:class:`~sfa_gym.sim.worlds.textures.TexturesSpec`; None keeps the world spec's).

    The env also offers :attr:`dt` (seconds per step), :attr:`arena_bounds` and
    :meth:`grid_positions` for drivers, and ``model``, ``data`` (MuJoCo), ``mjcf`` (the model's
    text) and ``layout`` (where the landmarks and obstacles stand); through wrappers, read them
    with ``env.get_wrapper_attr("arena_bounds")``.

    A ``panorama`` or ``render_size`` that needs a larger offscreen buffer than OpenGL supports
    (:data:`sfa_gym.sim.gl.MAX_FRAMEBUFFER_SIDE` pixels a side) is refused here, with the size
    and the limit.

    ## Rendering

    ``"rgb_array"``: ``render()`` returns the arena from straight above (image up is world +y;
    ``env.view.pixel`` maps world points to pixels). ``"human"`` shows it in ``env.window`` after
    each ``reset`` and ``step``, at ``metadata["render_fps"]`` (1 / ``control_dt``); it needs a
    display and pygame (``pip install 'sfa-gym[human]'``), else construction names what is
    missing. Rendering never changes an observation; the same seed gives the same pictures.

    ## Vector envs

    Rendering contexts are created on the first ``reset``, never in ``__init__``, so
    ``gym.make_vec(..., vectorization_mode="async")`` works with its default start method
    (fork on Linux) as long as the parent process has not rendered yet. A process forked
    after rendering would inherit a broken GL driver and hang; the env detects that and
    raises instead. Start the workers with ``vector_kwargs={"context": "spawn"}`` (or
    ``"forkserver"``) when the parent renders too.

    ## Version History

    * v0: initial version.
    """

    metadata = {"render_modes": ["human", "rgb_array"], "render_fps": 10}

    def __init__(
        self,
        world: str | os.PathLike[str] | WorldSpec = "paper_sim",
        world_seed: int = 0,
        panorama: PanoramaSpec | str | None = None,
        v_max: float = 0.4,
        w_max: float = 1.0,
        control_dt: float = 0.1,
        rover: RoverSpec | str | None = None,
        render_mode: str | None = None,
        render_size: int = 256,
        camera: str = "cylindrical",
        mirror: MirrorSpec | str | None = None,
        dynamics: bool | DynamicsSpec | Mapping[str, Any] | None = None,
        sensor: bool | SensorSpec | Mapping[str, Any] | None = None,
        textures: bool | TexturesSpec | Mapping[str, Any] | None = None,
    ) -> None:
        self.world = world
        self.world_seed = world_seed
        panorama_given = panorama is not None
        panorama = _from_preset("panorama", panorama, _PANORAMA_PRESETS, PanoramaSpec)
        if camera not in CAMERAS:
            raise ValueError(f"camera must be one of {list(CAMERAS)}, got {camera!r}")
        self.camera = camera
        if camera == "cylindrical":
            if mirror is not None:
                raise ValueError(
                    f"mirror={mirror!r} is for camera='mirror' or 'mirror_circular', not {camera!r}"
                )
            self.mirror: MirrorSpec | None = None
        else:
            mirror = _from_preset("mirror", mirror, _MIRROR_PRESETS, MirrorSpec)
            if panorama_given:  # an explicit panorama sets the size of the unwarped one
                mirror = dataclasses.replace(
                    mirror, panorama_width=panorama.width, panorama_height=panorama.height
                )
            self.mirror = mirror
            # what the mast's cameras render, before the mirror's resampling
            panorama = mirror.view_spec()
        self.panorama = panorama
        self.v_max = check_positive("v_max", v_max)
        self.w_max = check_positive("w_max", w_max)
        self.control_dt = check_positive("control_dt", control_dt)
        self.rover = _from_preset("rover", rover, _ROVER_PRESETS, RoverSpec)
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(
                f"render_mode must be None or one of {self.metadata['render_modes']}, "
                f"got {render_mode!r}"
            )
        if render_mode == "human":
            check_window()  # fail here, not deep inside the first step
        self.render_mode = render_mode
        self.render_size = render_size

        spec = world if isinstance(world, WorldSpec) else load_world_spec(world)
        self.world_spec = dataclasses.replace(
            spec, textures=resolve_effect("textures", textures, TexturesSpec, spec.textures)
        )
        self.dynamics = resolve_effect("dynamics", dynamics, DynamicsSpec, spec.dynamics)
        self.sensor = resolve_effect("sensor", sensor, SensorSpec)
        built = build_world(
            self.world_spec, world_seed, rover_mjcf(self.rover, panorama), self.dynamics
        )
        self.mjcf = built.mjcf
        self.layout = built.layout
        self.model = mujoco.MjModel.from_xml_string(self.mjcf, built.assets)
        self.data = mujoco.MjData(self.model)
        self.view = TopDownView(self.model, render_size)
        timestep = float(self.model.opt.timestep)
        self.frame_skip = round(self.control_dt / timestep)
        if self.frame_skip < 1 or abs(self.frame_skip * timestep - self.control_dt) > 1e-9:
            raise ValueError(
                f"control_dt must be a positive multiple of the physics timestep {timestep} s, "
                f"got {control_dt!r}"
            )
        self.metadata = {**self.metadata, "render_fps": 1.0 / self.control_dt}
        self.window = Window(f"sfa_gym: {self.world_spec.name}", self.metadata["render_fps"])

        joint = self.model.joint("rover_root")
        self._qpos0 = int(joint.qposadr[0])
        self._dof0 = int(joint.dofadr[0])
        self._rover_body = int(joint.bodyid[0])
        self._actuators = [self.model.actuator(f"rover_drive_{w}").id for w in WHEELS]
        self._rest_z = self._settled_height()

        # Cheap: the camera and the top-down renderer create their GL contexts on first use,
        # so the env can be built in one process and stepped in a forked or spawned worker.
        self._camera: OmniCamera | MirrorCamera = (
            OmniCamera(self.model, panorama)
            if self.mirror is None
            else MirrorCamera(self.model, self.mirror)
        )
        self._dynamics = (
            None
            if self.dynamics is None
            else Dynamics(
                self.dynamics, self.model, self.world_spec.arena.size, world_seed, built.lanes
            )
        )
        if self.dynamics is not None:
            camera = self._camera
            views = camera.view_camera if isinstance(camera, MirrorCamera) else camera
            views.visibility_m = self.dynamics.visibility_m
            views.shadows = self.dynamics.shadows
        # time of day (s since midnight): set on the first reset, then it runs on
        self._clock: float | None = None
        self._sun_time: float | None = None  # where the sun is held with the clock off
        exposure = 0.0 if self.sensor is None else self.sensor.exposure_s
        if exposure > 0 and self.camera == "mirror_circular":
            raise ValueError(
                f"exposure_s {exposure} (motion blur) needs a panorama, whose "
                "columns are azimuths: camera 'mirror' or 'cylindrical', not 'mirror_circular'"
            )
        self._sensor = None if self.sensor is None else Sensor(self.sensor, self._falloff())
        self._noise_rng: np.random.Generator | None = None

        self.action_space = spaces.Box(
            low=np.array([-self.v_max, -self.w_max], dtype=np.float32),
            high=np.array([self.v_max, self.w_max], dtype=np.float32),
            dtype=np.float32,
        )
        if self.mirror is None:
            shape = (panorama.height, panorama.width, 3)
        elif camera == "mirror_circular":
            shape = self.mirror.circular_shape
        else:
            shape = self.mirror.panorama_shape
        self.observation_space = spaces.Box(0, 255, shape=shape, dtype=np.uint8)

    @property
    def dt(self) -> float:
        """Simulated seconds per env step (``control_dt``), the Gymnasium convention."""
        return self.control_dt

    # -- helpers for drivers -------------------------------------------------------------------

    @property
    def arena_bounds(self) -> tuple[float, float, float, float]:
        """Drivable area ``(xmin, xmax, ymin, ymax)`` in metres, world frame."""
        return self.layout.bounds

    def rover_fits(self, points: Any) -> NDArray[np.bool_]:
        """``(n,)`` whether the rover fits at each of ``points`` ``(n, 2)`` (m): its clearance
        from every obstacle and interior wall exceeds its footprint radius. ``reset`` refuses a
        pose where it does not; the drivers, the navigation protocol and the feature fields keep
        only the positions where it does."""
        points = np.asarray(points, dtype=np.float64).reshape(-1, 2)
        return np.asarray(self.layout.clearance(points) > self.rover.footprint_radius, dtype=bool)

    def grid_positions(self, n: int = 30) -> NDArray[np.float64]:
        """The ``n x n`` regular grid of positions over :attr:`arena_bounds` (cell centres).

        Returns:
            ``(n * n, 2)`` float64 ``(x, y)`` in metres, x varying fastest. With the default
            world and ``n=30`` the spacing is 0.2 m.
        """
        if isinstance(n, bool) or not isinstance(n, int | np.integer) or n < 1:
            raise ValueError(f"n must be a positive int, got {n!r}")
        xmin, xmax, ymin, ymax = self.arena_bounds
        xs = xmin + (np.arange(n) + 0.5) * (xmax - xmin) / n
        ys = ymin + (np.arange(n) + 0.5) * (ymax - ymin) / n
        gx, gy = np.meshgrid(xs, ys)
        return np.stack([gx.ravel(), gy.ravel()], axis=1)

    # -- physics ------------------------------------------------------------------------------

    def _settled_height(self) -> float:
        """Height of the body origin when the rover rests on the ground (contacts are soft,
        so the wheels sink in slightly); placing the rover there makes it start at rest."""
        x, y = self._free_position(self.grid_positions(9))
        mujoco.mj_resetData(self.model, self.data)
        self.data.qpos[self._qpos0 : self._qpos0 + 2] = (x, y)
        mujoco.mj_step(
            self.model, self.data, nstep=round(_SETTLE_SECONDS / self.model.opt.timestep)
        )
        return float(self.data.qpos[self._qpos0 + 2])

    def _free_position(self, candidates: NDArray[np.float64]) -> tuple[float, float]:
        """The first candidate ``(x, y)`` where the rover clears every obstacle and interior
        wall (the last candidate if none does)."""
        free = np.flatnonzero(self.rover_fits(candidates))
        x, y = candidates[free[0] if free.size else -1]
        return float(x), float(y)

    def _place(self, x: float, y: float, yaw: float, data: mujoco.MjData | None = None) -> None:
        m, d = self.model, self.data if data is None else data
        mujoco.mj_resetData(m, d)
        q = self._qpos0
        d.qpos[q : q + 3] = (x, y, self._rest_z)
        d.qpos[q + 3 : q + 7] = (math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2))
        mujoco.mj_forward(m, d)

    def _pose(self) -> tuple[float, float, float]:
        q = self.data.qpos[self._qpos0 : self._qpos0 + 7]
        return float(q[0]), float(q[1]), yaw_of_quat(*(float(v) for v in q[3:7]))

    def _yaw_rate(self) -> float:
        """The rover's turning rate about the world's vertical, rad/s (counter-clockwise > 0):
        a free joint's angular velocity is in its body's frame."""
        omega = self.data.qvel[self._dof0 + 3 : self._dof0 + 6]
        return float(self.data.xmat[self._rover_body].reshape(3, 3)[2] @ omega)

    def _info(self, pose: tuple[float, float, float] | None = None) -> dict[str, float]:
        """Ground truth at ``pose`` (the current one, read from the state when None)."""
        x, y, yaw = self._pose() if pose is None else pose
        info = {"x": x, "y": y, "yaw": yaw, "t": float(self.data.time)}
        if self._clock is not None:
            info["clock"] = (self._clock % _DAY_SECONDS) / 3600.0
        return info

    def _random_pose(self) -> tuple[float, float, float]:
        xmin, xmax, ymin, ymax = self.arena_bounds
        # Rejection sampling around obstacles; draws continue from np_random, so a seed
        # still fixes the start.
        candidates = self.np_random.uniform((xmin, ymin), (xmax, ymax), size=(1000, 2))
        x, y = self._free_position(candidates)
        yaw = float(self.np_random.uniform(-math.pi, math.pi))
        return x, y, yaw

    @staticmethod
    def _pose_numbers(name: str, pose: Any) -> tuple[float, float, float]:
        """``options[name]`` as finite ``(x, y, yaw)`` floats, or a ValueError naming it."""
        try:
            x, y, yaw = (float(v) for v in pose)
        except (TypeError, ValueError):
            raise ValueError(
                f'options["{name}"] must be (x, y, yaw) numbers, got {pose!r}'
            ) from None
        if not all(math.isfinite(v) for v in (x, y, yaw)):
            raise ValueError(f'options["{name}"] must be finite, got {pose!r}')
        return x, y, yaw

    def _check_pose(self, pose: Any) -> tuple[float, float, float]:
        x, y, yaw = self._pose_numbers("pose", pose)
        xmin, xmax, ymin, ymax = self.arena_bounds
        if not (xmin - 1e-9 <= x <= xmax + 1e-9 and ymin - 1e-9 <= y <= ymax + 1e-9):
            raise ValueError(
                f'options["pose"] position ({x}, {y}) lies outside the drivable area '
                f"x in [{xmin}, {xmax}], y in [{ymin}, {ymax}]"
            )
        if not self.rover_fits([(x, y)])[0]:
            clearance = float(self.layout.clearance([(x, y)])[0])
            raise ValueError(
                f'options["pose"] position ({x}, {y}) is {clearance:.3f} m from an obstacle or '
                f"interior wall; the rover needs more than its footprint radius "
                f"{self.rover.footprint_radius:.3f} m"
            )
        return x, y, yaw

    # -- gymnasium API ------------------------------------------------------------------------

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[NDArray[np.uint8], dict[str, float]]:
        super().reset(seed=seed)
        options = {} if options is None else dict(options)
        unknown = sorted(set(options) - {"pose", "time_of_day"})
        if unknown:
            raise ValueError(f"unknown reset options {unknown}; expected 'pose', 'time_of_day'")
        if options.get("pose") is not None:
            pose = self._check_pose(options["pose"])
        else:
            pose = self._random_pose()
        self._start_clock(options.get("time_of_day"), restart=seed is not None)
        if self._sensor is not None:
            self._noise_rng = np.random.default_rng(int(self.np_random.integers(2**63)))
        self._place(*pose)
        if self._dynamics is not None:
            self._dynamics.apply(self.data, self._clock, self._sun_time)
            mujoco.mj_forward(self.model, self.data)
        gl.check_usable()
        observation, info = self._observe(None), self._info()
        self._show()
        return observation, info

    def _start_clock(self, hours: Any, restart: bool) -> None:
        """Set the clock to ``hours`` (time of day), or to the start hour on the first reset
        and on a seeded one (a seed fixes everything); otherwise it runs on."""
        if hours is not None:
            if self._dynamics is None:
                raise ValueError(
                    f'options["time_of_day"]={hours!r} needs dynamics; this env has none '
                    "(pass dynamics=True)"
                )
            if (
                isinstance(hours, bool)
                or not isinstance(hours, int | float)
                or not (0.0 <= hours < 24.0)
            ):
                raise ValueError(f'options["time_of_day"] must be hours in [0, 24), got {hours!r}')
            self._clock = float(hours) * 3600.0
        elif (self._clock is None or restart) and self.dynamics is not None:
            self._clock = self.dynamics.start_hour * 3600.0
        if self.dynamics is not None and not self.dynamics.clock:
            self._sun_time = self._clock  # the sun stays where it stands now

    def _falloff(self) -> NDArray[np.float32] | None:
        """The lens's relative illumination per pixel, when the sensor vignettes (a mirror
        camera's lens: the ideal cylindrical camera has no lens to vignette)."""
        if self.sensor is None or self.sensor.vignetting == 0:
            return None
        if not isinstance(self._camera, MirrorCamera):
            raise ValueError(
                f"vignetting {self.sensor.vignetting} needs a mirror camera (the lens under the "
                f"mirror); camera {self.camera!r} has none"
            )
        circular = self.camera == "mirror_circular"
        return vignetting_gain(self._camera.spec, self.sensor.vignetting, circular)

    def _observe(self, dt: float | None) -> NDArray[np.uint8]:
        """What the camera delivers now; ``dt`` seconds after the previous frame, or None for
        an episode's first frame (the sensor's exposure starts settled on it)."""
        sensor = None
        if self._sensor is not None:
            device, rng = self._sensor, self._noise_rng
            assert rng is not None  # set on reset

            def sensor(image: NDArray[np.uint8]) -> NDArray[np.uint8]:
                if dt is None:
                    device.reset(image)
                return device.process(image, 0.0 if dt is None else dt, rng, self._yaw_rate())

        if isinstance(self._camera, MirrorCamera):
            if self.camera == "mirror_circular":
                image = self._camera.render_circular(self.data)
                return image if sensor is None else sensor(image)
            # exposure and noise on the unwarped panorama: on the 480 x 480 circular image they
            # cost more than the render itself (measured), for pixels the unwarp mostly drops
        image = self._camera.render(self.data)
        return image if sensor is None else sensor(image)

    def step(
        self, action: NDArray[np.float32]
    ) -> tuple[NDArray[np.uint8], float, bool, bool, dict[str, float]]:
        a = np.asarray(action, dtype=np.float64)
        if a.shape != (2,):
            raise ValueError(f"action must have shape (2,) = (v, w), got shape {a.shape}")
        if not np.all(np.isfinite(a)):
            raise ValueError(f"action must be finite, got {a.tolist()}")
        v = min(max(a[0], -self.v_max), self.v_max)
        w = min(max(a[1], -self.w_max), self.w_max)
        left, right = self.rover.wheel_speeds(v, w)
        self.data.ctrl[self._actuators] = (left, left, right, right)
        if self._dynamics is not None and self._clock is not None:
            # the scene at the end of the step (movers are kinematic: no lag through physics)
            self._clock += self.control_dt * self._dynamics.spec.time_scale
            self._dynamics.apply(self.data, self._clock, self._sun_time)
        mujoco.mj_step(self.model, self.data, nstep=self.frame_skip)
        gl.check_usable()
        observation, info = self._observe(self.control_dt), self._info()
        self._show()
        return observation, 0.0, False, False, info

    def render(self) -> NDArray[np.uint8] | None:
        """The top-down view with :meth:`_marks`, ``(render_size, render_size, 3)`` uint8, for
        ``"rgb_array"``; for ``"human"`` shown in the window, and None returned."""
        if self.render_mode is None:
            gym.logger.warn("render() was called without a render_mode: pass 'rgb_array'")
            return None
        frame = self.view.render(self.data, **self._marks())
        if self.render_mode == "human":
            self.window.show(frame)
            return None
        return frame

    def _marks(self) -> dict[str, Any]:
        """What :meth:`render` draws on the arena (keywords of ``TopDownView.render``)."""
        return {}

    def _show(self) -> None:  # human mode shows each state that reset and step reach
        if self.render_mode == "human":
            self.render()

    def close(self) -> None:
        self._camera.close()
        self.view.close()
        self.window.close()
