"""The sun's cast shadows: the depth map's test on a box whose shadow is known, and the outdoor
env with shadows (only darker, where the sun is taken away; unchanged without sun; the same
pixels whatever the clock showed before)."""

from __future__ import annotations

import dataclasses
from contextlib import contextmanager

import mujoco  # noqa: E402  (after sfa_gym.sim: MUJOCO_GL set)
import numpy as np
import pytest

from sfa_gym.sim import gl
from sfa_gym.sim.camera.sensor import SensorSpec
from sfa_gym.sim.camera.shadows import SunShadows
from sfa_gym.sim.env import OmniRoverEnv
from sfa_gym.sim.worlds import load_world_spec
from sfa_gym.sim.worlds.dynamics import DynamicsSpec

# A 1 x 1 x 2 m box and a 1 m pillar on the ground, the sun in the +x direction 45 degrees
# high, and a box on a mocap body (something that moves: it casts no shadow in the map of the
# static scene).
BOX_SCENE = """
<mujoco>
  <statistic center="0 0 0" extent="5"/>
  <visual><global offwidth="256" offheight="256"/></visual>
  <worldbody>
    <light name="sun" type="directional" dir="-1 0 -1" diffuse="0.6 0.6 0.6"/>
    <geom name="ground" type="plane" size="10 10 1"/>
    <geom name="box" type="box" pos="0 0 1" size="0.5 0.5 1"/>
    <geom name="pillar" type="cylinder" pos="2 3 0.5" size="0.2 0.5"/>
    <body name="mover" mocap="true" pos="-1.5 3 1"><geom type="box" size="0.5 0.5 1"/></body>
  </worldbody>
</mujoco>
"""


@contextmanager
def _box_scene():
    """The box scene's model, data, an updated scene and a current offscreen context."""
    model = mujoco.MjModel.from_xml_string(BOX_SCENE)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    context = gl.new_context(256, 256, "the box scene")
    con = mujoco.MjrContext(model, mujoco.mjtFontScale.mjFONTSCALE_50)
    mujoco.mjr_setBuffer(mujoco.mjtFramebuffer.mjFB_OFFSCREEN, con)
    scene = mujoco.MjvScene(model, maxgeom=100)
    camera = mujoco.MjvCamera()
    mujoco.mjv_updateScene(
        model, data, mujoco.MjvOption(), None, camera, mujoco.mjtCatBit.mjCAT_ALL, scene
    )
    try:
        yield model, data, scene, con
    finally:
        con.free()
        context.free()


@pytest.fixture(scope="module")
def box_shadows():
    with _box_scene() as (model, data, scene, con):
        shadows = SunShadows(model, texels=256)
        before = [(c.pos.copy(), c.orthographic, c.frustum_near) for c in scene.camera]
        shadows.update(data, scene, con)
        after = [(c.pos.copy(), c.orthographic, c.frustum_near) for c in scene.camera]
        yield shadows, before, after


def test_the_box_shadow_falls_where_the_sun_rays_put_it(box_shadows):
    shadows, _, _ = box_shadows
    z = 0.01  # just above the ground
    # the rays (-1, 0, -1) carry the top edge at x = -0.5, 2 m high, to x = -2.5 on the ground
    inside = [(-1.5, 0.0, z), (-2.2, 0.3, z), (-0.8, -0.3, z)]
    outside = [(-3.0, 0.0, z), (1.0, 0.0, z), (-1.5, 0.9, z), (-1.5, -0.9, z)]
    assert shadows.in_shadow(np.array(inside)).all()
    assert not shadows.in_shadow(np.array(outside)).any()
    # the box's top and its sunny face are lit; its face turned from the sun lies behind it
    assert not shadows.in_shadow(np.array([(0.0, 0.0, 2.01), (0.51, 0.0, 1.0)])).any()
    assert shadows.in_shadow(np.array([(-0.52, 0.0, 1.0)])).all()
    # a pillar on one side only: its shadow on that side (the map is not mirrored)
    assert shadows.in_shadow(np.array([(1.2, 3.0, z)])).all()
    assert not shadows.in_shadow(np.array([(1.2, -3.0, z)])).any()
    # without the camera's place the moving box casts none: where its shadow would fall, the
    # ground is lit
    assert not shadows.in_shadow(np.array([(-3.0, 3.0, z)])).any()
    # points outside the map are lit
    assert not shadows.in_shadow(np.array([(40.0, 0.0, z)])).any()


@pytest.mark.parametrize(("centre", "near"), [((0.0, 0.0, 1.0), True), ((30.0, 0.0, 1.0), False)])
def test_a_moving_body_near_the_camera_casts_its_shadow_too(centre, near):
    with _box_scene() as (model, data, scene, con):
        shadows = SunShadows(model, texels=256, moving_texels=256)
        shadows.update(data, scene, con, np.array(centre))
        z = 0.01
        # the moving box (x -2..-1, y 2.5..3.5, 2 m high) shades x -4..-1 at its y, if it is
        # within the moving map's reach of the camera; the static box's shadow stays
        mover = np.array([(-3.0, 3.0, z), (-1.8, 2.7, z), (-3.8, 3.3, z)])
        assert shadows.in_shadow(mover).all() == near
        assert shadows.in_shadow(mover).any() == near
        assert not shadows.in_shadow(np.array([(-3.0, 4.0, z), (-4.5, 3.0, z)])).any()
        assert shadows.in_shadow(np.array([(-1.5, 0.0, z)])).all()


def test_the_depth_map_leaves_the_scene_cameras_as_they_were(box_shadows):
    _, before, after = box_shadows
    for (pos0, ortho0, near0), (pos1, ortho1, near1) in zip(before, after, strict=True):
        np.testing.assert_array_equal(pos0, pos1)
        assert (ortho0, near0) == (ortho1, near1)


def test_shadows_need_a_sun():
    model = mujoco.MjModel.from_xml_string(BOX_SCENE.replace('name="sun" ', ""))
    with pytest.raises(ValueError, match="light named 'sun'"):
        SunShadows(model)
    with pytest.raises(ValueError, match="texels must be an int >= 16"):
        SunShadows(mujoco.MjModel.from_xml_string(BOX_SCENE), texels=8)


def test_a_bad_shadows_switch_is_named():
    with pytest.raises(ValueError, match="shadows must be True or False"):
        DynamicsSpec(shadows=1)
    with pytest.raises(ValueError, match="dynamics: field shadows must be bool, got 'yes'"):
        OmniRoverEnv(world="paper_outdoor", dynamics={"shadows": "yes"})


def _env(shadows: bool, overcast: float = 0.0) -> OmniRoverEnv:
    declared = load_world_spec("paper_outdoor").dynamics
    return OmniRoverEnv(
        world="paper_outdoor",
        camera="cylindrical",
        mirror=None,
        panorama="paper_sim",
        dynamics=dataclasses.replace(
            declared, overcast=overcast, shadows=shadows, clouds=False, movers=False
        ),
        sensor=SensorSpec(auto_exposure=False, noise=False),
    )


def _frames(env: OmniRoverEnv, hours: list[float]) -> list[np.ndarray]:
    pose = (1.0, -1.0, 0.3)
    return [
        env.reset(seed=0, options={"pose": pose, "time_of_day": h})[0].astype(int) for h in hours
    ]


def test_shadows_only_take_the_sun_away():
    plain, shaded = _env(False), _env(True)
    try:
        hours = [9.0, 16.5]
        for a, b in zip(_frames(plain, hours), _frames(shaded, hours), strict=True):
            assert np.all(b <= a)  # a surface without the sun is never brighter
            darker = (b < a).any(axis=2).mean()
            assert 0.01 < darker < 0.9, darker
        # at night there is no sun to take away
        night = _frames(plain, [23.0])[0]
        np.testing.assert_array_equal(_frames(shaded, [23.0])[0], night)
    finally:
        plain.close()
        shaded.close()


def test_the_same_sun_gives_the_same_shadows_whatever_came_before():
    first, second = _env(True), _env(True)
    try:
        direct = _frames(first, [15.0])[0]
        after_others = _frames(second, [8.0, 11.0, 15.0])[-1]
        np.testing.assert_array_equal(direct, after_others)
    finally:
        first.close()
        second.close()


def test_an_overcast_sky_casts_faint_shadows():
    darkening = []
    for overcast in (0.0, 1.0):
        plain, shaded = _env(False, overcast), _env(True, overcast)
        try:
            a, b = _frames(plain, [12.0])[0], _frames(shaded, [12.0])[0]
            assert np.all(b <= a)
            darkening.append((a - b).mean())
        finally:
            plain.close()
            shaded.close()
    # a full overcast leaves 15 % of the direct light: a fraction of a clear day's shadows
    assert 0 <= darkening[1] < 0.3 * darkening[0]


def test_the_outdoor_protocol_casts_shadows_in_every_run():
    from sfa_gym.protocols.outdoor import Config

    config = Config(shadows=True, conditions=("after", "later", "fog", "rearranged"))
    for condition in config.test_conditions:
        assert config.env_kwargs(condition, 0)["dynamics"].shadows, condition
    assert not Config().env_kwargs("after", 0)["dynamics"].shadows
    with pytest.raises(TypeError, match="shadows must be True or False"):
        Config(shadows="on").validate()
