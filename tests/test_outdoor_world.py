"""The outdoor world (envs/paper_outdoor.json): spec, boundary kinds, surroundings, determinism,
curbs that stop the rover, and the walled worlds left byte-identical."""

from __future__ import annotations

import copy
import hashlib
import json
import math

import numpy as np
import pytest

from sfa_gym.sim import gl
from sfa_gym.sim.camera import PanoramaSpec
from sfa_gym.sim.worlds import build_world, load_world_spec, world_spec_from_dict
from sfa_gym.sim.worlds.data import envs_dir

gl.configure()

import mujoco  # noqa: E402

from sfa_gym.sim.env import OmniRoverEnv  # noqa: E402

# sha256 of build_world(spec, seed).mjcf for seeds 0..5, recorded before boundary kinds, the
# sun light and the outdoor block existed: those additions must not change walled worlds.
_WALLED_MJCF_SHA256 = {
    "paper_sim": [
        "2cfb8bdfd1877dc3a4b3f3a5e766a6d9be96b3af64808c27b3c9c50ed2adac25",
        "dd5f16f1d4153a6963629b635167e22b5648ef9715851f7d0a2d302d1d76c755",
        "6c0045c541fe9573bdc078490acc089dcc9fa069b1f13651e27be173203ffdec",
        "b6dc553c27e95b7f5cafa5827ab71f00adb35acb65f2c45fa49fadea66ce061a",
        "403c3a73ed22918d3a7ba62cff3a954b58828e3fd714688842c1c2916aecad8f",
        "a7e914013389cc9d62f6a19431310822c69f59b28cda2c53b7ced50dd779ae64",
    ],
    "paper_sim_obstacles": [
        "4acf7d9f2762bd9d080b54c3e5489d26d97d31da7910f2fee17170c47c0df503",
        "34044e9a40c67d63d38a580e43c8f6a66dd79211ee56deba8fece1691a3007fc",
        "0d5bd0a59b2916b3fcfdceb965d98fd471bbccbcd08d5be9c0cd1077fa02de1b",
        "42228ba4fe48755c6774200007ddb5d9745d36cb029dc26a1f01f6872aa39008",
        "177ca09e9845a99a8f1a43c80e86013519d0b87fcde3901aee95a4cdbfcc30f8",
        "c9a462aa7539d12e49834178e9043cb699222aabc6d958e10da3019ade0c969f",
    ],
    "paper_sim_maze": [
        "9b50f44bd3a8513e3fc399a93e01e50abf9127d503d23523499ad060e429b644",
        "54e851f510d1271938fef6cdf86b95da7734bbc33c2a15c10797e18a9c2c1141",
        "675a0c4f4652b098ed4a7cdc202ef9eaa24d03bfec2d7101259f83f9f9bcf2e2",
        "f7d6d913197cea37222eb83a889c6b21ed246c131e623d2d2ac8513fb5d6930c",
        "62195e53d486e884709c8a7038a1ba6df84327db509052bcbd5a4abfb76354cb",
        "2ae4ca5236ab00c60e2ff34c321594138644c68a39373ee7d92ae95ef00f08a9",
    ],
}

# small panoramas keep the physics tests cheap; what they check does not depend on pixels
_TINY = PanoramaSpec(width=64, height=8)


@pytest.fixture(scope="module")
def spec():
    return load_world_spec("paper_outdoor")


@pytest.fixture(scope="module")
def spec_dict():
    return json.loads((envs_dir() / "paper_outdoor.json").read_text())


@pytest.fixture(scope="module")
def model(spec):
    return mujoco.MjModel.from_xml_string(build_world(spec, 0).mjcf)


def _with(spec_dict, **arena):
    d = copy.deepcopy(spec_dict)
    d["arena"].update(arena)
    return world_spec_from_dict(d)


def _geom_names(model):
    return [model.geom(i).name for i in range(model.ngeom)]


@pytest.mark.parametrize("name", sorted(_WALLED_MJCF_SHA256))
def test_walled_worlds_are_byte_identical_to_before(name):
    spec = load_world_spec(name)
    assert spec.arena.boundary == "walls" and spec.outdoor is None
    got = [hashlib.sha256(build_world(spec, s).mjcf.encode()).hexdigest() for s in range(6)]
    assert got == _WALLED_MJCF_SHA256[name]


def test_outdoor_spec_loads_with_the_papers_area(spec):
    assert spec.name == "paper_outdoor"
    assert spec.arena.boundary == "curbs"
    # the paper's drivable asphalt: about 5 m x 7 m
    assert spec.arena.bounds == (-2.5, 2.5, -3.5, 3.5)
    assert spec.outdoor is not None and spec.lights.sun is not None


@pytest.mark.parametrize(
    "key, value, match",
    [
        ("boundary", "fence", r"boundary must be one of \('walls', 'curbs', 'markings'\).*'fence'"),
        ("boundary", 3, r"arena\.boundary must be str"),
        ("curb_height", 0.0, r"curb_height must be positive, got 0\.0"),
        ("border_width", -0.1, r"border_width must be positive"),
    ],
)
def test_bad_arena_boundary_values_are_refused_by_name(spec_dict, key, value, match):
    with pytest.raises(ValueError, match=match):
        _with(spec_dict, **{key: value})


@pytest.mark.parametrize(
    "path, value, match",
    [
        (("buildings", "sides"), [1, 5], r"buildings sides must lie in \[0, 4\]"),
        (("buildings", "storeys"), [3, 2], r"buildings storeys must be a \[min, max\] pair"),
        (("cars", "count"), -1, r"outdoor item count must be >= 0, got -1"),
        (("trees", "height"), [0.0, 2.0], r"outdoor item height must be >= 0\.001"),
        (("pavement_width",), 0, r"outdoor pavement_width must be positive"),
        (("tree_clusters",), 0, r"tree_clusters must be >= 1, got 0"),
        (("lorries",), 3, r"unknown key 'outdoor\.lorries'"),
    ],
)
def test_bad_outdoor_values_are_refused_by_name(spec_dict, path, value, match):
    d = copy.deepcopy(spec_dict)
    node = d["outdoor"]
    for key in path[:-1]:
        node = node[key]
    node[path[-1]] = value
    with pytest.raises(ValueError, match=match):
        world_spec_from_dict(d)


def test_same_seed_same_mjcf_other_seed_other_surroundings(spec):
    a, b, c = build_world(spec, 7), build_world(spec, 7), build_world(spec, 8)
    assert a.mjcf == b.mjcf
    assert a.layout == b.layout
    assert a.mjcf != c.mjcf
    assert a.layout.landmarks != c.layout.landmarks


@pytest.mark.parametrize("seed", range(6))
def test_surroundings_stand_outside_the_pavement_and_include_every_kind(spec, seed):
    world = build_world(spec, seed)
    kinds = {k for k, *_ in world.layout.landmarks}
    # buildings on two or three sides, so at least one row; the rest always finds room
    assert {"building", "tree", "car", "lamp_post", "bush"} <= kinds
    hx = spec.arena.size[0] / 2 + spec.outdoor.pavement_width
    hy = spec.arena.size[1] / 2 + spec.outdoor.pavement_width
    for kind, x, y, height in world.layout.landmarks:
        assert height > 0
        if kind == "lamp_post":  # on the pavement, off the asphalt
            assert abs(x) > spec.arena.size[0] / 2 or abs(y) > spec.arena.size[1] / 2
        else:
            assert abs(x) > hx or abs(y) > hy, (kind, x, y)
    # nothing inside the area: the occupancy sees a free drivable area
    assert world.layout.obstacles == () and world.layout.walls == ()
    assert np.isinf(world.layout.clearance([(0.0, 0.0), (2.5, 3.5)])).all()


def test_model_has_curbs_no_walls_a_sun_and_modest_geometry(spec, model):
    names = _geom_names(model)
    assert not [n for n in names if n.startswith("wall")]
    curbs = [model.geom(n) for n in names if n.startswith("curb")]
    assert len(curbs) == 4
    for g in curbs:
        assert g.contype[0] != 0 and g.conaffinity[0] != 0
        # low: the top of every curb at curb_height
        assert g.pos[2] + g.size[2] == pytest.approx(spec.arena.curb_height)
    # the surroundings are visual only: nothing but the curbs and the ground collides
    colliding = {
        n for i, n in enumerate(names) if model.geom_contype[i] | model.geom_conaffinity[i]
    }
    assert colliding == {g.name for g in curbs} | {"ground"}
    assert model.ngeom <= 250
    sun = model.light("sun")
    assert sun.type[0] == mujoco.mjtLightType.mjLIGHT_DIRECTIONAL
    assert not sun.castshadow[0]
    # the sun shines from azimuth 135 degrees, 40 degrees above the horizon (pointing away)
    az, el = math.radians(135.0), math.radians(40.0)
    expected = [-math.cos(el) * math.cos(az), -math.cos(el) * math.sin(az), -math.sin(el)]
    np.testing.assert_allclose(model.light_dir[sun.id], expected, atol=1e-3)
    # the other lights are the sky's, named apart from the sun
    lights = {model.light(i).name for i in range(model.nlight)}
    assert lights == {"sun", "sky0", "sky1", "sky2"}


@pytest.mark.parametrize("seed", range(4))
def test_a_road_passes_on_one_side_flat_and_visual_only_with_nothing_on_it(spec, seed):
    world = build_world(spec, seed)
    model = mujoco.MjModel.from_xml_string(world.mjcf)
    road = model.geom("road")
    assert road.contype[0] == 0 and road.pos[2] + road.size[2] < 0.01
    x0, x1, y0, y1 = world.lanes.road_rect()
    np.testing.assert_allclose(road.pos[:2], ((x0 + x1) / 2, (y0 + y1) / 2), atol=1e-3)
    # beyond the pavement, on the side the lanes name, and as long as they say
    hx, hy = spec.arena.size[0] / 2, spec.arena.size[1] / 2
    near = {"north": y0 - hy, "south": -hy - y1, "east": x0 - hx, "west": -hx - x1}
    assert near[world.lanes.road_side] > spec.outdoor.pavement_width
    assert max(x1 - x0, y1 - y0) == pytest.approx(world.lanes.length, abs=1e-3)
    for kind, x, y, _ in world.layout.landmarks:
        assert not (x0 <= x <= x1 and y0 <= y <= y1), (kind, x, y)


def test_markings_are_painted_lines_that_do_not_collide(spec_dict):
    model = mujoco.MjModel.from_xml_string(build_world(_with(spec_dict, boundary="markings")).mjcf)
    names = _geom_names(model)
    lines = [model.geom(n) for n in names if n.startswith("marking")]
    assert len(lines) == 4 and not [n for n in names if n.startswith(("curb", "wall"))]
    for g in lines:
        assert g.contype[0] == 0 and g.conaffinity[0] == 0
        assert g.pos[2] + g.size[2] < 0.01  # flat on the floor


def test_walls_boundary_on_the_outdoor_world_gives_panels(spec_dict):
    model = mujoco.MjModel.from_xml_string(build_world(_with(spec_dict, boundary="walls")).mjcf)
    assert len([n for n in _geom_names(model) if n.startswith("wall")]) == 16


@pytest.fixture(scope="module")
def curbs_env():
    env = OmniRoverEnv(world="paper_outdoor", panorama=_TINY)
    yield env
    env.close()


def test_rover_can_be_reset_at_every_corner_of_the_bounds(curbs_env):
    xmin, xmax, ymin, ymax = curbs_env.arena_bounds
    for x, y in [(xmin, ymin), (xmax, ymin), (xmax, ymax), (xmin, ymax)]:
        obs, info = curbs_env.reset(options={"pose": (x, y, 0.3)})
        assert obs.shape == (_TINY.height, _TINY.width, 3)
        for _ in range(3):  # standing still: no curb pushes it away
            _, _, _, _, info = curbs_env.step(np.zeros(2, np.float32))
        assert (info["x"], info["y"]) == pytest.approx((x, y), abs=0.01)
        assert info["yaw"] == pytest.approx(0.3, abs=0.01)


def _drive_out(env, pose, steps=30):
    """Drive straight ahead at 0.4 m/s for ``steps`` steps from ``pose``; the final info."""
    env.reset(options={"pose": pose})
    for _ in range(steps):
        _, _, _, _, info = env.step(np.array([0.4, 0.0], np.float32))
    return info


def test_curbs_stop_the_rover_and_markings_do_not(spec, spec_dict, curbs_env):
    hx = spec.arena.size[0] / 2
    # 3 s at 0.4 m/s would carry it 1.2 m, from x = 2.5 to 3.7 m, past the curb at 3.0 m
    stopped = _drive_out(curbs_env, (2.5, 0.0, 0.0))
    assert 2.6 < stopped["x"] < hx
    assert abs(stopped["y"]) < 0.1
    env = OmniRoverEnv(world=_with(spec_dict, boundary="markings"), panorama=_TINY)
    try:
        crossed = _drive_out(env, (2.5, 0.0, 0.0))
    finally:
        env.close()
    assert crossed["x"] > hx + 0.5


def test_panorama_from_the_centre_shows_asphalt_below_and_sky_between_things_above():
    env = OmniRoverEnv(world="paper_outdoor", panorama="paper_outdoor")
    try:
        obs, _ = env.reset(options={"pose": (0.0, 0.0, 0.0)})
    finally:
        env.close()
    assert obs.shape == (60, 600, 3)
    # the lowest row looks 20 degrees down: 2.7 m away, on the asphalt in every direction
    bottom = obs[-1].astype(int)
    assert (bottom.max(axis=1) - bottom.min(axis=1)).max() <= 10  # grey
    assert 30 < bottom.mean() < 110  # dark
    # the top row: blue sky over part of the horizon, facades and trees over the rest
    top = obs[0].astype(int)
    sky = (top[:, 2] > top[:, 0] + 20) & (top[:, 2] > 150)
    assert 0.05 < sky.mean() < 0.8
