"""OmniRoverEnv: Gymnasium/SB3 contract, determinism, physics, poses, errors, vector envs."""

from __future__ import annotations

import dataclasses
import math
import multiprocessing
import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import sfa_gym  # noqa: F401  (registers the ids)
from sfa_gym.registration import ENV_IDS, NAV_ENV_IDS
from sfa_gym.sim.camera import PanoramaSpec
from sfa_gym.sim.env import OmniRoverEnv
from sfa_gym.sim.worlds import ObstaclesSpec, load_world_spec

# Small panoramas keep the physics and pose tests fast; the registered ids are checked in full.
SMALL = PanoramaSpec(width=120, height=16)


@pytest.fixture(scope="module")
def env():
    e = OmniRoverEnv(panorama=SMALL)
    yield e
    e.close()


def _drive(env, pose, action, seconds):
    _, info = env.reset(options={"pose": pose})
    yaws = [info["yaw"]]
    for _ in range(round(seconds / env.control_dt)):
        _, _, _, _, info = env.step(np.asarray(action, dtype=np.float32))
        yaws.append(info["yaw"])
    turned = float(np.unwrap(yaws)[-1] - yaws[0])
    return info, turned


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_gymnasium_and_sb3_checkers_pass(env_id, monkeypatch):
    from stable_baselines3.common.env_checker import check_env as sb3_check_env

    # Gymnasium's checker also makes the env in each render mode: "human" opens its window
    # through SDL's dummy video driver, which needs no display
    monkeypatch.setenv("SDL_VIDEODRIVER", "dummy")
    env = gym.make(env_id)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # SB3 recommends a [-1, 1] action box; ours is physical
        check_env(env.unwrapped)
        sb3_check_env(env.unwrapped, warn=True)
    obs, info = env.reset(seed=0)
    assert obs.shape == env.observation_space.shape
    assert env.observation_space.contains(obs)
    assert set(info) >= {"x", "y", "yaw"}
    env.close()


def test_registered_ids_have_the_paper_resolutions_and_time_limit():
    assert gym.spec("sfa_gym/OmniRover-v0").max_episode_steps == 1000
    sim = gym.make("sfa_gym/OmniRover-v0")
    outdoor = gym.make("sfa_gym/OmniRoverOutdoorCam-v0")
    assert sim.observation_space.shape == (40, 350, 3)
    assert outdoor.observation_space.shape == (60, 600, 3)
    assert sim.get_wrapper_attr("layout") == outdoor.get_wrapper_attr("layout")  # the same world
    sim.close()
    outdoor.close()


def test_registration_is_idempotent():
    from sfa_gym.registration import register_envs

    before = {k: v for k, v in gym.registry.items() if k.startswith("sfa_gym/")}
    register_envs()
    register_envs()
    after = {k: v for k, v in gym.registry.items() if k.startswith("sfa_gym/")}
    assert before.keys() == after.keys() == set(ENV_IDS) | set(NAV_ENV_IDS)


def test_same_seeds_give_bit_identical_panoramas():
    actions = np.random.default_rng(0).uniform([-0.4, -1.0], [0.4, 1.0], (50, 2)).astype(np.float32)
    runs = []
    for _ in range(2):
        e = OmniRoverEnv(world_seed=5, panorama=SMALL)
        obs, info = e.reset(seed=11)
        frames, poses = [obs], [info]
        for a in actions:
            obs, reward, terminated, truncated, info = e.step(a)
            frames.append(obs)
            poses.append(info)
            assert reward == 0.0 and not terminated and not truncated
        e.close()
        runs.append((np.stack(frames), poses))
    assert np.array_equal(runs[0][0], runs[1][0])
    assert runs[0][1] == runs[1][1]
    # the rover moved and the views changed, so the equality is not trivial
    xy = np.array([(p["x"], p["y"]) for p in poses])
    path = np.linalg.norm(np.diff(xy, axis=0), axis=1).sum()
    assert path > 0.3
    assert not np.array_equal(runs[0][0][0], runs[0][0][-1])


def test_other_world_seed_gives_other_world_and_panoramas(env):
    other = OmniRoverEnv(world_seed=1, panorama=SMALL)
    assert other.mjcf != env.mjcf
    pose = {"pose": (0.5, -0.5, 0.3)}
    a, _ = env.reset(options=pose)
    b, _ = other.reset(options=pose)
    other.close()
    assert np.abs(a.astype(int) - b.astype(int)).mean() > 10


def test_reset_places_the_rover_exactly_at_rest(env):
    for pose in [(0.0, 0.0, 0.0), (-2.9, 2.9, math.pi), (1.234, -2.5, -3.1), (3.0, -3.0, 1.0)]:
        _, info = env.reset(options={"pose": pose})
        assert info["x"] == pytest.approx(pose[0], abs=1e-9)
        assert info["y"] == pytest.approx(pose[1], abs=1e-9)
        assert math.cos(info["yaw"] - pose[2]) == pytest.approx(1.0, abs=1e-12)
        assert -math.pi < info["yaw"] <= math.pi
        assert info["t"] == 0.0
        # standing still, the rover neither drops nor creeps
        _, _, _, _, info = env.step(np.zeros(2, np.float32))
        assert math.hypot(info["x"] - pose[0], info["y"] - pose[1]) < 1e-3
        assert math.cos(info["yaw"] - pose[2]) == pytest.approx(1.0, abs=1e-6)
    _, info = env.reset(options={"pose": (0, 0, math.pi)})
    assert info["yaw"] == pytest.approx(math.pi)  # wrapped to (-pi, pi]


def test_random_starts_come_from_the_reset_seed(env):
    xmin, xmax, ymin, ymax = env.arena_bounds
    _, a = env.reset(seed=3)
    _, b = env.reset(seed=3)
    _, c = env.reset(seed=4)
    assert a == b and a != c
    for info in (a, c):
        assert xmin <= info["x"] <= xmax and ymin <= info["y"] <= ymax


def test_random_starts_avoid_obstacles():
    spec = dataclasses.replace(load_world_spec("paper_sim"), obstacles=ObstaclesSpec(count=4))
    e = OmniRoverEnv(world=spec, panorama=SMALL)
    assert len(e.layout.obstacles) == 4
    half_diagonal = math.hypot(*e.rover.chassis_size[:2]) / 2
    for seed in range(6):
        _, info = e.reset(seed=seed)
        for x, y, r in e.layout.obstacles:
            assert math.hypot(info["x"] - x, info["y"] - y) > r + half_diagonal
    e.close()


def test_driving_forward_covers_v_times_t(env):
    v, seconds = 0.4, 3.0
    info, turned = _drive(env, (-2.0, 0.5, 0.0), (v, 0.0), seconds)
    assert info["x"] + 2.0 == pytest.approx(v * seconds, rel=0.1)
    assert abs(info["y"] - 0.5) < 0.05
    assert abs(turned) < 0.05
    info, _ = _drive(env, (0.0, 0.0, math.pi / 2), (-v, 0.0), seconds)
    assert -info["y"] == pytest.approx(v * seconds, rel=0.1)


@pytest.mark.parametrize("w", [0.5, -1.0])
def test_turning_in_place_turns_w_times_t(env, w):
    info, turned = _drive(env, (0.0, 0.0, 0.0), (0.0, w), 3.0)
    assert turned == pytest.approx(w * 3.0, rel=0.15)
    assert math.hypot(info["x"], info["y"]) < 0.05


def test_actions_beyond_the_box_are_clipped(env):
    fast, _ = _drive(env, (-2.0, 0.0, 0.0), (5.0, 0.0), 1.0)
    limit, _ = _drive(env, (-2.0, 0.0, 0.0), (0.4, 0.0), 1.0)
    assert fast["x"] == pytest.approx(limit["x"], abs=1e-9)


def test_walls_stop_the_rover(env):
    info, _ = _drive(env, (2.5, 0.0, 0.0), (0.4, 0.0), 4.0)
    wall = env.world_spec.arena.size[0] / 2
    assert info["x"] < wall - 0.2  # the chassis (0.25 m half length) stays inside


def test_turning_shifts_panorama_columns(env):
    width = SMALL.width
    k = 10
    a, _ = env.reset(options={"pose": (0.3, 0.2, 0.0)})
    b, _ = env.reset(options={"pose": (0.3, 0.2, 2 * math.pi * k / width)})
    diffs = [np.abs(np.roll(a, -j, axis=1).astype(int) - b).mean() for j in range(width)]
    assert int(np.argmin(diffs)) == k
    assert diffs[k] < 0.5 * np.median(diffs)


@pytest.mark.parametrize("preset", ["paper_sim", "paper_outdoor"])
def test_turning_changes_no_row_of_the_shifted_panorama(preset):
    """At the registered resolutions, in the default world: a turn by k columns that is not a
    multiple of a quarter turn changes no row of the shifted-back panorama by more than 2 grey
    levels on average (the views turning with the rover gave 8-12 just below the horizon); in
    fact by nothing."""
    e = OmniRoverEnv(panorama=preset)
    try:
        width = e.panorama.width
        for x, y, yaw in [(0.7, -1.1, 0.4), (-1.9, 1.3, -2.0)]:
            base, _ = e.reset(options={"pose": (x, y, yaw)})
            for k in (5, 17, 33, 70):
                turned, _ = e.reset(options={"pose": (x, y, yaw + 2 * math.pi * k / width)})
                shifted = np.roll(turned, k, axis=1).astype(np.float64)
                assert np.abs(shifted - base).mean(axis=(1, 2)).max() <= 2.0
                np.testing.assert_array_equal(shifted, base)
    finally:
        e.close()


def test_grid_positions_and_bounds(env):
    assert env.arena_bounds == (-3.0, 3.0, -3.0, 3.0)
    grid = env.grid_positions()
    assert grid.shape == (900, 2)
    xs = np.unique(grid[:, 0])
    assert len(xs) == 30 and np.allclose(np.diff(xs), 0.2)
    assert grid.min() > -3.0 and grid.max() < 3.0
    with pytest.raises(ValueError, match="0"):
        env.grid_positions(0)


def test_top_down_render():
    e = OmniRoverEnv(panorama=SMALL, render_mode="rgb_array", render_size=64)
    e.reset(options={"pose": (0.0, 0.0, 0.0)})
    top = e.render()
    assert top.shape == (64, 64, 3) and top.dtype == np.uint8
    assert top.std() > 10
    e.close()
    e.close()  # closing twice is allowed


def test_dt_is_the_control_period_and_reachable_through_wrappers():
    wrapped = gym.make("sfa_gym/OmniRover-v0", control_dt=0.05, panorama=SMALL)
    try:
        assert wrapped.get_wrapper_attr("dt") == 0.05 == wrapped.unwrapped.control_dt
        assert wrapped.get_wrapper_attr("arena_bounds") == (-3.0, 3.0, -3.0, 3.0)
        _, info = wrapped.reset(seed=0)
        _, _, _, _, info2 = wrapped.step(np.zeros(2, np.float32))
        assert info2["t"] - info["t"] == pytest.approx(wrapped.get_wrapper_attr("dt"))
    finally:
        wrapped.close()


@pytest.mark.parametrize(
    "kwargs, size",
    [
        ({"panorama": PanoramaSpec(width=20000, height=40)}, "25472x13824"),
        ({"render_mode": "rgb_array", "render_size": 20000}, "20000x20000"),
    ],
)
def test_sizes_beyond_the_framebuffer_fail_at_construction(kwargs, size):
    from sfa_gym.sim import gl

    with pytest.raises(ValueError, match=rf"{size}.*at most {gl.MAX_FRAMEBUFFER_SIDE}x"):
        OmniRoverEnv(**kwargs)


def test_bad_arguments_raise_clear_errors(env):
    with pytest.raises(TypeError, match="flavour"):
        gym.make("sfa_gym/OmniRover-v0", flavour=1)
    with pytest.raises(TypeError, match="flavour"):
        OmniRoverEnv(flavour=1)
    for name, value in [("v_max", 0.0), ("w_max", -1.0), ("control_dt", 0.0)]:
        with pytest.raises(ValueError, match=name):
            OmniRoverEnv(**{name: value})
    with pytest.raises(ValueError, match="0.0123"):
        OmniRoverEnv(control_dt=0.0123)
    with pytest.raises(ValueError, match="fisheye"):
        OmniRoverEnv(panorama="fisheye")
    with pytest.raises(ValueError, match="width"):
        OmniRoverEnv(panorama=PanoramaSpec(width=0))
    with pytest.raises(ValueError, match="render_mode.*'movie'"):
        OmniRoverEnv(render_mode="movie")
    with pytest.raises(ValueError, match="atlantis"):
        OmniRoverEnv(world="atlantis")
    env.reset(seed=0)
    with pytest.raises(ValueError, match=r"\(3,\)"):
        env.step(np.zeros(3, np.float32))
    with pytest.raises(ValueError, match="finite"):
        env.step(np.array([np.nan, 0.0], np.float32))
    with pytest.raises(ValueError, match="outside"):
        env.reset(options={"pose": (5.0, 0.0, 0.0)})
    with pytest.raises(ValueError, match="heading"):
        env.reset(options={"heading": 1.0})


@pytest.mark.parametrize(
    "mode, vector_kwargs",
    [("sync", {}), ("async", {"context": "spawn"})],
)
def test_vector_envs_return_panoramas_and_poses(mode, vector_kwargs):
    venv = gym.make_vec(
        "sfa_gym/OmniRover-v0",
        num_envs=2,
        vectorization_mode=mode,
        vector_kwargs=vector_kwargs,
        panorama=SMALL,
    )
    obs, info = venv.reset(seed=7)
    assert obs.shape == (2, SMALL.height, SMALL.width, 3)
    obs, reward, terminated, truncated, info = venv.step(np.array([[0.4, 0.0], [0.0, 1.0]]))
    assert obs.shape == (2, SMALL.height, SMALL.width, 3) and obs.dtype == np.uint8
    for key in ("x", "y", "yaw"):
        assert info[key].shape == (2,)
    assert not np.array_equal(obs[0], obs[1])
    venv.close()


@pytest.mark.skipif(
    multiprocessing.get_start_method() != "fork",
    reason="only a forking start method inherits a used GL driver",
)
def test_forking_after_rendering_fails_clearly_instead_of_hanging(env):
    env.reset(seed=0)  # this process has rendered
    venv = gym.make_vec(
        "sfa_gym/OmniRover-v0", num_envs=1, vectorization_mode="async", panorama=SMALL
    )
    with pytest.raises(RuntimeError, match="spawn"):
        venv.reset(seed=0)
    venv.close()


def test_a_pose_inside_an_obstacle_is_refused():
    e = OmniRoverEnv(world="paper_sim_obstacles", panorama=SMALL)
    try:
        x, y, radius = e.layout.obstacles[0]
        with pytest.raises(ValueError, match=r"from an obstacle or interior wall"):
            e.reset(options={"pose": (x, y, 0.0)})
        # just outside the obstacle's circle is still too close for the rover's footprint
        edge = (x + radius + 0.5 * e.rover.footprint_radius, y, 0.0)
        if e.layout.bounds[0] <= edge[0] <= e.layout.bounds[1]:
            with pytest.raises(ValueError, match="footprint radius"):
                e.reset(options={"pose": edge})
        free = e.grid_positions(9)[e.layout.clearance(e.grid_positions(9)) > 1.0][0]
        _, info = e.reset(options={"pose": (*free, 0.0)})
        assert (info["x"], info["y"]) == pytest.approx(tuple(free), abs=0.01)
    finally:
        e.close()
