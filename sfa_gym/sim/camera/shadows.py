"""Shadows that the sun casts, moving with the clock: a shadow map applied to the views.

MuJoCo's own shadow maps make the software rasteriser about 40x slower (its soft-shadow
sampling runs in every fragment of every view), so the camera does the classic two steps
itself, with the rasteriser for the geometry and numpy for the test:

1. **The sun's depth map** of the static scene (buildings, parked cars, trees, lamp posts,
   fences, bushes, curbs, the ground): one orthographic render looking along the sun's rays
   over the world's extent, redrawn when the sun has moved by :data:`DIRECTION_STEP_DEG`
   (every 10-20 s of the clock), so that the same sun gives the same pixels whatever came
   before; and a second, smaller map of the moving bodies (the rover itself, the people,
   cyclists and cars) within :data:`MOVING_HALF_WIDTH_M` of the camera, redrawn every frame.
2. **Each view twice**, with and without the sun's light. A pixel whose surface point lies
   behind either map's surface, seen from the sun, shows the second render: the same
   surface lit by the sky and the fill lights only. Both renders use MuJoCo's lighting, so a
   shaded surface is exactly that surface without the sun (faces turned from the sun do not
   change), on walls, cars and the ground alike. The map's depth is interpolated between its
   texels; the panorama's resampling softens the shadows' edges.

Every part is a pure function of the scene and the sun, so shadows keep the camera
deterministic. Under an overcast sky or at night the sun has no light to take away and the
second render is skipped.

Not modelled: shadows of movers farther than :data:`MOVING_HALF_WIDTH_M` from the camera, and
the sun's half-degree penumbra (1 cm per metre of height) beyond the maps' texels
(:data:`MAP_TEXELS` over the world's extent: about 4 cm in the outdoor world). Light through
see-through crowns in winter is blocked as by leaves: the map records the first surface.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from contextlib import contextmanager
from typing import TYPE_CHECKING, Any

import cv2
import numpy as np
from numpy.typing import NDArray

from sfa_gym._checks import check_int_in
from sfa_gym.sim.camera.fog import eye_depths

if TYPE_CHECKING:  # imported where used: MUJOCO_GL must be set before mujoco is imported
    import mujoco

__all__ = [
    "DIRECTION_STEP_DEG",
    "MAP_TEXELS",
    "SunShadows",
    "without_light",
]

DIRECTION_STEP_DEG = 0.05
"""The depth map is drawn for the sun's azimuth and elevation rounded to this step (degrees):
the sun moves about 0.25 degrees a minute."""

MAP_TEXELS = 2048
"""Side of the sun's depth map, texels, over twice the world's extent (``model.stat.extent``)."""

MOVING_TEXELS = 256
"""Side of the moving bodies' depth map, texels (about 5 cm each)."""

MOVING_HALF_WIDTH_M = 6.0
"""The moving bodies' map covers this many metres either side of the camera: the rover's own
shadow and those of the movers near it; a mover farther away casts none."""

_BIAS_M = 0.02  # a surface is in shadow only this far (m) behind the map's, plus the slope term
_SLOPE_BIAS = 1.5  # times the map's largest depth step between neighbouring texels
_FAR = 1.0e9  # a distance no point reaches: lit


_GL_CAMERA = (
    "pos",
    "forward",
    "up",
    "frustum_center",
    "frustum_width",
    "frustum_bottom",
    "frustum_top",
    "frustum_near",
    "frustum_far",
    "orthographic",
)
"""The fields of a scene camera (``mujoco.MjvGLCamera``) that the depth map's render sets."""


def _copy(value: Any) -> Any:
    return value.copy() if isinstance(value, np.ndarray) else value


def _set_camera(camera: Any, fields: dict[str, Any]) -> None:
    for name, value in fields.items():
        if isinstance(getattr(camera, name), np.ndarray):
            getattr(camera, name)[:] = value
        else:
            setattr(camera, name, value)


class SunShadows:
    """The sun's depth map of a model's static scene, and the shadow test of points.

    Args:
        model: a compiled model with a light named ``"sun"``; its geoms of the world body are
            the static scene, centred on the origin within ``model.stat.extent``.
        texels: the static scene's depth map's side.
        moving_texels: the side of the moving bodies' map (:data:`MOVING_HALF_WIDTH_M` either
            side of the camera).

    Raises:
        ValueError: the model has no light named ``"sun"``, or ``texels`` or
            ``moving_texels`` is not an int >= 16.
    """

    def __init__(
        self, model: mujoco.MjModel, texels: int = MAP_TEXELS, moving_texels: int = MOVING_TEXELS
    ) -> None:
        import mujoco

        for name, value in (("texels", texels), ("moving_texels", moving_texels)):
            check_int_in(name, value, 16)
        self.sun = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_LIGHT, "sun")
        if self.sun < 0:
            raise ValueError("shadows need the sun: the model has no light named 'sun'")
        self.model = model
        self.texels = texels
        self.half_width = float(model.stat.extent)
        self._static = np.asarray(model.geom_bodyid) == 0
        self._key: tuple[int, int] | None = None
        self._frame: NDArray[np.float64] | None = None  # rows: right, up, forward (to the ground)
        self._origin: NDArray[np.float64] | None = None  # the map camera's eye
        # the distance along the rays (m) beyond which a point is in shadow, per texel
        self._threshold: NDArray[np.float32] | None = None
        self.moving_texels = moving_texels
        # the moving bodies' map (redrawn every frame) and its camera's eye
        self._moving: NDArray[np.float32] | None = None
        self._moving_origin: NDArray[np.float64] | None = None

    def scene_sun(self, scene: mujoco.MjvScene) -> Any:
        """The ``scene``'s light of the sun while it shines; None at night or under an overcast
        sky (no direct light to take away) or when the scene has no such light."""
        for k in range(scene.nlight):
            light = scene.lights[k]
            if light.id == self.sun and not light.headlight:
                return light if float(np.max(light.diffuse)) > 0.0 else None
        return None

    # -- the map --------------------------------------------------------------------------------

    def _ray(self, data: mujoco.MjData) -> tuple[tuple[int, int], NDArray[np.float64]]:
        """The sun's rays, rounded (module docstring): ``(key, unit direction)``."""
        d = np.asarray(data.light_xdir[self.sun], dtype=np.float64)
        step = math.radians(DIRECTION_STEP_DEG)
        az = round(math.atan2(d[1], d[0]) / step)
        el = round(math.asin(max(-1.0, min(1.0, d[2] / max(np.linalg.norm(d), 1e-12)))) / step)
        a, e = az * step, el * step
        return (az, el), np.array(
            [math.cos(e) * math.cos(a), math.cos(e) * math.sin(a), math.sin(e)]
        )

    def update(
        self,
        data: mujoco.MjData,
        scene: mujoco.MjvScene,
        context: mujoco.MjrContext,
        centre: NDArray[np.float64] | None = None,
    ) -> None:
        """Redraw the static scene's depth map if the sun has moved, and the moving bodies' map
        around ``centre`` (the camera's eye, world; None: no moving bodies' shadows), with
        ``scene`` (updated for ``data``) and ``context`` (current, with an offscreen buffer of
        at least :attr:`texels` and :attr:`moving_texels` a side). The scene's cameras and
        geoms are left as they were."""
        key, ray = self._ray(data)
        if key != self._key:
            forward = ray
            up = np.array([0.0, 0.0, 1.0]) - forward[2] * forward
            if np.linalg.norm(up) < 1e-6:  # the sun in the zenith
                up = np.array([0.0, 1.0, 0.0])
            up /= np.linalg.norm(up)
            self._frame = np.stack([np.cross(forward, up), up, forward])
            self._origin = -2.0 * self.half_width * forward  # the extent lies in [near, far]
            self._threshold = self._draw(scene, context, self._origin, self.half_width, True)
            self._key = key
        self._moving = None
        if centre is not None and self.moving_texels:
            # the moving bodies' map: centred on the camera, on the static map's rays
            centre = np.asarray(centre, dtype=np.float64)
            assert self._origin is not None
            forward = self._axes()[2]
            across = (centre - self._origin) - ((centre - self._origin) @ forward) * forward
            self._moving_origin = self._origin + across
            self._moving = self._draw(
                scene, context, self._moving_origin, MOVING_HALF_WIDTH_M, False
            )

    def _draw(
        self,
        scene: mujoco.MjvScene,
        context: mujoco.MjrContext,
        origin: NDArray[np.float64],
        half: float,
        static: bool,
    ) -> NDArray[np.float32]:
        """The shadow threshold per texel (distance along the rays, m, bias added) of the
        static geoms (``static``) or of the moving ones, seen along the sun's rays from
        ``origin`` over ``half`` metres either side."""
        import mujoco

        n = self.texels if static else self.moving_texels
        right, up, forward = self._axes()
        near, far = 0.01 * self.half_width, 4.0 * self.half_width
        saved_cameras = [
            {name: _copy(getattr(c, name)) for name in _GL_CAMERA} for c in scene.camera
        ]
        hidden = []
        none = mujoco.mjtGeom.mjGEOM_NONE
        for j in range(scene.ngeom):
            g = scene.geoms[j]
            is_geom = g.objtype == mujoco.mjtObj.mjOBJ_GEOM
            fixed = is_geom and self._static[g.objid]
            keep = fixed if static else is_geom and not fixed
            if not keep and g.type != none:
                hidden.append((g, g.type))
                g.type = none
        skybox = scene.flags[mujoco.mjtRndFlag.mjRND_SKYBOX]
        try:
            scene.flags[mujoco.mjtRndFlag.mjRND_SKYBOX] = 0
            map_camera = {
                "pos": origin,
                "forward": forward,
                "up": up,
                "frustum_center": 0.0,
                "frustum_width": half,
                "frustum_bottom": -half,
                "frustum_top": half,
                "frustum_near": near,
                "frustum_far": far,
                "orthographic": 1,
            }
            for c in scene.camera:
                _set_camera(c, map_camera)
            rect = mujoco.MjrRect(0, 0, n, n)
            mujoco.mjr_render(rect, scene, context)
            depth = np.empty((n, n), dtype=np.float32)
            mujoco.mjr_readPixels(None, depth, rect, context)
        finally:
            scene.flags[mujoco.mjtRndFlag.mjRND_SKYBOX] = skybox
            for g, kind in hidden:
                g.type = kind
            for c, saved in zip(scene.camera, saved_cameras, strict=True):
                _set_camera(c, saved)
        # an orthographic depth buffer is linear in the distance along the rays
        distance = (near + depth * (far - near)).astype(np.float32)
        step = np.zeros_like(distance)
        step[:, :-1] = np.abs(np.diff(distance, axis=1))
        step[:-1, :] = np.maximum(step[:-1, :], np.abs(np.diff(distance, axis=0)))
        # a neighbour across an edge is no slope: a texel's bias is at most a few texels' worth
        texel = 2.0 * half / n
        step = np.minimum(step, 8.0 * texel)
        bias = (_BIAS_M + _SLOPE_BIAS * step).astype(np.float32)
        bias[depth >= 1.0] = _FAR  # nothing there: lit
        return distance + bias

    # -- the test -------------------------------------------------------------------------------

    def light_coordinates(
        self,
        depth: NDArray[np.float32],
        layout: Any,
        eye: NDArray[np.float64],
        frames: NDArray[np.float64],
        znear: float,
        zfar: float,
    ) -> tuple[NDArray[np.float32], NDArray[np.float32], NDArray[np.float32]]:
        """Where each pixel's surface point lies in the depth map: ``(column, row, distance
        along the rays)``, each ``(H, W)`` (texels, texels, m).

        Args:
            depth: the views' depth buffer, window depth of a perspective projection from
                ``znear`` to ``zfar`` (m), as read back (row 0 at the bottom); laid out by
                ``layout`` (the camera's views side by side, their focal length in pixels).
            eye: the views' eye, world.
            frames: ``(n_views, 3, 3)``, each view's right, up and backward directions
                (columns).
        """
        lay = layout
        eye_depth = eye_depths(depth, znear, zfar)
        # a pixel's point is eye + z (u right + v up - backward), so each of its coordinates
        # along the map's axes is a + z (u b + v c - d) with a scalar a, b, c, d per view
        offset = self.to_map(eye[None])[0]
        scale = self._scale()
        out = np.full((3, lay.buffer_h, lay.buffer_w), -1.0e6, dtype=np.float32)
        u = ((np.arange(lay.view_w) + 0.5 - lay.view_w / 2.0) / lay.focal).astype(np.float32)
        v = ((np.arange(lay.view_h) + 0.5 - lay.view_h / 2.0) / lay.focal).astype(np.float32)
        for i in range(lay.n_views):
            left, bottom = lay.origin(i)
            rows, cols = slice(bottom, bottom + lay.view_h), slice(left, left + lay.view_w)
            axes = (frames[i].T @ self._axes().T) * scale  # rows: right, up, backward
            z = eye_depth[rows, cols]
            for k in range(3):
                b, c, d = (np.float32(x) for x in axes[:, k])
                out[k, rows, cols] = offset[k] + z * (u[None, :] * b + v[:, None] * c - d)
        return out[0], out[1], out[2]

    def _axes(self) -> NDArray[np.float64]:
        if self._frame is None:
            raise RuntimeError("SunShadows.update() has not drawn a depth map yet")
        return self._frame

    def _scale(self) -> NDArray[np.float64]:
        per_texel = self.texels / (2.0 * self.half_width)
        return np.array([per_texel, per_texel, 1.0])

    def to_map(self, points: NDArray[np.float64]) -> NDArray[np.float64]:
        """World points ``(n, 3)`` (m) in the depth map: ``(n, 3)`` columns, rows (texels;
        texel ``i`` spans ``[i - 0.5, i + 0.5)``) and distance along the rays (m)."""
        assert self._origin is not None
        shift = np.array([self.texels / 2.0 - 0.5, self.texels / 2.0 - 0.5, 0.0])
        return ((np.asarray(points) - self._origin) @ self._axes().T) * self._scale() + shift

    def in_shadow(self, points: NDArray[np.float64]) -> NDArray[np.bool_]:
        """Which world points ``(n, 3)`` (m) lie in the sun's shadow (:meth:`shaded`)."""
        where = self.to_map(np.asarray(points, dtype=np.float64).reshape(-1, 3))
        return self.shaded(*(where.T.astype(np.float32)[:, :, None]))[:, 0]

    def shaded(
        self, column: NDArray[np.float32], row: NDArray[np.float32], distance: NDArray[np.float32]
    ) -> NDArray[np.bool_]:
        """Which points (:meth:`light_coordinates`) lie behind the static scene's or a moving
        body's surface, seen from the sun: in its shadow. The maps' depth is interpolated
        between texels; points outside a map are lit by it."""
        if self._threshold is None:
            raise RuntimeError("SunShadows.update() has not drawn a depth map yet")
        out = distance > _lookup(self._threshold, column, row)
        if self._moving is not None:
            assert self._origin is not None and self._moving_origin is not None
            # the same rays, another origin across them and another texel size
            ratio = np.float32(
                self.moving_texels * self.half_width / (self.texels * MOVING_HALF_WIDTH_M)
            )
            shift = (self._moving_origin - self._origin) @ self._axes()[:2].T
            shift *= self.moving_texels / (2.0 * MOVING_HALF_WIDTH_M)
            centre, moving_centre = self.texels / 2.0 - 0.5, self.moving_texels / 2.0 - 0.5
            col = (column - np.float32(centre)) * ratio + np.float32(moving_centre - shift[0])
            row_ = (row - np.float32(centre)) * ratio + np.float32(moving_centre - shift[1])
            out |= distance > _lookup(self._moving, col, row_)
        return out


def _lookup(
    threshold: NDArray[np.float32], column: NDArray[np.float32], row: NDArray[np.float32]
) -> NDArray[np.float32]:
    """A map's threshold at the texel coordinates, interpolated; beyond the map: lit."""
    return cv2.remap(
        threshold, column, row, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT, borderValue=_FAR
    )


@contextmanager
def without_light(light: Any) -> Iterator[None]:
    """A scene light (``mujoco.MjvLight``) switched off (no diffuse or specular light) for the
    duration, then restored."""
    diffuse, specular = light.diffuse.copy(), light.specular.copy()
    try:
        light.diffuse[:] = 0.0
        light.specular[:] = 0.0
        yield
    finally:
        light.diffuse[:], light.specular[:] = diffuse, specular
