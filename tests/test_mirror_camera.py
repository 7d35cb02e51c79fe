"""Mirror (catadioptric) camera: the unified model's geometry, spec validation, and the circular
image and unwarped panorama of real renders (known points, rotation, an off-centre unwarp)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from sfa_gym.sim import gl

gl.configure()

import mujoco  # noqa: E402

from sfa_gym.sim.camera import camera_mjcf  # noqa: E402
from sfa_gym.sim.camera.mirror import (  # noqa: E402
    MirrorCamera,
    MirrorSpec,
    lift,
    project,
    unwarp,
)
from sfa_gym.sim.rover import RoverSpec, rover_mjcf  # noqa: E402
from sfa_gym.sim.worlds import build_world, load_world_spec  # noqa: E402

# A third of the paper preset's size keeps the renders cheap: a 160-pixel circular image
# unwarped to 20 x 200, centred unwarp.
SMALL = MirrorSpec(
    image_size=160,
    gamma=39.5,
    elevation_range_deg=(-45.0, 25.0),
    panorama_width=200,
    panorama_height=20,
)
CAM_HEIGHT = 1.0
# Markers of the known-point scene: (azimuth, elevation) in degrees from the camera, distance m.
RED = (60.0, 10.0, 3.0)
BLUE = (200.0, -20.0, 2.5)


def mad(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.abs(a.astype(np.float64) - b.astype(np.float64)).mean())


def _marker(name: str, azimuth_deg: float, elevation_deg: float, dist: float, rgb: str) -> str:
    a, e = math.radians(azimuth_deg), math.radians(elevation_deg)
    x, y = dist * math.cos(e) * math.cos(a), dist * math.cos(e) * math.sin(a)
    z = CAM_HEIGHT + dist * math.sin(e)
    return f'<geom name="{name}" type="sphere" size="0.25" pos="{x} {y} {z}" rgba="{rgb} 1"/>'


def marker_scene(spec: MirrorSpec) -> tuple[mujoco.MjModel, mujoco.MjData]:
    """Grey floor, a red and a blue ball at known directions, the cameras on a mocap mast."""
    xml = f"""
<mujoco>
  <worldbody>
    <light directional="true" dir="0 0 -1" castshadow="false"/>
    <geom type="plane" size="10 10 1" rgba=".4 .4 .4 1"/>
    {_marker("red", *RED, "1 0 0")}
    {_marker("blue", *BLUE, "0 0 1")}
    <body name="mast" mocap="true" pos="0 0 {CAM_HEIGHT}">
      {camera_mjcf(spec.view_spec())}
    </body>
  </worldbody>
</mujoco>"""
    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    return model, data


def rover_scene(spec: MirrorSpec) -> tuple[mujoco.MjModel, mujoco.MjData]:
    built = build_world(load_world_spec("paper_sim"), 0, rover_mjcf(RoverSpec(), spec.view_spec()))
    model = mujoco.MjModel.from_xml_string(built.mjcf)
    return model, mujoco.MjData(model)


def place(model: mujoco.MjModel, data: mujoco.MjData, x: float, y: float, yaw: float) -> None:
    q = int(model.joint("rover_root").qposadr[0])
    data.qpos[q : q + 3] = (x, y, 0.2)
    data.qpos[q + 3 : q + 7] = (math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2))
    mujoco.mj_forward(model, data)


def centroid(image: np.ndarray, channel: int) -> tuple[float, float]:
    """(column, row) centroid of the pixels dominated by one colour channel."""
    img = image.astype(np.int32)
    others = [c for c in range(3) if c != channel]
    hit = (img[..., channel] > 100) & (img[..., channel] > 2 * img[..., others].max(axis=-1))
    assert hit.sum() >= 3, "marker not visible"
    rows, cols = np.nonzero(hit)
    return float(cols.mean()), float(rows.mean())


@pytest.fixture(scope="module")
def rover():
    model, data = rover_scene(SMALL)
    camera = MirrorCamera(model, SMALL)
    yield model, data, camera
    camera.close()


# -- geometry -----------------------------------------------------------------------------------


@pytest.mark.parametrize("xi", [0.0, 0.5, 0.9, 1.0])
def test_lift_inverts_project(xi):
    # project and lift do not depend on the ranges; these fit every xi (even the pinhole's)
    spec = dataclasses.replace(
        SMALL,
        xi=xi,
        gamma=20.0,
        elevation_range_deg=(-70.0, -20.0),
        unwarp_elevation_deg=(-60.0, -30.0),
    )
    rng = np.random.default_rng(0)
    azimuth = rng.uniform(-math.pi, math.pi, 500)
    top = math.asin(xi) - 0.05
    elevation = rng.uniform(-math.pi / 2 + 0.01, top, 500)
    u, v = project(spec, azimuth, elevation)
    assert np.isfinite(u).all() and np.isfinite(v).all()
    a, e = lift(spec, u, v)
    np.testing.assert_allclose(e, elevation, atol=1e-9)
    np.testing.assert_allclose(np.angle(np.exp(1j * (a - azimuth))), 0.0, atol=1e-9)
    # and the other way round, over the whole image
    uu, vv = np.meshgrid(np.arange(0.0, 160.0, 7.3), np.arange(0.0, 160.0, 5.1))
    u2, v2 = project(spec, *lift(spec, uu, vv))
    np.testing.assert_allclose(u2, uu, atol=1e-8)
    np.testing.assert_allclose(v2, vv, atol=1e-8)


def test_known_directions_land_where_the_model_says():
    spec = MirrorSpec.paper_outdoor()
    # The horizon is the ring of radius gamma / xi; the heading points up, the rover's left
    # (azimuth +90 degrees, counter-clockwise) to the image's right: the view from below.
    u, v = project(spec, [0.0, math.pi / 2, math.pi, -math.pi / 2], 0.0)
    r = spec.gamma / spec.xi
    np.testing.assert_allclose(u, [spec.cx, spec.cx + r, spec.cx, spec.cx - r], atol=1e-9)
    np.testing.assert_allclose(v, [spec.cy - r, spec.cy, spec.cy + r, spec.cy], atol=1e-9)
    # straight down is the centre; the radius grows with the elevation up to the rim
    np.testing.assert_allclose(project(spec, 0.3, -math.pi / 2), (spec.cx, spec.cy), atol=1e-9)
    elevations = np.radians(np.linspace(*spec.elevation_range_deg, 50))
    radii = np.hypot(
        *(
            np.subtract(p, c)
            for p, c in zip(project(spec, 1.0, elevations), (spec.cx, spec.cy), strict=True)
        )
    )
    assert np.all(np.diff(radii) > 0)
    np.testing.assert_allclose(spec.disc_radii, (radii[0], radii[-1]), rtol=1e-12)
    # the rim fits the 480-pixel image, as a real mirror fills its camera's frame
    assert 200 < spec.disc_radii[1] < 240
    # beyond asin(xi) the mirror shows nothing
    assert np.isnan(project(spec, 0.0, math.asin(spec.xi) + 0.01)[0])


def test_presets_and_shapes():
    spec = MirrorSpec.paper_outdoor()
    assert spec.panorama_shape == (60, 600, 3)
    assert spec.circular_shape == (480, 480, 3)
    assert spec.unwarp_centre_offset != (0.0, 0.0)  # the paper's mirror was uncalibrated
    view = spec.view_spec()
    assert view.vfov_deg / 2 > max(abs(e) for e in spec.elevation_range_deg)
    assert view.supersample == 1
    # the widest range still gives a valid view panorama
    widest = MirrorSpec(xi=1.0, gamma=30.0, elevation_range_deg=(-74.0, 73.9))
    assert widest.view_spec().vfov_deg == 150.0
    # replacing the image size moves the default centre along
    assert dataclasses.replace(spec, image_size=400, gamma=90.0).cx == 199.5


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("xi", -0.1),
        ("xi", 1.5),
        ("xi", "0.9"),
        ("gamma", 0.0),
        ("gamma", float("nan")),
        ("gamma", 400.0),  # the rim would leave the image
        ("image_size", 8),
        ("image_size", 480.0),
        ("centre", (500.0, 10.0)),
        ("centre", (1.0,)),
        ("elevation_range_deg", (25.0, -45.0)),
        ("elevation_range_deg", (-45.0, 70.0)),  # beyond asin(0.9) = 64 degrees
        ("elevation_range_deg", (-80.0, 20.0)),  # beyond the view panorama's reach
        ("panorama_width", 0),
        ("panorama_height", True),
        ("unwarp_elevation_deg", (-50.0, 20.0)),
        ("unwarp_elevation_deg", (10.0, 10.0)),
        ("unwarp_rows", "log"),
        ("unwarp_centre_offset", (30.0, 0.0)),
        ("unwarp_centre_offset", "off"),
        ("supersample", 0),
        ("n_views", 2),
        ("view_scale", 0.1),
    ],
)
def test_bad_spec_names_field_and_value(field, value):
    with pytest.raises(ValueError) as err:
        MirrorSpec(**{field: value})
    assert f"MirrorSpec.{field}" in str(err.value) and repr(value) in str(err.value)


def test_unwarp_checks_its_input():
    with pytest.raises(ValueError, match=r"\(160, 160, 3\)"):
        unwarp(np.zeros((100, 100, 3), np.uint8), SMALL)
    with pytest.raises(TypeError, match="uint8"):
        unwarp(np.zeros((160, 160, 3), np.float32), SMALL)
    with pytest.raises(TypeError, match="MirrorSpec"):
        unwarp(np.zeros((160, 160, 3), np.uint8), SMALL.view_spec())


@pytest.mark.parametrize("rows", ["elevation", "radius"])
def test_unwarp_of_a_drawn_pattern_follows_the_conventions(rows):
    # A circular image whose colour encodes the azimuth (red), the elevation and the radius.
    spec = dataclasses.replace(SMALL, unwarp_rows=rows, unwarp_elevation_deg=[-30, 20])
    v, u = np.mgrid[0:160, 0:160].astype(np.float64)
    azimuth, elevation = lift(spec, u, v)
    radius = np.hypot(u - spec.cx, v - spec.cy)
    image = np.zeros(spec.circular_shape, np.uint8)
    image[..., 0] = np.round(np.mod(azimuth, 2 * np.pi) / (2 * np.pi) * 250)
    image[..., 1] = np.clip(np.round(128 + 4 * np.degrees(elevation)), 0, 255)
    image[..., 2] = np.clip(np.round(2 * radius), 0, 255)
    pano = unwarp(image, spec).astype(np.float64)
    # away from the 0/360 seam, red grows by 250/W per column (counter-clockwise)
    red = pano[:, 10:-10, 0].mean(axis=0)
    expected = (np.arange(10, 190) / 200.0) * 250
    assert np.abs(red - expected).max() < 1.5
    fraction = (np.arange(20) + 0.5) / 20  # row centres, 0 at the top edge
    if rows == "elevation":
        # rows equiangular from +20 degrees (top edge) to -30 (bottom edge)
        want = 128 + 4 * (20.0 - 50.0 * fraction)
        got = pano[:, :, 1].mean(axis=1)
    else:
        # rows evenly spaced in radius from r(+20) (top edge) to r(-30) (bottom edge)
        bottom, top = spec.unwarp_radii
        want = 2 * (top + (bottom - top) * fraction)
        got = pano[:, :, 2].mean(axis=1)
    assert np.abs(got - want).max() < 1.5, (got, want)


# -- renders ------------------------------------------------------------------------------------


def test_markers_appear_where_the_model_projects_them():
    model, data = marker_scene(SMALL)
    camera = MirrorCamera(model, SMALL)
    try:
        circular = camera.render_circular(data)
        panorama = camera.render(data)
    finally:
        camera.close()
    assert circular.shape == SMALL.circular_shape and panorama.shape == SMALL.panorama_shape
    for (az, el, _), channel in ((RED, 0), (BLUE, 2)):
        want = project(SMALL, math.radians(az), math.radians(el))
        got = centroid(circular, channel)
        # The magnification grows with the radius, which pulls a ball's centroid outwards by
        # about a pixel; its azimuth is exact.
        assert math.dist(got, want) < 2.5, (got, want)
        got_azimuth = math.degrees(float(lift(SMALL, *got)[0]))
        assert abs((got_azimuth - az + 180.0) % 360.0 - 180.0) < 1.0, (got_azimuth, az)
        col, _ = centroid(panorama, channel)
        assert abs(col - az / 360.0 * SMALL.panorama_width) < 1.0
    # black outside the mirror's annulus, the floor and sky inside it
    inner, outer = SMALL.disc_radii
    v, u = np.mgrid[0:160, 0:160]
    radius = np.hypot(u - SMALL.cx, v - SMALL.cy)
    assert circular[(radius < inner - 1) | (radius > outer + 1)].max() == 0
    assert circular[(radius > inner + 1) & (radius < outer - 1)].min(axis=-1).mean() > 20


def test_turning_shifts_the_unwarped_panorama(rover):
    model, data, camera = rover
    width = SMALL.panorama_width
    place(model, data, 0.4, -0.7, 0.3)
    before = camera.render(data)
    for k in (5, 37):
        place(model, data, 0.4, -0.7, 0.3 + 2 * math.pi * k / width)
        after = camera.render(data)
        residual = mad(after, np.roll(before, -k, axis=1))
        unrelated = mad(after, np.roll(before, -k + width // 4, axis=1))
        assert residual < 3.0 and residual < unrelated / 8, (k, residual, unrelated)


def test_an_off_centre_unwarp_wobbles(rover):
    model, data, camera = rover
    off = dataclasses.replace(SMALL, unwarp_centre_offset=(4.0, -3.0))
    width, k = SMALL.panorama_width, 37
    place(model, data, 0.4, -0.7, 0.3)
    circular = camera.render_circular(data)
    centred, shifted = unwarp(circular, SMALL), unwarp(circular, off)
    assert mad(centred, shifted) > 3.0
    place(model, data, 0.4, -0.7, 0.3 + 2 * math.pi * k / width)
    turned = camera.render_circular(data)
    residual_centred = mad(unwarp(turned, SMALL), np.roll(centred, -k, axis=1))
    residual_off = mad(unwarp(turned, off), np.roll(shifted, -k, axis=1))
    assert residual_off > 2 * residual_centred, (residual_off, residual_centred)


def test_same_pose_same_pixels(rover):
    model, data, camera = rover
    place(model, data, -1.0, 1.2, 2.0)
    first = camera.render(data)
    again = MirrorCamera(model, SMALL)
    try:
        np.testing.assert_array_equal(again.render(data), first)
        np.testing.assert_array_equal(camera.render(data), first)
    finally:
        again.close()


def test_sensor_effects_act_on_the_circular_image(rover):
    model, data, camera = rover
    place(model, data, -1.0, 1.2, 2.0)
    circular = camera.render_circular(data)
    inverted = camera.render(data, sensor=lambda image: 255 - image)
    np.testing.assert_array_equal(inverted, unwarp(255 - circular, SMALL))
    assert mad(inverted, camera.render(data)) > 50
    with pytest.raises(ValueError, match="shape"):
        camera.render(data, sensor=lambda image: image[::2])


def test_cameras_of_another_spec_are_refused(rover):
    model, _, _ = rover
    with pytest.raises(ValueError, match="camera_mjcf"):
        MirrorCamera(model, dataclasses.replace(SMALL, n_views=6))
    with pytest.raises(TypeError, match="MirrorSpec"):
        MirrorCamera(model, SMALL.view_spec())
