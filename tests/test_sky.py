"""The cloud sky (sfa_gym.sim.worlds.sky): its faces as MuJoCo orients them, the cover, the
weather, determinism, and its switch (DynamicsSpec.cloud_cover: None builds the world as
before)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from sfa_gym.sim import gl
from sfa_gym.sim.worlds import build_world, load_world_spec
from sfa_gym.sim.worlds.dynamics import DynamicsSpec
from sfa_gym.sim.worlds.sky import face_directions, sky_faces, skybox_mjcf
from sfa_gym.sim.worlds.textures import png_bytes

gl.configure()

ZENITH, HORIZON = (0.25, 0.45, 0.8), (0.75, 0.85, 0.95)


def _faces(*, cover=0.5, overcast=0.0, hour=10.0, day=0, seed=3, n=64):
    out = sky_faces(seed, day, hour, ZENITH, HORIZON, cover, overcast, n=n)
    return out.reshape(6, n, n, 3).astype(float) / 255.0


def test_face_directions_are_where_mujoco_shows_them():
    """A skybox whose texels hold their own directions, rendered by MuJoCo: the colour at the
    centre of a view looking along d decodes to d."""
    import mujoco

    n = 64
    image = np.round((face_directions(n) + 1.0) * 127.5).astype(np.uint8).reshape(6 * n, n, 3)
    xml = (
        '<mujoco><visual><global fovy="1" offwidth="16" offheight="16"/></visual>'
        f"<asset>{skybox_mjcf('sky', 'sky.png')}</asset><worldbody/></mujoco>"
    )
    model = mujoco.MjModel.from_xml_string(xml, {"sky.png": png_bytes(image)})
    data = mujoco.MjData(model)
    camera = mujoco.MjvCamera()
    camera.type = mujoco.mjtCamera.mjCAMERA_FREE
    scene = mujoco.MjvScene(model, maxgeom=10)
    rect, pixels = mujoco.MjrRect(0, 0, 16, 16), np.empty((16, 16, 3), np.uint8)
    context = gl.new_context(16, 16, "the sky probe")
    con = mujoco.MjrContext(model, mujoco.mjtFontScale.mjFONTSCALE_50)
    rng = np.random.default_rng(0)
    try:
        mujoco.mjr_setBuffer(mujoco.mjtFramebuffer.mjFB_OFFSCREEN, con)
        for _ in range(40):
            azimuth, elevation = rng.uniform(-180, 180), rng.uniform(-80, 80)
            camera.azimuth, camera.elevation = azimuth, elevation
            mujoco.mjv_updateScene(
                model, data, mujoco.MjvOption(), None, camera, mujoco.mjtCatBit.mjCAT_ALL, scene
            )
            mujoco.mjr_render(rect, scene, con)
            mujoco.mjr_readPixels(pixels, None, rect, con)
            seen = pixels[8, 8].astype(float) / 127.5 - 1.0
            a, e = np.radians(azimuth), np.radians(elevation)
            looking = np.array([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)])
            assert np.abs(seen - looking).max() < 0.05, (azimuth, elevation, seen, looking)
    finally:
        con.free()
        context.free()


def test_the_same_arguments_give_the_same_bytes_and_weather_changes_the_clouds():
    a = sky_faces(3, 0, 10.0, ZENITH, HORIZON, 0.5, n=32)
    assert np.array_equal(a, sky_faces(3, 0, 10.0, ZENITH, HORIZON, 0.5, n=32))
    up = _faces(n=32)[2]
    for other in (_faces(day=1, n=32), _faces(hour=14.0, n=32), _faces(seed=4, n=32)):
        assert np.abs(up - other[2]).mean() > 0.05  # another day, 4 h later, another world


def test_a_second_later_the_clouds_have_only_drifted_even_across_the_hour():
    """The hourly fields blend into each other and the wind moves the clouds by metres per
    second: a second changes the sky far less than an hour, at the turn of the hour too."""
    up = _faces(hour=10.5)[2]
    hour = np.abs(up - _faces(hour=11.5)[2]).mean()
    for at in (10.5, 11.0 - 0.5 / 3600):
        second = np.abs(_faces(hour=at)[2] - _faces(hour=at + 1 / 3600)[2]).mean()
        assert second < 0.1 * hour


def _clouded(faces: np.ndarray, clear: np.ndarray) -> float:
    """The share of the up face that cloud makes visibly whiter than the clear sky there."""
    return float(np.mean(np.abs(faces[2] - clear[2]).max(axis=-1) > 0.05))


def test_the_cover_is_the_share_of_the_sky_in_cloud():
    clear = _faces(cover=0.0)
    d = face_directions(64)
    weight = np.sqrt(d[..., 2].clip(0, 1))[..., None]
    expected = (1 - weight) * np.asarray(HORIZON) + weight * np.asarray(ZENITH)
    assert np.abs(clear - expected).max() <= 0.5 / 255 + 1e-9  # no cloud at all
    shares = [_clouded(_faces(cover=c), clear) for c in (0.2, 0.5, 0.8)]
    assert shares[0] < shares[1] < shares[2]
    assert 0.05 < shares[0] < 0.3 and shares[2] > 0.6


def test_overcast_closes_the_sky_into_grey():
    faces = _faces(cover=0.2, overcast=1.0)
    up = faces[2]
    saturation = up.max(axis=-1) - up.min(axis=-1)
    assert saturation.mean() < 0.05
    assert up.mean() < _faces(cover=0.2)[2].mean()


def test_the_horizon_shows_haze_not_noise():
    """Below a few degrees the clouds have faded into the horizon's colour (aerial
    perspective): no texel there is far from the clear sky's."""
    d = face_directions(64)
    low = (d[..., 2] > 0.0) & (d[..., 2] < 0.03)
    faces = _faces(cover=0.8)
    clear = _faces(cover=0.0)
    assert low.any()
    assert np.abs(faces[low] - clear[low]).max() < 0.08


@pytest.mark.parametrize("bad", [-0.1, 1.5, "half", True])
def test_a_bad_cover_is_refused_by_name(bad):
    with pytest.raises(ValueError, match="cloud_cover"):
        DynamicsSpec(cloud_cover=bad)


def test_no_cover_builds_the_world_as_before_and_a_cover_puts_a_sky_file_in():
    spec = load_world_spec("paper_outdoor")
    plain = build_world(spec, 5)
    unset = build_world(spec, 5, dynamics=dataclasses.replace(spec.dynamics, cloud_cover=None))
    assert unset.mjcf == plain.mjcf and unset.assets == plain.assets
    assert 'builtin="gradient"' in plain.mjcf and "sky.png" not in plain.assets
    cloudy = build_world(spec, 5, dynamics=dataclasses.replace(spec.dynamics, cloud_cover=0.4))
    assert skybox_mjcf("sky", "sky.png") in cloudy.mjcf and "sky.png" in cloudy.assets
    # only the sky changed: the rest of the world is drawn from the same generator
    assert _without_sky(cloudy.mjcf) == _without_sky(plain.mjcf)


def _without_sky(mjcf: str) -> list[str]:
    return [line for line in mjcf.splitlines() if 'name="sky"' not in line]


def test_a_cloudy_env_renders_clouds_above_the_horizon_only():
    import gymnasium as gym

    import sfa_gym  # noqa: F401
    from sfa_gym.sim.camera import PanoramaSpec

    wide = PanoramaSpec(width=240, height=60, vfov_deg=90.0, n_views=6)
    kwargs = {"camera": "cylindrical", "mirror": None, "panorama": wide, "sensor": False}
    seen = {}
    for cover in (None, 0.7):
        env = gym.make(
            "sfa_gym/OmniRoverOutdoor-v0",
            dynamics={"movers": False, "cloud_cover": cover},
            **kwargs,
        )
        assert env.unwrapped.dynamics.cloud_cover == cover
        seen[cover] = env.reset(seed=0, options={"pose": (0.0, 0.0, 0.0)})[0].astype(int)
        env.close()
    difference = np.abs(seen[None] - seen[0.7]).mean(axis=(1, 2))
    assert difference[:20].mean() > 5.0  # the upper rows: sky
    assert difference[35:].max() < 1.0  # below the horizon: the same ground


def test_a_cloud_cover_on_a_world_without_dynamics_starts_from_the_defaults():
    from sfa_gym.sim.env import resolve_effect

    chosen = resolve_effect("dynamics", {"cloud_cover": 0.5}, DynamicsSpec, declared=None)
    assert chosen == DynamicsSpec(cloud_cover=0.5)


def test_the_outdoor_protocol_draws_each_runs_clouds_for_its_hour():
    import gymnasium as gym

    import sfa_gym  # noqa: F401
    from sfa_gym.protocols.outdoor import ENV_ID, Config

    config = Config(cloud_cover=0.4, conditions=("after", "later", "overcast", "other_day"))
    skies = {}
    for condition in config.test_conditions:
        kwargs = config.env_kwargs(condition, 0)
        assert kwargs["dynamics"].cloud_cover == 0.4, condition
        env = gym.make(ENV_ID, **kwargs)
        assert "sky.png" in env.unwrapped.mjcf
        skies[condition] = env.unwrapped.dynamics  # what the sky was drawn for
        env.close()
    assert skies["later"].start_hour != skies["after"].start_hour
    assert skies["other_day"].day == skies["after"].day + 1
    assert Config().env_kwargs("after", 0)["dynamics"].cloud_cover is None
    with pytest.raises(ValueError, match="cloud_cover"):
        Config(cloud_cover=2.0).validate()
