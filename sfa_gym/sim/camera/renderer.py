"""The omnidirectional camera's renderer: N pinhole views into one offscreen buffer, read
once and resampled onto the panorama with the remap tables of :mod:`.projection`."""

from __future__ import annotations

import math
import os
from typing import Any

import cv2
import numpy as np
from numpy.typing import NDArray

from sfa_gym.sim import gl

gl.configure()

import mujoco  # noqa: E402  (MUJOCO_GL must be set first)

from sfa_gym.sim.camera.fog import (  # noqa: E402
    airlight,
    apply_fog,
    check_visibility,
    ray_lengths,
)
from sfa_gym.sim.camera.projection import (  # noqa: E402
    _SMOOTH_SKY_STEP,
    PanoramaSpec,
    _layout,
    _remap_tables,
    _view_azimuths,
    _view_fovy_deg,
    heading_phases,
)
from sfa_gym.sim.camera.shadows import (  # noqa: E402
    MAP_TEXELS,
    SunShadows,
    without_light,
)

__all__ = ["OmniCamera", "headlight_to_eye", "sample_nearest"]


def _smooth_skyboxes(model: mujoco.MjModel) -> list[int]:
    """Ids of the skybox textures smooth enough to be sampled without filtering.

    MuJoCo samples every texture trilinearly (from mipmaps), and on llvmpipe the sky's
    cube-map lookups are then about a third of a panorama's cost. Where neighbouring texels
    differ by at most ``_SMOOTH_SKY_STEP`` grey level, the nearest texel of the full-size
    texture is within about a grey level of any filtered value (and the mip levels of a smooth
    gradient equal it), so nearest sampling gives the same pixels to within a grey level at
    about half the cost of the sky.
    """
    ids = []
    for tex in range(model.ntex):
        if model.tex_type[tex] != mujoco.mjtTexture.mjTEXTURE_SKYBOX:
            continue
        width, height = int(model.tex_width[tex]), int(model.tex_height[tex])
        channels = int(model.tex_nchannel[tex])
        if height != 6 * width or width < 2:
            continue  # not six square faces: leave it alone
        start = int(model.tex_adr[tex])
        faces = model.tex_data[start : start + width * height * channels]
        faces = faces.reshape(6, width, width, channels).astype(np.int16)
        step = max(int(np.abs(np.diff(faces, axis=axis)).max()) for axis in (1, 2))
        if step <= _SMOOTH_SKY_STEP:
            ids.append(tex)
    return ids


def sample_nearest(con: mujoco.MjrContext, textures: list[int]) -> None:
    """Make the current context sample the given skybox textures from their nearest texel."""
    if not textures:
        return
    from OpenGL import GL  # PyOpenGL comes with mujoco; its platform is set by now

    for tex in textures:
        if tex < con.ntexture and con.textureType[tex] == mujoco.mjtTexture.mjTEXTURE_SKYBOX:
            GL.glBindTexture(GL.GL_TEXTURE_CUBE_MAP, int(con.texture[tex]))
            for name in (GL.GL_TEXTURE_MIN_FILTER, GL.GL_TEXTURE_MAG_FILTER):
                GL.glTexParameteri(GL.GL_TEXTURE_CUBE_MAP, name, GL.GL_NEAREST)
    GL.glBindTexture(GL.GL_TEXTURE_CUBE_MAP, 0)


def headlight_to_eye(scn: mujoco.MjvScene) -> None:
    """Turn the scene's headlight into a light at the eye that shines in all directions.

    A headlight shines along the axis of whichever view renders, so a wall at the border of
    two views would be lit differently in each. Shining from the shared eye in all directions
    (a 180-degree spot: the classic renderer draws nothing for point-type lights) lights every
    view alike.
    """
    eye = 0.5 * (scn.camera[0].pos + scn.camera[1].pos)  # mono = mean of the stereo eyes
    for j in range(scn.nlight):
        light = scn.lights[j]
        if light.headlight:
            light.headlight = 0
            light.type = mujoco.mjtLightType.mjLIGHT_SPOT
            light.cutoff = 180.0
            light.exponent = 0.0
            light.pos[:] = eye
            light.attenuation[:] = (1.0, 0.0, 0.0)


def _cam_forward_up(quat: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    mat = np.empty(9)
    mujoco.mju_quat2Mat(mat, np.asarray(quat, dtype=np.float64))
    mat = mat.reshape(3, 3)
    return -mat[:, 2], mat[:, 1]


def _find_cameras(model: mujoco.MjModel, spec: PanoramaSpec, prefix: str) -> list[int]:
    """Ids of the cameras ``f"{prefix}{i}"``, checked against ``camera_mjcf(spec, prefix)``."""

    def exists(i: int) -> bool:
        return mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, f"{prefix}{i}") >= 0

    count = 0
    while exists(count):
        count += 1
    if count != spec.n_views:
        raise ValueError(
            f"the model has {count} cameras {prefix!r}0, 1, ... but spec.n_views is "
            f"{spec.n_views}; put camera_mjcf(spec, prefix={prefix!r}) inside the mast body"
        )
    expected_fovy = _view_fovy_deg(spec)
    ids = []
    for i, azimuth in enumerate(_view_azimuths(spec)):
        name = f"{prefix}{i}"
        cam_id = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, name)
        fovy = float(model.cam_fovy[cam_id])
        if not math.isclose(fovy, expected_fovy, rel_tol=1e-6):
            raise ValueError(
                f"camera {name!r} has fovy {fovy:g} deg but {spec} needs {expected_fovy:g}; "
                "build the cameras with camera_mjcf(spec) for this spec"
            )
        forward, up = _cam_forward_up(model.cam_quat[cam_id])
        want = np.array([math.cos(azimuth), math.sin(azimuth), 0.0])
        if not (np.allclose(forward, want, atol=1e-6) and np.allclose(up, [0, 0, 1], atol=1e-6)):
            raise ValueError(
                f"camera {name!r} looks along {np.round(forward, 4).tolist()} (up "
                f"{np.round(up, 4).tolist()}) in its body frame, expected "
                f"{np.round(want, 4).tolist()} (up [0, 0, 1]); use camera_mjcf(spec)"
            )
        if model.cam_mode[cam_id] != mujoco.mjtCamLight.mjCAMLIGHT_FIXED:
            raise ValueError(f"camera {name!r} must have mode 'fixed'")
        ids.append(cam_id)
    for cam_id in ids[1:]:
        if model.cam_bodyid[cam_id] != model.cam_bodyid[ids[0]] or not np.allclose(
            model.cam_pos[cam_id], model.cam_pos[ids[0]]
        ):
            raise ValueError(
                f"the cameras {prefix}0..{prefix}{spec.n_views - 1} must share one body and "
                "one position"
            )
    return ids


class OmniCamera:
    """Renders panoramas from the cameras that :func:`camera_mjcf` put on a body.

    Construction is cheap and creates no GL context: the context is created on the first
    :meth:`render`, so an env holding a camera can be built in a parent process and used in
    spawned or forked workers, provided the parent never rendered: OpenGL does not survive a
    fork (a forked child's first GL call would hang), so a camera first rendered in another
    process raises instead (use the ``spawn`` or ``forkserver`` start method). While creating
    the context, the model's ``vis.global_.offwidth/offheight`` and ``vis.quality.offsamples``
    are set to what the camera needs and then restored.

    Args:
        model: the MuJoCo model containing the cameras ``f"{prefix}{i}"``, ``i < n_views``.
        spec: panorama geometry; ``vfov_deg`` and ``n_views`` must match the cameras' MJCF.
        prefix: camera name prefix used with :func:`camera_mjcf`.
    Raises:
        ValueError: a camera is missing or its fovy, orientation or placement does not match
            ``camera_mjcf(spec, prefix)``; or the views need an offscreen buffer larger than
            OpenGL supports (the message gives the size and the limit).
    """

    def __init__(self, model: mujoco.MjModel, spec: PanoramaSpec, prefix: str = "omni") -> None:
        self._gl: Any = None
        self._con: mujoco.MjrContext | None = None
        self._owner_pid: int | None = None
        if not isinstance(spec, PanoramaSpec):
            raise TypeError(f"spec must be a PanoramaSpec, got {type(spec).__name__}")
        self.model = model
        self.spec = spec
        self.prefix = prefix
        self._cam_ids = _find_cameras(model, spec, prefix)
        self._layout = _layout(spec, float(model.cam_fovy[self._cam_ids[0]]))
        lay = self._layout
        # here, not at the first render: MuJoCo would fail there with a FatalError
        gl.check_framebuffer(lay.buffer_w, lay.buffer_h, str(spec))
        self._tan_half = ((lay.view_w / 2.0) / lay.focal, (lay.view_h / 2.0) / lay.focal)
        self._body_id = int(model.cam_bodyid[self._cam_ids[0]])
        azimuths = _view_azimuths(spec)
        self._view_cos_sin = (np.cos(azimuths)[:, None], np.sin(azimuths)[:, None])
        # Remap tables of the last heading phase (a standing or grid-stepping rover reuses them).
        self._maps: tuple[int, NDArray[Any], NDArray[Any]] | None = None
        # Skip, in each view, the geoms outside its frustum: same pixels, less geometry.
        self._cull = True
        self._cull_cache: tuple[int, list[Any], NDArray[np.intp], list[int]] | None = None
        self._smooth_skies = _smooth_skyboxes(model)
        self.visibility_m: float | None = None
        """fog's meteorological visibility (m), or None: clear air (:mod:`.fog`)"""
        self.shadows = False
        """the sun's cast shadows (:mod:`.shadows`); the model needs a light named 'sun'"""
        self._sun_shadows: SunShadows | None = None

    @property
    def smooth_skies(self) -> list[int]:
        """Ids of the skybox textures this camera samples from their nearest texel
        (:func:`sample_nearest`); empty where the GL state could not be set."""
        return list(self._smooth_skies)

    # -- GL resources ---------------------------------------------------------------------------

    def _ensure_context(self) -> None:
        gl.check_owner(self._owner_pid, "OmniCamera")
        if self._con is not None and self.shadows and self._con.offWidth < MAP_TEXELS:
            self.close()  # shadows switched on after the first render: a larger buffer
        if self._con is not None:
            gl.check_usable()
            self._gl.make_current()
            return
        lay, vis = self._layout, self.model.vis
        # the sun's depth map (shadows) is drawn into the same offscreen buffer
        side = MAP_TEXELS if self.shadows else 0
        if side:
            gl.check_framebuffer(side, side, f"{self.spec} with shadows")
        gl_context = gl.new_context(lay.buffer_w, lay.buffer_h, str(self.spec))
        # MjrContext sizes its offscreen buffer from the model. No MSAA: supersampling is
        # cheaper on a CPU rasteriser.
        saved = (vis.global_.offwidth, vis.global_.offheight, vis.quality.offsamples)
        try:
            vis.global_.offwidth = max(lay.buffer_w, side)
            vis.global_.offheight = max(lay.buffer_h, side)
            vis.quality.offsamples = 0
            con = mujoco.MjrContext(self.model, mujoco.mjtFontScale.mjFONTSCALE_50)
        except Exception:
            gl_context.free()
            raise
        finally:
            vis.global_.offwidth, vis.global_.offheight, vis.quality.offsamples = saved
        if con.offWidth < lay.buffer_w or con.offHeight < lay.buffer_h:
            con.free()
            gl_context.free()
            raise ValueError(
                f"{self.spec} needs a {lay.buffer_w}x{lay.buffer_h} offscreen buffer but OpenGL "
                f"gave {con.offWidth}x{con.offHeight}; use a smaller width/height/supersample"
            )
        try:
            sample_nearest(con, self._smooth_skies)
        except Exception:
            # Texture state is an optimisation: without it, MuJoCo's filtering stays (slower,
            # within a grey level of the same pixels).
            self._smooth_skies = []
        mujoco.mjr_setBuffer(mujoco.mjtFramebuffer.mjFB_OFFSCREEN, con)
        self._gl, self._con, self._owner_pid = gl_context, con, os.getpid()
        gl.track(self)
        self._init_scene()

    def _init_scene(self) -> None:
        model, lay = self.model, self._layout
        self._scene = mujoco.MjvScene(model, maxgeom=model.ngeom + 1000)
        flags = self._scene.flags
        # Shadows and reflections make a CPU rasteriser ~40x slower and would differ between
        # views; post-processing belongs to the Filament renderer and only costs time here.
        flags[mujoco.mjtRndFlag.mjRND_SHADOW] = 0
        flags[mujoco.mjtRndFlag.mjRND_REFLECTION] = 0
        flags[mujoco.mjtRndFlag.mjRND_POST_PROCESSING] = 0
        self._option = mujoco.MjvOption()
        self._option.sitegroup[:] = 0  # sites are markers, not things a camera sees
        self._perturb = mujoco.MjvPerturb()
        # the scene is built from camera 0 (eye and frustum); each view then turns it
        self._scene_camera = mujoco.MjvCamera()
        self._scene_camera.type = mujoco.mjtCamera.mjCAMERA_FIXED
        self._scene_camera.fixedcamid = self._cam_ids[0]
        self._rects = [
            mujoco.MjrRect(*lay.origin(i), lay.view_w, lay.view_h) for i in range(lay.n_views)
        ]
        self._full_rect = mujoco.MjrRect(0, 0, lay.buffer_w, lay.buffer_h)
        self._buffer = np.empty((lay.buffer_h, lay.buffer_w, 3), dtype=np.uint8)
        self._depth: NDArray[np.float32] | None = None  # read only in fog and with shadows
        self._unlit: NDArray[np.uint8] | None = None  # the views without the sun (shadows)
        self._ray_lengths: NDArray[np.float32] | None = None
        s = self.spec.supersample
        self._fine = np.empty((self.spec.height * s, self.spec.width * s, 3), dtype=np.uint8)
        # the panorama before the whole columns of the heading are rolled in
        self._resampled = np.empty((self.spec.height, self.spec.width, 3), dtype=np.uint8)
        self._cull_cache = None

    def _remap_maps(self, phase: int) -> tuple[NDArray[Any], NDArray[Any]]:
        """Fixed-point remap tables for a heading phase (see :func:`_remap_tables`)."""
        if self._maps is None or self._maps[0] != phase:
            map_x, map_y = _remap_tables(self.spec, self._layout, phase)
            # Fixed-point maps (1/32 pixel) make cv2.remap about twice as fast.
            self._maps = (phase, *cv2.convertMaps(map_x, map_y, cv2.CV_16SC2))
        return self._maps[1], self._maps[2]

    # -- rendering ------------------------------------------------------------------------------

    def _headlight_at_eye(self) -> None:
        headlight_to_eye(self._scene)

    def _cullable(self) -> tuple[list[Any], NDArray[np.intp], list[int]]:
        """The scene's model geoms with a finite bounding sphere: (mjvGeoms, geom ids, types).

        Cached while the scene holds as many geoms as before: it is rebuilt from the same
        model and options every frame, so its composition changes only with its size.
        """
        scn = self._scene
        if self._cull_cache is None or self._cull_cache[0] != scn.ngeom:
            geoms = []
            for j in range(scn.ngeom):
                g = scn.geoms[j]
                # Planes have no bounding sphere (rbound 0) and are drawn in every view.
                if g.objtype == mujoco.mjtObj.mjOBJ_GEOM and g.modelrbound > 0.0:
                    geoms.append(g)
            ids = np.array([g.objid for g in geoms], dtype=np.intp)
            self._cull_cache = (scn.ngeom, geoms, ids, [g.type for g in geoms])
        _, geoms, ids, types = self._cull_cache
        return geoms, ids, types

    def _view_frames(
        self, data: mujoco.MjData
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], int, int]:
        """Where the views look, and how the panorama is cut from them.

        Returns ``(eye, frames, shift, phase)``: the eye ``(3,)``; ``frames (n_views, 3, 3)``
        whose columns are each view's right, up and backward directions (a MuJoCo camera
        frame); the panorama is ``np.roll(P, -shift, axis=1)`` of the panorama ``P`` resampled
        with the tables of ``phase``.
        """
        eye = data.cam_xpos[self._cam_ids[0]].copy()
        if self.spec.views == "rover":
            return eye, data.cam_xmat[self._cam_ids].reshape(-1, 3, 3), 0, 0
        body = data.xmat[self._body_id].reshape(3, 3)
        heading_axis, up = body[:, 0], body[:, 2]
        # Compass axes in the mast's horizontal plane: world +x (or +y, should the mast point
        # along x) made perpendicular to the mast, and the axis 90 degrees counter-clockwise
        # of it. Upright, they are exactly world x and y, so the views are the same at every
        # heading.
        reference = np.array([1.0, 0.0, 0.0]) if abs(up[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
        compass_x = reference - (reference @ up) * up
        compass_x /= np.linalg.norm(compass_x)
        compass_y = np.cross(up, compass_x)
        heading = math.atan2(heading_axis @ compass_y, heading_axis @ compass_x)
        phases = heading_phases(self.spec)
        steps = round(heading / (2.0 * math.pi) * self.spec.width * phases)
        shift, phase = divmod(steps, phases)
        cos, sin = self._view_cos_sin
        forward = cos * compass_x + sin * compass_y
        frames = np.empty((len(forward), 3, 3))
        frames[:, :, 0] = np.cross(forward, up)
        frames[:, :, 1] = up
        frames[:, :, 2] = -forward
        return eye, frames, shift % self.spec.width, phase

    def _visibility(
        self,
        data: mujoco.MjData,
        eye: NDArray[np.float64],
        frames: NDArray[np.float64],
        ids: NDArray[np.intp],
    ) -> NDArray[np.bool_]:
        """``(n_views, G)``: may view ``i`` (frame ``frames[i]``) see geom ``ids[g]``?

        False when the geom's bounding sphere lies wholly outside one of the four side planes of
        the view's frustum or behind the camera.
        """
        rel = data.geom_xpos[ids] - eye  # (G, 3)
        local = rel @ frames  # (V, G, 3)
        x, y, depth = local[..., 0], local[..., 1], -local[..., 2]
        th, tv = self._tan_half
        radius = self.model.geom_rbound[ids]
        outside = (
            ((np.abs(x) - depth * th) > radius * math.sqrt(1.0 + th * th))
            | ((np.abs(y) - depth * tv) > radius * math.sqrt(1.0 + tv * tv))
            | (depth < -radius)
        )
        return ~outside

    def _render_views(
        self, data: mujoco.MjData, eye: NDArray[np.float64], frames: NDArray[np.float64]
    ) -> None:
        scn, con = self._scene, self._con
        changes: list[tuple[list[int], list[int]]] = [([], [])] * len(self._rects)
        hidden: list[int] = []
        geoms: list[Any] = []
        types: list[int] = []
        if self._cull:
            geoms, ids, types = self._cullable()
            if geoms:
                # Per view, the geoms to hide and to show again relative to the previous view.
                shown = np.ones(len(geoms), dtype=bool)
                changes = []
                for vis in self._visibility(data, eye, frames, ids):
                    hide, show = np.flatnonzero(shown & ~vis), np.flatnonzero(vis & ~shown)
                    changes.append((hide.tolist(), show.tolist()))
                    shown = vis
                hidden = np.flatnonzero(~shown).tolist()
        none = mujoco.mjtGeom.mjGEOM_NONE
        try:
            for i, rect in enumerate(self._rects):
                # Both eyes at the eye: the scene renders in mono; the frustum (fovy) is the
                # same for every view and was set by mjv_updateScene.
                for gl_camera in scn.camera:
                    gl_camera.pos[:] = eye
                    gl_camera.forward[:] = -frames[i, :, 2]
                    gl_camera.up[:] = frames[i, :, 1]
                hide, show = changes[i]
                for j in hide:
                    geoms[j].type = none
                for j in show:
                    geoms[j].type = types[j]
                mujoco.mjr_render(rect, scn, con)
        except BaseException:
            hidden = list(range(len(geoms)))
            raise
        finally:
            for j in hidden:
                geoms[j].type = types[j]

    def render(self, data: mujoco.MjData) -> NDArray[np.uint8]:
        """Render the panorama seen from the cameras' current pose.

        Args:
            data: simulation state of ``model``; camera and geom poses are read from it, so
                call ``mj_forward`` (or step) after moving things.
        Returns:
            ``(H, W, 3)`` uint8 RGB, C-contiguous, a new array on every call.
        """
        self._ensure_context()
        mujoco.mjr_setBuffer(mujoco.mjtFramebuffer.mjFB_OFFSCREEN, self._con)
        # The geoms are the same for every view: build the scene once (with view 0 as its
        # camera, which sets the frustum), then only turn the scene camera from viewport to
        # viewport.
        mujoco.mjv_updateScene(
            self.model,
            data,
            self._option,
            self._perturb,
            self._scene_camera,
            mujoco.mjtCatBit.mjCAT_ALL,
            self._scene,
        )
        self._headlight_at_eye()
        eye, frames, shift, phase = self._view_frames(data)
        sun = None
        if self.shadows:
            if self._sun_shadows is None:
                self._sun_shadows = SunShadows(self.model)
            sun = self._sun_shadows.scene_sun(self._scene)
            if sun is not None:
                self._sun_shadows.update(data, self._scene, self._con, eye)
        self._render_views(data, eye, frames)
        if self.visibility_m is None and sun is None:
            mujoco.mjr_readPixels(self._buffer, None, self._full_rect, self._con)
        else:
            self._read_depth()
            if sun is not None:
                self._apply_shadows(data, eye, frames, sun)
            if self.visibility_m is not None:
                self._apply_fog(data, check_visibility(self.visibility_m))
        map_x, map_y = self._remap_maps(phase)
        spec, resampled = self.spec, self._resampled
        if spec.supersample == 1:
            cv2.remap(self._buffer, map_x, map_y, cv2.INTER_LINEAR, dst=resampled)
        else:
            cv2.remap(self._buffer, map_x, map_y, cv2.INTER_LINEAR, dst=self._fine)
            size = (spec.width, spec.height)
            cv2.resize(self._fine, size, dst=resampled, interpolation=cv2.INTER_AREA)
        # Whole columns of the heading: column c looks where column c + shift of the resampled
        # panorama looks. The one copy also gives the caller a new array.
        return np.concatenate((resampled[:, shift:], resampled[:, :shift]), axis=1)

    def _read_depth(self) -> None:
        """Read the views' colours and depths."""
        lay = self._layout
        if self._depth is None:
            self._depth = np.empty((lay.buffer_h, lay.buffer_w), dtype=np.float32)
        mujoco.mjr_readPixels(self._buffer, self._depth, self._full_rect, self._con)

    def _clip_planes(self) -> tuple[float, float]:
        extent = float(self.model.stat.extent)
        return self.model.vis.map.znear * extent, self.model.vis.map.zfar * extent

    def _apply_fog(self, data: mujoco.MjData, visibility_m: float) -> None:
        """Blend each pixel towards the airlight by its distance
        (:func:`~sfa_gym.sim.camera.fog.apply_fog`)."""
        lay = self._layout
        assert self._depth is not None
        if self._ray_lengths is None:
            rects = [(*lay.origin(i), lay.view_w, lay.view_h) for i in range(lay.n_views)]
            self._ray_lengths = ray_lengths(lay.buffer_w, lay.buffer_h, rects, lay.focal)
        znear, zfar = self._clip_planes()
        air = airlight(self.model, data)
        apply_fog(self._buffer, self._depth, self._ray_lengths, znear, zfar, visibility_m, air)

    # -- shadows ---------------------------------------------------------------------------------

    def _apply_shadows(
        self, data: mujoco.MjData, eye: NDArray[np.float64], frames: NDArray[np.float64], sun: Any
    ) -> None:
        """Render the views again without the ``sun`` (a scene light) and show that render
        where the sun's depth map hides the pixel's surface point (:mod:`.shadows`)."""
        assert self._depth is not None and self._sun_shadows is not None
        if self._unlit is None:
            self._unlit = np.empty_like(self._buffer)
        with without_light(sun):
            self._render_views(data, eye, frames)
        mujoco.mjr_readPixels(self._unlit, None, self._full_rect, self._con)
        shadows = self._sun_shadows
        where = shadows.light_coordinates(
            self._depth, self._layout, eye, frames, *self._clip_planes()
        )
        np.copyto(self._buffer, self._unlit, where=shadows.shaded(*where)[..., None])

    # -- cleanup --------------------------------------------------------------------------------

    def close(self) -> None:
        """Free the GL context and its buffers; safe to call more than once.

        A later :meth:`render` creates a new context.
        """
        con, gl_context = self._con, self._gl
        self._con = self._gl = None
        gl.untrack(self)
        if self._owner_pid != os.getpid():
            return  # nothing created, or inherited through fork: the parent's to free
        self._owner_pid = None
        if con is not None:
            if gl_context is not None:
                gl_context.make_current()
            con.free()
        if gl_context is not None:
            gl_context.free()

    def __del__(self) -> None:
        # At interpreter shutdown the GL bindings may already be gone: nothing left to free.
        try:
            self.close()
        except Exception:
            pass
