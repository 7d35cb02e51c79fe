"""The envs' ``render()`` picture: the arena seen from the overhead camera, with marks on it.

:class:`TopDownView` renders the model's fixed camera ``"overhead"`` (straight down on the
arena; image right is world +x, image up is world +y) and draws marks into the MuJoCo scene
between ``update_scene`` and ``render``: the rover's path as a polyline of capsules and a goal
as a translucent disc with a line out of it along its heading. Drawn into the scene, the marks
lie on the ground under the camera's projection, hidden where the rover drives over them.
They live in this view's scene only: the panorama camera has its own scene and context, so
observations never see them.

:meth:`TopDownView.pixel` projects world points to the picture's pixels, for drawing one's own
marks on a frame or finding the goal in it.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from sfa_gym._checks import check_positive_int
from sfa_gym.sim import gl

gl.configure()

import mujoco  # noqa: E402  (MUJOCO_GL must be set first)

__all__ = ["GOAL_HEADING_RGBA", "GOAL_RGBA", "PATH_RGBA", "TopDownView"]

CAMERA = "overhead"
PATH_RGBA = (1.0, 0.85, 0.0, 1.0)
"""Colour of the rover's path: yellow, apart from every colour of the worlds' floors."""
GOAL_RGBA = (0.0, 1.0, 0.25, 0.6)
"""Colour of the goal's disc (translucent: the floor shows through)."""
GOAL_HEADING_RGBA = (0.0, 0.45, 0.1, 1.0)
"""Colour of the line from the goal's centre along its heading, out of the disc."""
# The path's capsules are this wide (m): about 2 px in the default 256 px picture of the
# 7 m arena. Marks float a little above the floor tile (its top is 1 mm up), under the rover.
PATH_WIDTH = 0.06
_PATH_Z = 0.012
_GOAL_Z = 0.008
_GOAL_HEADING = 0.15  # m, how far the heading line reaches out of the disc
# A long episode's path is drawn through at most this many evenly chosen points, so the marks
# never crowd the world's geoms out of the scene (MuJoCo's scene holds max_geom geoms).
MAX_PATH_POINTS = 400
_MAX_GEOM = 10000


class TopDownView:
    """The overhead camera's ``size x size`` RGB picture of ``model``, with marks.

    Construction only sizes the model's offscreen buffer (no OpenGL): the renderer and its GL
    context are created by the first :meth:`render`, in the process that renders.

    Args:
        model: the MuJoCo model; it must have a camera named ``"overhead"``.
        size: side of the square picture, pixels.
    """

    def __init__(self, model: mujoco.MjModel, size: int) -> None:
        check_positive_int("render_size", size)
        gl.check_framebuffer(size, size, f"render_size={size}")
        self.model = model
        self.size = size
        self.camera = int(model.camera(CAMERA).id)
        # the renderer draws into the model's offscreen buffer
        vis = model.vis.global_
        vis.offwidth, vis.offheight = max(vis.offwidth, size), max(vis.offheight, size)
        self._renderer: mujoco.Renderer | None = None

    def render(
        self,
        data: mujoco.MjData,
        path: NDArray[np.float64] | Sequence[Sequence[float]] | None = None,
        goal: Sequence[float] | None = None,
        goal_radius: float = 0.3,
    ) -> NDArray[np.uint8]:
        """The picture of ``data``'s state, ``(size, size, 3)`` uint8.

        Args:
            data: the state to show.
            path: ``(n, 2)`` world ``(x, y)`` points (m) drawn as a polyline; None or fewer
                than two points draw none.
            goal: ``(x, y, yaw)`` (m, rad) drawn as a disc of ``goal_radius`` with a line
                from its centre along ``yaw``; None draws none.
            goal_radius: the disc's radius, m.
        """
        gl.check_usable()
        if self._renderer is None:
            size = self.size
            # a driver of this process may have reported a smaller limit than the constant
            gl.check_framebuffer(size, size, f"render_size={size}")
            gl.load_llvm_users()
            self._renderer = mujoco.Renderer(self.model, size, size, max_geom=_MAX_GEOM)
        self._renderer.update_scene(data, camera=CAMERA)
        scene = self._renderer.scene
        if goal is not None:
            _draw_goal(scene, goal, goal_radius)
        if path is not None:
            _draw_path(scene, np.asarray(path, dtype=np.float64).reshape(-1, 2))
        return self._renderer.render()

    def pixel(self, points: Any, z: float = 0.0) -> NDArray[np.float64]:
        """``(n, 2)`` ``(row, column)`` pixel coordinates of world points ``(n, 2)`` ``(x, y)``
        at height ``z`` (m) in the picture; pixel ``(r, c)`` covers ``[r, r+1) x [c, c+1)``."""
        xy = np.asarray(points, dtype=np.float64).reshape(-1, 2)
        world = np.column_stack([xy, np.full(len(xy), float(z))])
        # the camera is fixed to the world body: its local frame is the world's
        rotation = np.zeros(9)
        mujoco.mju_quat2Mat(rotation, self.model.cam_quat[self.camera])
        local = (world - self.model.cam_pos[self.camera]) @ rotation.reshape(3, 3)
        # the camera looks along its -z axis; x is image right, y image up
        scale = (self.size / 2) / (-local[:, 2] * math.tan(math.radians(self._fovy) / 2))
        col = self.size / 2 + local[:, 0] * scale
        row = self.size / 2 - local[:, 1] * scale
        return np.column_stack([row, col])

    @property
    def _fovy(self) -> float:
        return float(self.model.cam_fovy[self.camera])

    def close(self) -> None:
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None


def _add_geom(scene: mujoco.MjvScene) -> mujoco.MjvGeom | None:
    """The scene's next free geom, counted in; None when the scene is full."""
    if scene.ngeom >= scene.maxgeom:
        return None
    geom = scene.geoms[scene.ngeom]
    scene.ngeom += 1
    return geom


def _init(geom: mujoco.MjvGeom, kind: int, rgba: Sequence[float]) -> None:
    mujoco.mjv_initGeom(
        geom, kind, np.zeros(3), np.zeros(3), np.eye(3).ravel(), np.asarray(rgba, np.float32)
    )
    geom.emission = 0.6  # keeps the colour under any light of the world
    geom.category = mujoco.mjtCatBit.mjCAT_DECOR


def _draw_goal(scene: mujoco.MjvScene, goal: Sequence[float], radius: float) -> None:
    x, y, yaw = (float(v) for v in goal)
    disc = _add_geom(scene)
    if disc is not None:
        _init(disc, mujoco.mjtGeom.mjGEOM_CYLINDER, GOAL_RGBA)
        disc.size[:] = (radius, radius, 0.002)
        disc.pos[:] = (x, y, _GOAL_Z)
    heading = _add_geom(scene)
    if heading is not None:
        _init(heading, mujoco.mjtGeom.mjGEOM_CAPSULE, GOAL_HEADING_RGBA)
        reach = radius + _GOAL_HEADING
        tip = np.array([x + reach * math.cos(yaw), y + reach * math.sin(yaw), _PATH_Z])
        centre = np.array([x, y, _PATH_Z])
        mujoco.mjv_connector(heading, mujoco.mjtGeom.mjGEOM_CAPSULE, PATH_WIDTH / 2, centre, tip)


def _draw_path(scene: mujoco.MjvScene, points: NDArray[np.float64]) -> None:
    if len(points) > MAX_PATH_POINTS:
        points = points[np.linspace(0, len(points) - 1, MAX_PATH_POINTS).round().astype(int)]
    ends = np.column_stack([points, np.full(len(points), _PATH_Z)])
    for start, end in zip(ends[:-1], ends[1:], strict=True):
        if np.array_equal(start, end):
            continue  # the rover stood still: a segment without a direction
        geom = _add_geom(scene)
        if geom is None:
            return
        _init(geom, mujoco.mjtGeom.mjGEOM_CAPSULE, PATH_RGBA)
        mujoco.mjv_connector(geom, mujoco.mjtGeom.mjGEOM_CAPSULE, PATH_WIDTH / 2, start, end)
