"""OmniRoverNavEnv: image-goal navigation for the omnidirectional rover."""

from __future__ import annotations

import math
import os
from typing import Any

import numpy as np
from numpy.typing import NDArray

from sfa_gym.sim import gl

gl.configure()

import gymnasium as gym  # noqa: E402
import mujoco  # noqa: E402  (MUJOCO_GL must be set first)
from gymnasium import spaces  # noqa: E402

from sfa_gym._checks import check_positive  # noqa: E402
from sfa_gym.navigation.distance_map import GeodesicMap  # noqa: E402
from sfa_gym.navigation.field import FeatureField  # noqa: E402
from sfa_gym.navigation.occupancy import OccupancyGrid  # noqa: E402
from sfa_gym.navigation.odometry import WheelOdometry  # noqa: E402
from sfa_gym.sim.camera import PanoramaSpec  # noqa: E402
from sfa_gym.sim.env import OmniRoverEnv  # noqa: E402
from sfa_gym.sim.rover import WHEELS, RoverSpec  # noqa: E402
from sfa_gym.sim.worlds import WorldSpec  # noqa: E402

__all__ = ["INTERIOR_CLEARANCE", "REWARDS", "OmniRoverNavEnv"]

REWARDS = ("geodesic", "sparse")
INTERIOR_CLEARANCE = 0.6
"""An episode is *interior* when its start and goal lie at least this far (m) inside the
drivable area, away from its boundary and from obstacles: near the walls the slowest features
flatten out, which is where gradient following is hardest."""

# Draws per attempt when sampling a start for a goal; attempts before giving up.
_CANDIDATES = 256
_ATTEMPTS = 50
# Height of the range sensor's rays above the body origin (on the axles): above the wheels
# (their tops are 0.11 m up) and below the chassis top, so the rays leave the rover through
# its own chassis, which the cast excludes, and hit obstacles of any height.
_RANGE_HEIGHT = 0.12


class OmniRoverNavEnv(OmniRoverEnv):
    """Drive to the place shown in a goal panorama: image-goal navigation.

    ## Description

    The rover and world of :class:`~sfa_gym.sim.env.OmniRoverEnv` (read its docstring for the
    physics and the camera). Each episode draws a start pose and a goal pose with
    ``self.np_random``: both in free space (for the rover's footprint radius, around walls and
    obstacles), the goal reachable from the start, and the geodesic distance between them (the
    shortest path on an occupancy grid of the world, see
    :class:`~sfa_gym.navigation.occupancy.OccupancyGrid`) at least ``min_distance``. The agent
    sees its panorama and the goal's panorama and must decide itself when it has arrived.

    ## Action Space

    ``Box([-v_max, -w_max, -1], [v_max, w_max, 1], (3,), float32)``: forward speed (m/s), yaw
    rate (rad/s) and *stop* (the episode ends when ``action[2] > 0``). With
    ``stop_action=False`` the action is ``(v, w)`` only and the episode ends on arrival.

    ## Observation Space

    ``Dict(panorama=Box(0, 255, (H, W, 3), uint8), goal=Box(0, 255, (H, W, 3), uint8))``: the
    current panorama and the panorama rendered at the goal pose. With ``feature_field`` the env
    renders nothing and observes ``Dict(features=Box(-inf, inf, (k,), float32),
    goal_features=...)``: the field's features at the current and the goal position, the same
    observation :class:`~sfa_gym.wrappers.GoalFeatureObservation` computes from panoramas.

    ## Rewards

    * ``"geodesic"`` (default): the decrease of the geodesic distance to the goal in the step
      (m; oracle shaping from the map, for RL baselines), plus ``success_reward`` on success.
    * ``"sparse"``: ``success_reward`` on success, else 0.

    The reward a robot can compute itself, the decrease of the distance between current and goal
    features, is :class:`~sfa_gym.wrappers.FeatureProgressReward`.

    ## Starting State

    ``options={"start": (x, y, yaw), "goal": (x, y, yaw)}`` fixes either pose (both must be in
    free space); otherwise they are drawn as described above.

    ## Episode End

    Terminates when the agent stops (``action[2] > 0``): a *success* when the rover is then
    within ``success_radius`` of the goal position. With ``stop_action=False`` it terminates,
    successfully, as soon as the rover is within ``success_radius``. The registered ids
    truncate after ``max_episode_steps``.

    ## Info

    Ground truth (for evaluation and oracles; controllers must not use it): ``"x"``, ``"y"``,
    ``"yaw"``, ``"t"``, ``"start"`` and ``"goal"`` (poses), ``"geodesic_distance"`` (m, from
    the rover to the goal: the straight line in the open arena, else read from the goal's
    :class:`~sfa_gym.navigation.distance_map.GeodesicMap`, within 1.5 % + 2 cm of the exact
    distance), ``"shortest_path"`` (the exact geodesic distance at the start),
    ``"path_length"`` (m driven), ``"success"``, ``"collisions"`` (contacts of the rover with
    walls or obstacles that began during the episode), ``"interior"`` (start and goal at least
    :data:`INTERIOR_CLEARANCE` from walls and obstacles).

    The rover's own sensors: ``"odometry"`` (``(x, y, yaw)`` from the wheel encoders in the
    frame of the start pose, :class:`~sfa_gym.navigation.odometry.WheelOdometry`) and
    ``"range"`` (distances (m) from the rover's centre to the nearest wall or obstacle along
    ``range_rays`` horizontal rays spread over ``range_fov_deg`` around the heading, cut at
    ``range_max``; MuJoCo's ray cast, the one its rangefinder sensors use).

    ## Rendering

    As in :class:`~sfa_gym.sim.env.OmniRoverEnv` (``render_mode`` "rgb_array" or "human"),
    with the goal drawn on the top-down view (a green disc of ``success_radius``, a dark green
    line along the goal's heading) and the rover's path since ``reset`` (a yellow line). The
    marks are in ``render()``'s picture only, never in an observation.

    ## Arguments

    Those of :class:`~sfa_gym.sim.env.OmniRoverEnv` (the camera, dynamics, sensor and textures
    by keyword), and:

    * ``success_radius`` (0.3): metres from the goal position that count as arrived. The rover
      is 0.5 m long and wide; at 0.3 m its footprint overlaps the goal footprint by more than
      half, and the paper's localization error is 0.1-0.2 m: closer than that a robot cannot
      tell from vision alone whether it has arrived.
    * ``stop_action`` (True): the agent ends the episode with a stop action (Habitat); False
      ends on arrival.
    * ``reward`` ("geodesic"): one of :data:`REWARDS`.
    * ``success_reward`` (1.0): reward added on success.
    * ``min_distance`` (1.0): smallest geodesic start-goal distance of a drawn episode (m).
    * ``feature_field`` (None): a :class:`~sfa_gym.navigation.field.FeatureField` (or the path
      of a saved one) of this world and seed: observe its features instead of rendering.
    * ``range_rays`` (7), ``range_fov_deg`` (180), ``range_max`` (2.0 m): the range sensor;
      ``range_rays=0`` switches it off.
    * ``grid_resolution`` (0.05): cell size of the occupancy grid (m).

    ## Version History

    * v0: initial version.
    """

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
        success_radius: float = 0.3,
        stop_action: bool = True,
        reward: str = "geodesic",
        success_reward: float = 1.0,
        min_distance: float = 1.0,
        feature_field: FeatureField | str | os.PathLike[str] | None = None,
        range_rays: int = 7,
        range_fov_deg: float = 180.0,
        range_max: float = 2.0,
        grid_resolution: float = 0.05,
        **scene: Any,
    ) -> None:
        # the camera, dynamics, sensor and textures of OmniRoverEnv (camera="mirror", ...)
        super().__init__(
            world,
            world_seed,
            panorama,
            v_max,
            w_max,
            control_dt,
            rover,
            render_mode,
            render_size,
            **scene,
        )
        self.success_radius = check_positive("success_radius", success_radius)
        if not isinstance(stop_action, bool):
            raise TypeError(f"stop_action must be a bool, got {stop_action!r}")
        self.stop_action = stop_action
        if reward not in REWARDS:
            raise ValueError(f"reward must be one of {REWARDS}, got {reward!r}")
        self.reward_kind = reward
        self.success_reward = float(success_reward)
        if not math.isfinite(self.success_reward):
            raise ValueError(f"success_reward must be finite, got {success_reward!r}")
        self.min_distance = check_positive("min_distance", min_distance)
        if isinstance(range_rays, bool) or not isinstance(range_rays, int) or range_rays < 0:
            raise ValueError(f"range_rays must be an int >= 0, got {range_rays!r}")
        self.range_rays = range_rays
        self.range_fov_deg = check_positive("range_fov_deg", range_fov_deg)
        if self.range_fov_deg > 360:
            raise ValueError(f"range_fov_deg must be at most 360, got {range_fov_deg!r}")
        self.range_max = check_positive("range_max", range_max)

        self.occupancy = OccupancyGrid.from_layout(
            self.layout, self.rover.footprint_radius, resolution=grid_resolution
        )
        self.feature_field = self._load_field(feature_field)
        self.odometry = WheelOdometry(self.rover.wheel_radius, self.rover.effective_track)
        self._goal: tuple[float, float, float] | None = None  # drawn by reset
        self._path: list[tuple[float, float]] = []  # the rover's positions since reset
        self._scratch: mujoco.MjData | None = None  # renders at other poses (render_panorama)

        m = self.model
        self._wheel_qpos = [int(m.joint(f"rover_wheel_{w}").qposadr[0]) for w in WHEELS]
        self._body = int(m.body("rover").id)
        rover_bodies = {b for b in range(m.nbody) if self._in_rover(b)}
        self._rover_geom = np.isin(m.geom_bodyid, list(rover_bodies))
        # everything the rover can bump into: colliding geoms that are not the ground
        self._solid = (
            ~self._rover_geom
            & ((m.geom_contype != 0) | (m.geom_conaffinity != 0))
            & (m.geom_type != mujoco.mjtGeom.mjGEOM_PLANE)
        )
        half = math.radians(self.range_fov_deg) / 2
        if self.range_rays == 1:
            angles = np.zeros(1)
        elif self.range_fov_deg >= 360:
            angles = np.linspace(-math.pi, math.pi, self.range_rays, endpoint=False)
        else:
            angles = np.linspace(-half, half, self.range_rays)
        self.range_angles = angles
        self._ray_dirs = np.stack([np.cos(angles), np.sin(angles), np.zeros_like(angles)], 1)
        self._ray_geom = np.zeros(self.range_rays, dtype=np.int32)
        self._ray_dist = np.zeros(self.range_rays)

        if self.stop_action:
            self.action_space = spaces.Box(
                low=np.array([-self.v_max, -self.w_max, -1.0], dtype=np.float32),
                high=np.array([self.v_max, self.w_max, 1.0], dtype=np.float32),
                dtype=np.float32,
            )
        panorama_space = self.observation_space
        if self.feature_field is None:
            self.observation_space = spaces.Dict(
                {"panorama": panorama_space, "goal": panorama_space}
            )
        else:
            k = self.feature_field.n_features
            box = spaces.Box(-np.inf, np.inf, (k,), np.float32)
            self.observation_space = spaces.Dict({"features": box, "goal_features": box})

    # -- set-up helpers -----------------------------------------------------------------------

    def _in_rover(self, body: int) -> bool:
        while body > 0:
            if body == self._body:
                return True
            body = int(self.model.body_parentid[body])
        return False

    def _load_field(self, field: Any) -> FeatureField | None:
        if field is None:
            return None
        if isinstance(field, str | os.PathLike):
            field = FeatureField.load(field)
        if not isinstance(field, FeatureField):
            raise TypeError(f"feature_field must be a FeatureField, a path or None, got {field!r}")
        field.check_env(self)
        return field

    # -- sensors -------------------------------------------------------------------------------

    def _wheel_angles(self) -> NDArray[np.float64]:
        return self.data.qpos[self._wheel_qpos].copy()

    def _ranges(self) -> NDArray[np.float32]:
        out = np.full(self.range_rays, self.range_max, dtype=np.float32)
        if not self.range_rays:
            return out
        xmat = self.data.xmat[self._body].reshape(3, 3)
        origin = self.data.xpos[self._body] + xmat[:, 2] * _RANGE_HEIGHT
        directions = np.einsum("ri,ji->rj", self._ray_dirs, xmat).ravel()  # not BLAS: portable
        mujoco.mj_multiRay(
            self.model, self.data, origin, directions, None, 1, self._body,
            self._ray_geom, self._ray_dist, None, self.range_rays, self.range_max,
        )  # fmt: skip
        hit = (self._ray_dist >= 0) & (self._ray_dist < self.range_max)
        out[hit] = self._ray_dist[hit]
        return out

    def _touching(self) -> bool:
        """Whether the rover touches a wall or obstacle now."""
        n = self.data.ncon
        if n == 0:
            return False
        g1 = self.data.contact.geom1[:n]
        g2 = self.data.contact.geom2[:n]
        hits = (self._rover_geom[g1] & self._solid[g2]) | (self._rover_geom[g2] & self._solid[g1])
        return bool(hits.any())

    # -- episode -------------------------------------------------------------------------------

    def _check_pose_option(self, name: str, pose: Any) -> tuple[float, float, float]:
        x, y, yaw = self._pose_numbers(name, pose)
        if not self.occupancy.is_free(np.array([[x, y]]))[0]:
            raise ValueError(
                f'options["{name}"] position ({x}, {y}) is not in free space: outside the '
                f"drivable area {self.arena_bounds} or within the rover's footprint radius "
                f"{self.rover.footprint_radius:.3f} m of a wall or obstacle"
            )
        return x, y, yaw

    def _draw_episode(
        self, start: tuple[float, float, float] | None, goal: tuple[float, float, float] | None
    ) -> tuple[tuple[float, float, float], tuple[float, float, float], Any]:
        rng = self.np_random
        for _ in range(_ATTEMPTS):
            g = goal
            if g is None:
                gx, gy = self.occupancy.sample_free(rng, 1)[0]
                g = (float(gx), float(gy), float(rng.uniform(-math.pi, math.pi)))
            geodesic = self.occupancy.geodesic(np.array(g[:2]))
            if start is not None:
                return start, g, geodesic
            candidates = self.occupancy.sample_free(rng, _CANDIDATES)
            start = self._first_start(candidates, geodesic)
            if start is not None:
                sx, sy = start
                return (float(sx), float(sy), float(rng.uniform(-math.pi, math.pi))), g, geodesic
        raise RuntimeError(
            f"found no start at least min_distance={self.min_distance} m (geodesic) from a goal "
            f"in {_ATTEMPTS} attempts; the free space of this world is too small for it"
        )

    def _first_start(self, candidates: NDArray[np.float64], geodesic: Any) -> NDArray | None:
        """The first of ``candidates`` ``(n, 2)`` that reaches the goal and is at least
        ``min_distance`` from it (geodesic), or None."""
        # The geodesic is never shorter than the straight line: a candidate in the goal's
        # component that far in a straight line qualifies without a query; only the candidates
        # before it need the exact (slower) one.
        goal = geodesic.goal[None]
        far = np.hypot(*(candidates - goal).T) >= self.min_distance
        same = self.occupancy.component(candidates) == self.occupancy.component(goal)[0]
        sure = np.flatnonzero(far & same)
        head = candidates[: sure[0] if sure.size else len(candidates)]
        distance = geodesic.distance(head) if len(head) else np.zeros(0)
        ok = np.flatnonzero(np.isfinite(distance) & (distance >= self.min_distance))
        if ok.size:
            return head[ok[0]]
        return candidates[sure[0]] if sure.size else None

    def _observation(
        self, panorama: NDArray[np.uint8] | None, x: float, y: float
    ) -> dict[str, NDArray]:
        """The observation at position ``(x, y)``: the rendered ``panorama``, or the field."""
        if self.feature_field is None:
            # copies: users keep observations, and the goal's stays the same all episode
            return {"panorama": panorama, "goal": self._goal_panorama.copy()}
        return {
            "features": self.feature_field.at(x, y),
            "goal_features": self._goal_features.copy(),
        }

    def render_panorama(self, pose: Any = None) -> NDArray[np.uint8]:
        """The camera's panorama, ``(H, W, 3)`` uint8, rendered now: also with a
        ``feature_field``, whose observations hold no pixels (for recordings and for controllers
        that act on panoramas).

        Args:
            pose: None for the rover's current pose; else ``(x, y, yaw)``: the rover at rest
                there, placed in a scratch copy of the scene (the episode's state is untouched;
                the same pixels as the env's own render at that pose, e.g. its goal panorama).
        """
        gl.check_usable()
        if pose is None:
            return self._camera.render(self.data)
        if self._scratch is None:
            self._scratch = mujoco.MjData(self.model)
        self._place(*self._pose_numbers("pose", pose), data=self._scratch)
        return self._camera.render(self._scratch)

    def _nav_info(self, x: float, y: float, yaw: float) -> dict[str, Any]:
        """The info dict at the current pose ``(x, y, yaw)`` (read once per step by the caller)."""
        return self._info((x, y, yaw)) | {
            "start": np.array(self._start),
            "goal": np.array(self._goal),
            "geodesic_distance": self._distance,
            "shortest_path": self._shortest,
            "path_length": self._path_length,
            "success": self._success,
            "collisions": self._collisions,
            "interior": self._interior,
            "odometry": self.odometry.pose.copy(),
            "range": self._ranges(),
        }

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, NDArray], dict[str, Any]]:
        gym.Env.reset(self, seed=seed)
        options = {} if options is None else dict(options)
        unknown = sorted(set(options) - {"start", "goal"})
        if unknown:
            raise ValueError(f"unknown reset options {unknown}; expected 'start' and/or 'goal'")
        start = goal = None
        if options.get("start") is not None:
            start = self._check_pose_option("start", options["start"])
        if options.get("goal") is not None:
            goal = self._check_pose_option("goal", options["goal"])
        self._start, self._goal, self._goal_geodesic = self._draw_episode(start, goal)
        self._shortest = float(self._goal_geodesic.distance(np.array([self._start[:2]]))[0])
        if not math.isfinite(self._shortest):
            raise ValueError(f"the goal {self._goal} cannot be reached from {self._start}")
        # per step, the distance to the goal: the straight line in an open arena, else a
        # lookup in the goal's distance map (an exact query costs as much as the physics)
        if self.occupancy.free.all():
            self._distance_at = self._goal_geodesic.distance_at
        else:
            self._distance_at = GeodesicMap(self.occupancy, self._goal[:2]).distance_at
        clear = self.occupancy.clearance(np.array([self._start[:2], self._goal[:2]]))
        self._interior = bool(np.all(clear >= INTERIOR_CLEARANCE))

        panorama = None
        if self.feature_field is None:
            gl.check_usable()
            self._place(*self._goal)
            self._goal_panorama = self._camera.render(self.data)
        else:
            self._goal_features = self.feature_field(np.array([self._goal[:2]]))[0]
        self._place(*self._start)
        if self.feature_field is None:
            panorama = self._camera.render(self.data)

        self.odometry.reset(self._wheel_angles())
        # the rewards telescope over the map's values; shortest_path stays exact for SPL
        self._distance = self._distance_at(*self._start[:2])
        self._path_length = 0.0
        self._success = False
        self._collisions = 0
        self._was_touching = self._touching()
        self._xy = self._pose()[:2]
        self._path = [self._xy]
        observation = self._observation(panorama, *self._start[:2])
        info = self._nav_info(*self._pose())
        self._show()
        return observation, info

    def step(
        self, action: NDArray[np.float32]
    ) -> tuple[dict[str, NDArray], float, bool, bool, dict[str, Any]]:
        a = np.asarray(action, dtype=np.float64)
        n = 3 if self.stop_action else 2
        if a.shape != (n,):
            what = "(v, w, stop)" if self.stop_action else "(v, w)"
            raise ValueError(f"action must have shape ({n},) = {what}, got shape {a.shape}")
        if not np.all(np.isfinite(a)):
            raise ValueError(f"action must be finite, got {a.tolist()}")
        x0, y0 = self._xy
        v = min(max(a[0], -self.v_max), self.v_max)
        w = min(max(a[1], -self.w_max), self.w_max)
        left, right = self.rover.wheel_speeds(v, w)
        self.data.ctrl[self._actuators] = (left, left, right, right)
        mujoco.mj_step(self.model, self.data, nstep=self.frame_skip)

        x, y, yaw = self._pose()
        self._xy = x, y
        self._path.append(self._xy)
        self._path_length += math.hypot(x - x0, y - y0)
        self.odometry.update(self._wheel_angles())
        touching = self._touching()
        self._collisions += int(touching and not self._was_touching)
        self._was_touching = touching
        previous = self._distance
        self._distance = self._distance_at(x, y)
        arrived = math.hypot(x - self._goal[0], y - self._goal[1]) <= self.success_radius
        terminated = bool(a[2] > 0) if self.stop_action else arrived
        self._success = terminated and arrived

        reward = self.success_reward if self._success else 0.0
        if self.reward_kind == "geodesic" and math.isfinite(previous - self._distance):
            reward += previous - self._distance
        panorama = None
        if self.feature_field is None:
            gl.check_usable()
            panorama = self._camera.render(self.data)
        obs = self._observation(panorama, x, y)
        info = self._nav_info(x, y, yaw)
        self._show()
        return obs, float(reward), terminated, False, info

    def _marks(self) -> dict[str, Any]:
        """The rover's path since reset and the goal (a disc of ``success_radius``)."""
        if self._goal is None:
            return {}
        return {"path": self._path, "goal": self._goal, "goal_radius": self.success_radius}
