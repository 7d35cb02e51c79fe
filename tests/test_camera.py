"""Omnidirectional camera: spec validation, MJCF cameras, and the geometry of real renders.

The scene is built here (textured floor and walls, coloured boxes around a mocap body that
carries the cameras), independent of the env's worlds.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sfa_gym.sim import gl

gl.configure()

import mujoco  # noqa: E402

from sfa_gym.sim.camera.projection import (  # noqa: E402
    PanoramaSpec,
    _layout,
    _remap_tables,
    _view_fovy_deg,
    camera_mjcf,
    heading_phases,
)
from sfa_gym.sim.camera.renderer import OmniCamera, _smooth_skyboxes  # noqa: E402

CAM_HEIGHT = 0.5
# Small panoramas keep the tests fast; 144 = 4 sectors of 36 columns.
SPEC = PanoramaSpec(width=144, height=20, vfov_deg=40.0, n_views=4, supersample=2)
RED_AT = (0.0, 3.0, CAM_HEIGHT + 0.55)  # azimuth +90 deg, above the horizon
BLUE_AT = (-3.2, 0.0, CAM_HEIGHT - 0.2)  # azimuth 180 deg


COARSE_SKY = (
    '<texture type="skybox" builtin="gradient" rgb1=".5 .7 1" rgb2=".9 .9 1" width="64" '
    'height="384"/>'
)
# 256 texels a face: neighbouring texels differ by at most one grey level.
SMOOTH_SKY = COARSE_SKY.replace('width="64" height="384"', 'width="256" height="1536"')
SPECKLED_SKY = SMOOTH_SKY.replace("/>", ' mark="random" random="0.02" markrgb="1 1 1"/>')


def scene_xml(spec: PanoramaSpec, n_boxes: int = 20, seed: int = 0, sky: str = COARSE_SKY) -> str:
    """Walled room with a textured floor, random grey-ish boxes and two marker boxes."""
    rng = np.random.default_rng(seed)
    boxes = []
    for i in range(n_boxes):
        azimuth = 2 * np.pi * (i + 0.5) / n_boxes + rng.uniform(-0.08, 0.08)
        dist = rng.uniform(1.8, 3.6)
        if min(abs(azimuth - np.pi / 2), abs(azimuth - np.pi)) < 0.25:
            continue  # keep the marker boxes unobstructed
        hx, hy, hz = rng.uniform(0.08, 0.25, 2).tolist() + [rng.uniform(0.2, 0.7)]
        rgb = rng.uniform(0.15, 0.6, 3)
        rgb[0] = min(rgb[0], rgb[1])  # no strongly red distractors
        boxes.append(
            f'<geom type="box" pos="{dist * np.cos(azimuth):.4f} {dist * np.sin(azimuth):.4f} '
            f'{hz:.4f}" size="{hx:.4f} {hy:.4f} {hz:.4f}" '
            f'rgba="{rgb[0]:.3f} {rgb[1]:.3f} {rgb[2]:.3f} 1"/>'
        )
    walls = "".join(
        f'<geom type="box" pos="{x} {y} 1" size="{sx} {sy} 1" material="wall"/>'
        for x, y, sx, sy in [(5, 0, 0.1, 5), (-5, 0, 0.1, 5), (0, 5, 5, 0.1), (0, -5, 5, 0.1)]
    )
    return f"""
<mujoco>
  <visual><quality shadowsize="0"/></visual>
  <asset>
    <texture name="floor" type="2d" builtin="checker" rgb1=".2 .3 .4" rgb2=".8 .8 .7"
             width="64" height="64"/>
    <material name="floor" texture="floor" texrepeat="10 10"/>
    <texture name="wall" type="2d" builtin="checker" rgb1=".7 .6 .3" rgb2=".3 .5 .6"
             width="64" height="64"/>
    <material name="wall" texture="wall" texrepeat="6 2"/>
    {sky}
  </asset>
  <worldbody>
    <light directional="true" dir="-0.3 -0.5 -1" castshadow="false"/>
    <geom type="plane" size="5 5 1" material="floor"/>
    {walls}
    {"".join(boxes)}
    <geom name="red" type="box" pos="{" ".join(map(str, RED_AT))}" size=".25 .25 .15"
          rgba="1 0 0 1"/>
    <geom name="blue" type="box" pos="{" ".join(map(str, BLUE_AT))}" size=".3 .3 .3"
          rgba="0 0 1 1"/>
    <body name="mast" mocap="true" pos="0 0 {CAM_HEIGHT}">
      {camera_mjcf(spec)}
    </body>
  </worldbody>
</mujoco>"""


def make_scene(
    spec: PanoramaSpec = SPEC, sky: str = COARSE_SKY
) -> tuple[mujoco.MjModel, mujoco.MjData]:
    model = mujoco.MjModel.from_xml_string(scene_xml(spec, sky=sky))
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    return model, data


def set_pose(model: mujoco.MjModel, data: mujoco.MjData, x: float, y: float, yaw: float) -> None:
    data.mocap_pos[0] = (x, y, CAM_HEIGHT)
    data.mocap_quat[0] = (math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2))
    mujoco.mj_forward(model, data)


@pytest.fixture(scope="module")
def scene():
    model, data = make_scene()
    camera = OmniCamera(model, SPEC)
    yield model, data, camera
    camera.close()


def mad(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.abs(a.astype(np.float64) - b.astype(np.float64)).mean())


# -- spec ---------------------------------------------------------------------------------------


def test_presets_and_defaults():
    assert (PanoramaSpec().width, PanoramaSpec().height) == (350, 40)
    assert (PanoramaSpec.paper_sim().width, PanoramaSpec.paper_sim().height) == (350, 40)
    assert (PanoramaSpec.paper_outdoor().width, PanoramaSpec.paper_outdoor().height) == (600, 60)


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("width", 0),
        ("width", -5),
        ("width", 3.5),
        ("width", True),
        ("height", 0),
        ("n_views", 2),
        ("n_views", 65),
        ("supersample", 0),
        ("supersample", 9),
        ("vfov_deg", 0.0),
        ("vfov_deg", -10.0),
        ("vfov_deg", 151.0),
        ("vfov_deg", "40"),
        ("views", "world"),
    ],
)
def test_bad_spec_names_field_and_value(field, value):
    with pytest.raises(ValueError) as err:
        PanoramaSpec(**{field: value})
    assert field in str(err.value) and repr(value) in str(err.value)


@settings(max_examples=40, deadline=None)
@given(
    width=st.integers(1, 700),
    height=st.integers(1, 70),
    vfov=st.floats(1.0, 150.0),
    n_views=st.integers(3, 12),
    supersample=st.integers(1, 3),
    phase=st.floats(0.0, 1.0, exclude_max=True),
)
def test_remap_samples_stay_inside_the_views(width, height, vfov, n_views, supersample, phase):
    spec = PanoramaSpec(width, height, vfov, n_views, supersample)
    layout = _layout(spec, _view_fovy_deg(spec))
    phase = int(phase * heading_phases(spec))  # any fraction of a column of heading
    map_x, map_y = _remap_tables(spec, layout, phase)  # raises if a sample leaves its view
    assert map_x.shape == map_y.shape == (height * supersample, width * supersample)
    assert 0 <= map_x.min() and map_x.max() <= layout.buffer_w - 1
    assert 0 <= map_y.min() and map_y.max() <= layout.buffer_h - 1


# -- MJCF cameras -------------------------------------------------------------------------------


@pytest.mark.parametrize("n_views", [3, 4, 7])
def test_camera_mjcf_looks_along_the_azimuths(n_views):
    spec = PanoramaSpec(n_views=n_views, vfov_deg=30.0)
    model = mujoco.MjModel.from_xml_string(
        f'<mujoco><worldbody><body name="mast" pos="1 2 0.5" euler="0 0 30">'
        f"{camera_mjcf(spec, prefix='cam')}</body></worldbody></mujoco>"
    )
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    assert model.ncam == n_views
    heading = math.radians(30.0)
    for i in range(n_views):
        cam_id = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, f"cam{i}")
        frame = data.cam_xmat[cam_id].reshape(3, 3)
        azimuth = heading + 2 * math.pi * i / n_views
        np.testing.assert_allclose(
            -frame[:, 2], [math.cos(azimuth), math.sin(azimuth), 0], atol=1e-9
        )
        np.testing.assert_allclose(frame[:, 1], [0, 0, 1], atol=1e-9)
        np.testing.assert_allclose(data.cam_xpos[cam_id], [1, 2, 0.5], atol=1e-12)
        # The fovy covers the cylinder's top edge even at the sector's side.
        half = math.radians(model.cam_fovy[cam_id] / 2)
        needed = math.tan(math.radians(15.0)) / math.cos(math.pi / n_views)
        assert math.tan(half) > needed


def test_camera_rejects_models_that_do_not_match_the_spec():
    model, _ = make_scene()
    with pytest.raises(ValueError, match="4 cameras 'omni'.*n_views is 6"):
        OmniCamera(model, PanoramaSpec(width=144, height=20, n_views=6))
    with pytest.raises(ValueError, match="fovy"):
        OmniCamera(model, PanoramaSpec(width=144, height=20, vfov_deg=60.0))
    with pytest.raises(ValueError, match="0 cameras 'pano'"):
        OmniCamera(model, SPEC, prefix="pano")


# -- rendering ----------------------------------------------------------------------------------


def test_render_shape_dtype_and_determinism(scene):
    model, data, camera = scene
    set_pose(model, data, 0.3, -0.2, 0.4)
    first = camera.render(data)
    assert first.shape == (SPEC.height, SPEC.width, 3)
    assert first.dtype == np.uint8 and first.flags.c_contiguous
    assert first.std() > 10  # a real image, not a blank buffer
    again = camera.render(data)
    assert again is not first
    np.testing.assert_array_equal(first, again)
    other = OmniCamera(model, SPEC)
    try:
        np.testing.assert_array_equal(first, other.render(data))
    finally:
        other.close()


def test_no_black_views(scene):
    """Every view contributes lit pixels (no view left black by a bad viewport or light)."""
    model, data, camera = scene
    set_pose(model, data, 0.0, 0.0, 0.0)
    pano = camera.render(data).astype(np.float64)
    sector = SPEC.width // SPEC.n_views
    for i in range(SPEC.n_views):
        cols = (np.arange(sector) + i * sector - sector // 2) % SPEC.width
        assert pano[:, cols].mean() > 60, f"view {i} is dark"


# The equivariance target (issue "rotation-equivariant panoramas"): after turning by whole
# columns and shifting back, no row differs by more than this on average (grey levels).
ROW_TOLERANCE = 2.0


def turned_pair(model, data, camera, k: float, x=0.4, y=-0.3, yaw=0.3):
    """Panoramas at one position before and after turning by ``k`` columns."""
    set_pose(model, data, x, y, yaw)
    base = camera.render(data)
    set_pose(model, data, x, y, yaw + 2 * math.pi * k / camera.spec.width)
    return base, camera.render(data)


def row_errors(base: np.ndarray, turned: np.ndarray, k: int) -> np.ndarray:
    return np.abs(np.roll(turned, k, axis=1).astype(np.float64) - base).mean(axis=(1, 2))


@pytest.mark.parametrize("k", [1, 5, 13, 18, 36, 50, 72, 100])
def test_turning_by_whole_columns_shifts_the_panorama_exactly(scene, k):
    """Yaw +2*pi*k/W gives np.roll(pano, -k, axis=1), pixel for pixel, for every k: the
    views look along fixed compass directions, so the rendered pixels do not depend on the
    heading (36 and 72 are a quarter and half a turn; 18 is half a view)."""
    model, data, camera = scene
    base, turned = turned_pair(model, data, camera, k)
    np.testing.assert_array_equal(turned, np.roll(base, -k, axis=1))


def test_views_that_turn_with_the_rover_miss_the_row_tolerance(scene):
    """The same check fails for the old camera (views turning with the rover) wherever a turn
    is not a multiple of a quarter: edges near the horizon are anti-aliased differently. A
    quarter turn maps its views onto each other and stays exact."""
    model, data, _ = scene
    rover = OmniCamera(model, dataclasses.replace(SPEC, views="rover"))
    try:
        worst = [row_errors(*turned_pair(model, data, rover, k), k).max() for k in (5, 13, 50)]
        assert max(worst) > ROW_TOLERANCE
        base, turned = turned_pair(model, data, rover, 36, yaw=0.0)
        assert row_errors(base, turned, 36).max() < 0.01  # a few values off by one
    finally:
        rover.close()


def test_fractions_of_a_column_move_the_panorama_smoothly(scene):
    """Turning by a fraction of a column resamples the same views a little further on. No
    sampled panorama can be shifted by a fraction of a column exactly; linear interpolation
    between its neighbours' shifts explains it as well as it explains a reference camera's
    (8 views, 4x supersampling), and better than the old camera's. The smallest heading step
    the camera resolves changes it by much less than a column."""
    model, data, camera = scene
    spec8 = dataclasses.replace(SPEC, n_views=8, supersample=4)
    model8, data8 = make_scene(spec8)
    reference = OmniCamera(model8, spec8)
    rover = OmniCamera(model, dataclasses.replace(SPEC, views="rover"))

    def interpolation_error(m, d, cam, frac: float) -> float:
        base, turned = turned_pair(m, d, cam, 3 + frac)
        between = (1 - frac) * np.roll(base, -3, axis=1) + frac * np.roll(base, -4, axis=1)
        return float(np.abs(turned - between).mean())

    try:
        for frac in (0.25, 0.5):
            ours = interpolation_error(model, data, camera, frac)
            assert ours < 1.1 * interpolation_error(model8, data8, reference, frac)
            assert ours < 0.9 * interpolation_error(model, data, rover, frac)
    finally:
        reference.close()
        rover.close()
    base, turned = turned_pair(model, data, camera, 1 / heading_phases(SPEC))
    assert mad(base, turned) < 0.1 * mad(base, np.roll(base, -1, axis=1))


def test_a_tilted_mast_tilts_the_panorama_and_keeps_the_heading(scene):
    """With the mast tilted, the compass views tilt with it: the panorama equals what views
    turning with the rover render (to anti-aliasing: as close as when upright), and differs
    from the upright one."""
    model, data, camera = scene
    rover = OmniCamera(model, dataclasses.replace(SPEC, views="rover"))
    try:
        set_pose(model, data, 0.2, 0.1, 0.7)
        upright = camera.render(data)
        aliasing = mad(upright, rover.render(data))
        tilt = math.radians(6.0)  # roll about the heading after the yaw
        yaw_q = np.array([math.cos(0.35), 0.0, 0.0, math.sin(0.35)])
        roll_q = np.array([math.cos(tilt / 2), math.sin(tilt / 2), 0.0, 0.0])
        mujoco.mju_mulQuat(data.mocap_quat[0], yaw_q, roll_q)
        mujoco.mj_forward(model, data)
        tilted = camera.render(data)
        assert mad(tilted, rover.render(data)) < 1.5 * aliasing
        assert mad(tilted, upright) > 5 * aliasing
    finally:
        rover.close()


def test_seams_are_invisible(scene):
    """Neighbouring columns across each view boundary and across the wrap (W-1 -> 0) differ as
    much as the same columns of a 3-view camera, whose boundaries lie elsewhere (same scene,
    same poses: the scene's own edges cancel out); the same statistic flags a seam misaligned
    by one row or one column."""
    model, data, camera = scene
    spec3 = dataclasses.replace(SPEC, n_views=3)
    model3, data3 = make_scene(spec3)
    other = OmniCamera(model3, spec3)
    rng = np.random.default_rng(7)
    panos, others = [], []
    try:
        for _ in range(32):
            # heading 0: the compass views' boundaries fall on the columns below
            xy = rng.uniform(-1.5, 1.5, 2)
            set_pose(model, data, *xy, 0.0)
            set_pose(model3, data3, *xy, 0.0)
            panos.append(camera.render(data).astype(np.float64))
            others.append(other.render(data3).astype(np.float64))
    finally:
        other.close()
    panos, others = np.stack(panos), np.stack(others)  # (N, H, W, 3)
    width, sector = SPEC.width, SPEC.width // SPEC.n_views
    # Boundary b (azimuth (i + 1/2) * 2*pi/n) lies at column i*sector + sector/2.
    bounds = [i * sector + sector // 2 for i in range(SPEC.n_views)]
    seam_pairs = [c for b in bounds for c in (b - 1, b)] + [width - 1]

    def step_profile(p: np.ndarray) -> np.ndarray:  # mean |col c+1 - col c|, per c
        return np.abs(np.roll(p, -1, axis=2) - p).mean(axis=(0, 1, 3))

    reference = step_profile(others)[seam_pairs]

    def worst_seam(p: np.ndarray) -> float:
        return float((step_profile(p)[seam_pairs] / reference).max())

    assert worst_seam(panos) < 1.25
    a, b = bounds[0], bounds[1]
    misaligned = panos.copy()
    misaligned[:, :, a:b] = np.roll(panos[:, :, a:b], 1, axis=1)
    assert worst_seam(misaligned) > 1.5
    gap = panos.copy()
    gap[:, :, a:b] = np.roll(panos[:, :, a:b], 1, axis=2)
    assert worst_seam(gap) > 1.5


def test_known_directions(scene):
    """Red box at +y (azimuth +90 deg, above the horizon) -> column W/4, upper half;
    blue box at -x (azimuth 180 deg) -> column W/2."""
    model, data, camera = scene
    set_pose(model, data, 0.0, 0.0, 0.0)
    pano = camera.render(data).astype(np.int64)
    red = (pano[..., 0] - pano[..., 1:].max(axis=-1)) > 100
    blue = (pano[..., 2] - pano[..., :2].max(axis=-1)) > 100
    assert red.sum() >= 4 and blue.sum() >= 4
    rows, cols = np.nonzero(red)
    assert abs(cols.mean() - SPEC.width / 4) < 1.5
    expected_row = (SPEC.vfov_deg / 2 - math.degrees(math.atan2(0.55, 3.0))) / SPEC.vfov_deg
    assert abs(rows.mean() + 0.5 - expected_row * SPEC.height) < 1.5
    assert rows.max() < SPEC.height / 2
    _, cols = np.nonzero(blue)
    assert abs(cols.mean() - SPEC.width / 2) < 1.5
    # Turning the rover left by 90 deg brings the red box to the heading, column 0.
    set_pose(model, data, 0.0, 0.0, math.pi / 2)
    pano = camera.render(data).astype(np.int64)
    red = (pano[..., 0] - pano[..., 1:].max(axis=-1)) > 100
    cols = np.nonzero(red)[1]
    signed = (cols + SPEC.width // 2) % SPEC.width - SPEC.width // 2  # near 0, either side
    assert abs(signed.mean()) < 1.5


def test_culling_changes_no_pixel(scene):
    """Views skip the geoms outside their frustum; the panorama is the same without it."""
    model, data, camera = scene
    set_pose(model, data, -0.7, 0.9, 1.0)
    culled = camera.render(data)
    _, ids, _ = camera._cullable()
    eye, frames, _, _ = camera._view_frames(data)
    assert not camera._visibility(data, eye, frames, ids).all()  # something is culled
    camera._cull = False
    try:
        full = camera.render(data)
    finally:
        camera._cull = True
    np.testing.assert_array_equal(culled, full)


def test_supersample_one_and_other_shapes():
    spec = PanoramaSpec(width=90, height=12, vfov_deg=50.0, n_views=5, supersample=1)
    model, data = make_scene(spec)
    camera = OmniCamera(model, spec)
    try:
        pano = camera.render(data)
        assert pano.shape == (12, 90, 3) and pano.std() > 10
    finally:
        camera.close()


def test_close_is_idempotent_and_render_reopens():
    model, data = make_scene()
    camera = OmniCamera(model, SPEC)
    first = camera.render(data)
    camera.close()
    camera.close()
    np.testing.assert_array_equal(camera.render(data), first)
    camera.close()
    saved = (model.vis.global_.offwidth, model.vis.global_.offheight, model.vis.quality.offsamples)
    assert saved == (640, 480, 4)  # the model's settings are restored after use


def test_context_from_another_process_is_refused_not_reused():
    """After a fork the parent's GL context is unusable; render must say so, not hang.
    (Simulated by pretending the context was made by another process: a real fork of a
    process with llvmpipe threads may deadlock.)"""
    model, data = make_scene()
    camera = OmniCamera(model, SPEC)
    camera.render(data)
    own = camera._owner_pid
    camera._owner_pid = own + 1
    try:
        with pytest.raises(RuntimeError, match="spawn"):
            camera.render(data)
    finally:
        camera._owner_pid = own
        camera.close()


def test_views_beyond_the_framebuffer_fail_at_construction():
    huge = PanoramaSpec(width=20000, height=40)
    model, _ = make_scene(huge)
    with pytest.raises(ValueError, match=r"width=20000.*25472x13824.*at most 16384x16384"):
        OmniCamera(model, huge)


def test_the_limit_a_driver_reports_is_checked_too(monkeypatch):
    monkeypatch.setattr(gl, "_queried_limit", 100)
    with pytest.raises(ValueError, match=r"a 120x80 offscreen.*at most 100x100"):
        gl.check_framebuffer(120, 80, "a")
    gl.check_framebuffer(100, 100, "fits")
    with pytest.raises(ValueError, match="at most 50x50"):
        gl.check_framebuffer(60, 10, "b", limit=50)


def test_cameras_open_at_exit_are_closed_by_the_gl_module():
    model, data = make_scene()
    camera = OmniCamera(model, SPEC)
    camera.render(data)
    assert camera in gl._LIVE
    gl._close_live()  # what runs at exit
    assert camera._con is None and camera not in gl._LIVE
    camera.render(data)  # a closed camera opens a new context
    camera.close()
    assert camera not in gl._LIVE


# -- sky sampling -------------------------------------------------------------------------------


def _skybox_ids(model: mujoco.MjModel) -> list[int]:
    return [i for i in range(model.ntex) if model.tex_type[i] == mujoco.mjtTexture.mjTEXTURE_SKYBOX]


def _sky_min_filter(camera: OmniCamera) -> int:
    from OpenGL import GL

    (sky,) = _skybox_ids(camera.model)
    camera._gl.make_current()
    GL.glBindTexture(GL.GL_TEXTURE_CUBE_MAP, int(camera._con.texture[sky]))
    value = int(GL.glGetTexParameteriv(GL.GL_TEXTURE_CUBE_MAP, GL.GL_TEXTURE_MIN_FILTER))
    GL.glBindTexture(GL.GL_TEXTURE_CUBE_MAP, 0)
    return value


def test_smooth_sky_is_sampled_nearest_to_within_a_grey_level():
    """A smooth gradient sky skips MuJoCo's trilinear filtering (a third of a panorama's cost
    on llvmpipe); the panorama stays within one grey level of the filtered one."""
    from OpenGL import GL

    model, data = make_scene(sky=SMOOTH_SKY)
    assert _smooth_skyboxes(model) == _skybox_ids(model)
    fast = OmniCamera(model, SPEC)
    filtered = OmniCamera(model, SPEC)
    filtered._smooth_skies = []  # as MuJoCo samples it
    try:
        rng = np.random.default_rng(3)
        diffs = []
        for _ in range(6):
            set_pose(model, data, *rng.uniform(-1.5, 1.5, 2), rng.uniform(0, 2 * math.pi))
            a, b = fast.render(data), filtered.render(data)
            diffs.append(np.abs(a.astype(np.int64) - b.astype(np.int64)).max())
        assert _sky_min_filter(fast) == GL.GL_NEAREST
        assert _sky_min_filter(filtered) == GL.GL_LINEAR_MIPMAP_LINEAR
        assert max(diffs) <= 1
    finally:
        fast.close()
        filtered.close()


@pytest.mark.parametrize("sky", [COARSE_SKY, SPECKLED_SKY])
def test_rough_skies_keep_mujocos_filtering(sky):
    """Skies with steps of more than a grey level between texels (a coarse gradient, random
    marks) keep trilinear filtering: nearest sampling would show their texels."""
    from OpenGL import GL

    model, data = make_scene(sky=sky)
    assert _smooth_skyboxes(model) == []
    camera = OmniCamera(model, SPEC)
    try:
        camera.render(data)
        assert _sky_min_filter(camera) == GL.GL_LINEAR_MIPMAP_LINEAR
    finally:
        camera.close()
