"""render(): the top-down view with the navigation goal and path, where they stand in the world;
observations untouched by rendering; "human" mode's window, and its clear error without one."""

from __future__ import annotations

import sys

import gymnasium as gym
import numpy as np
import pytest

import sfa_gym  # noqa: F401  (registers the ids)
from sfa_gym.navigation.env import OmniRoverNavEnv
from sfa_gym.sim.camera import PanoramaSpec
from sfa_gym.sim.env import OmniRoverEnv
from sfa_gym.sim.window import NoWindowError

SMALL = PanoramaSpec(width=120, height=16)
SIZE = 128
START = (-2.0, -2.0, 0.0)
GOAL = (2.0, 1.5, 0.0)
FORWARD = np.array([0.4, 0.0, -1.0], np.float32)


@pytest.fixture(scope="module")
def nav():
    env = OmniRoverNavEnv(panorama=SMALL, render_mode="rgb_array", render_size=SIZE)
    yield env
    env.close()


def _pixel(env, x, y):
    row, col = env.view.pixel([(x, y)])[0]
    return int(row), int(col)


def _changed(env, frame):
    """Where ``frame`` differs from the same state rendered without marks."""
    return np.any(frame != env.view.render(env.data), axis=2)


def _is_green(rgb):
    r, g, b = (int(v) for v in rgb)
    return g > 150 and g > r + 60 and g > b + 60


def _is_yellow(rgb):
    r, g, b = (int(v) for v in rgb)
    return r > 150 and g > 120 and b < 80


def test_projection_puts_the_arena_centre_mid_picture_and_world_y_up(nav):
    (row, col), (row_up, col_right) = nav.view.pixel([(0.0, 0.0), (1.0, 1.0)])
    assert row == pytest.approx(SIZE / 2) and col == pytest.approx(SIZE / 2)
    assert row_up < row and col_right > col  # +y is up in the picture, +x right


def test_the_goal_is_drawn_where_it_stands(nav):
    nav.reset(seed=0, options={"start": START, "goal": GOAL})
    frame = nav.render()
    assert frame.shape == (SIZE, SIZE, 3) and frame.dtype == np.uint8
    changed = _changed(nav, frame)
    gx, gy, _ = GOAL
    radius = nav.success_radius
    # inside the disc (both sides of the heading line) green; beyond its rim, against the
    # heading, the arena as it is
    for dx, dy in [(0.0, 0.6), (0.0, -0.6), (-0.6, 0.0), (-0.4, 0.4)]:
        row, col = _pixel(nav, gx + dx * radius, gy + dy * radius)
        assert changed[row, col] and _is_green(frame[row, col]), (dx, dy, frame[row, col])
    row, col = _pixel(nav, gx - 1.6 * radius, gy)
    assert not changed[row, col]
    # only the goal and nothing else before the rover moves: the marks stay near the goal
    rows, cols = np.nonzero(changed)
    (grow, gcol), (edge, _) = nav.view.pixel([(gx, gy), (gx, gy + radius + 0.2)])
    assert np.hypot(rows - grow, cols - gcol).max() <= (grow - edge) + 1.5


def test_the_path_grows_with_the_steps(nav):
    nav.reset(seed=0, options={"start": START, "goal": GOAL})
    counts = [_changed(nav, nav.render()).sum()]
    xs = []
    for _ in range(3):
        for _ in range(8):
            _, _, _, _, info = nav.step(FORWARD)
            xs.append(info["x"])
        counts.append(_changed(nav, nav.render()).sum())
    assert counts[0] < counts[1] < counts[2] < counts[3], counts
    frame = nav.render()
    # a point driven over, behind the rover (0.5 m long) now: the path's yellow
    x_behind = xs[4]
    assert xs[-1] - x_behind > 0.5
    row, col = _pixel(nav, x_behind, START[1])
    assert _is_yellow(frame[row, col]), frame[row, col]
    # a new episode starts a new path
    nav.reset(seed=0, options={"start": START, "goal": GOAL})
    assert _changed(nav, nav.render()).sum() == counts[0]


def test_a_long_path_keeps_to_the_scene_and_renders(nav):
    nav.reset(seed=0, options={"start": (0.0, 0.0, 0.0), "goal": GOAL})
    turn = np.array([0.3, 1.0, -1.0], np.float32)
    for _ in range(500):  # circles: more points than the view draws
        nav.step(turn)
    changed = _changed(nav, nav.render())
    row, col = _pixel(nav, 0.0, 0.0)
    assert changed.sum() > 50 and changed[row - 3 : row + 4, col - 3 : col + 4].any()


@pytest.mark.parametrize("make", [OmniRoverEnv, OmniRoverNavEnv])
def test_rendering_changes_no_observation_and_repeats_with_the_seed(make):
    plain = make(panorama=SMALL)
    drawn = [make(panorama=SMALL, render_mode="rgb_array", render_size=SIZE) for _ in range(2)]
    envs = [plain, *drawn]
    try:
        results = [env.reset(seed=7)[0] for env in envs]
        frames: list[list[np.ndarray]] = [[], []]
        rng = np.random.default_rng(0)
        for _ in range(6):
            action = rng.uniform(plain.action_space.low, plain.action_space.high)
            action = action.astype(np.float32)
            if len(action) == 3:
                action[2] = -1.0  # no stop
            steps = [env.step(action) for env in envs]
            for frame_list, env in zip(frames, drawn, strict=True):
                frame_list.append(env.render())
            results += [s[0] for s in steps]
            for s in steps[1:]:
                assert s[1:4] == steps[0][1:4]
        n = len(envs)
        for i in range(0, len(results), n):
            first = results[i]
            for other in results[i + 1 : i + n]:
                if isinstance(first, dict):
                    assert first.keys() == other.keys()
                    for key in first:
                        np.testing.assert_array_equal(first[key], other[key])
                else:
                    np.testing.assert_array_equal(first, other)
        for a, b in zip(*frames, strict=True):
            np.testing.assert_array_equal(a, b)
        assert not np.array_equal(frames[0][0], frames[0][-1])  # the rover moved in the picture
    finally:
        for env in envs:
            env.close()


@pytest.mark.parametrize("env_id", ["sfa_gym/OmniRover-v0", "sfa_gym/OmniRoverNav-v0"])
@pytest.mark.parametrize("control_dt", [0.1, 0.05])
def test_metadata_names_both_render_modes_and_the_step_rate(env_id, control_dt):
    env = gym.make(env_id, control_dt=control_dt)
    assert env.metadata["render_modes"] == ["human", "rgb_array"]
    assert env.metadata["render_fps"] == pytest.approx(1.0 / control_dt)
    env.close()


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="a display is an X11 matter")
@pytest.mark.parametrize("env_id", ["sfa_gym/OmniRover-v0", "sfa_gym/OmniRoverNav-v0"])
def test_human_mode_without_a_display_fails_at_construction_saying_so(env_id, monkeypatch):
    monkeypatch.setenv("DISPLAY", "")
    monkeypatch.setenv("WAYLAND_DISPLAY", "")
    monkeypatch.setenv("SDL_VIDEODRIVER", "x11")  # names the display it lacks
    with pytest.raises(NoWindowError, match=r"no display \(DISPLAY .*xvfb-run.*rgb_array"):
        gym.make(env_id, render_mode="human")


def test_human_mode_on_a_display_without_a_server_says_so_at_the_first_frame(monkeypatch):
    pytest.importorskip("pygame")
    monkeypatch.setenv("DISPLAY", ":4242")  # no X server listens there
    monkeypatch.delenv("SDL_VIDEODRIVER", raising=False)
    env = OmniRoverEnv(panorama=SMALL, render_mode="human", render_size=64)
    try:
        with pytest.raises(NoWindowError, match="':4242'"):
            env.reset(seed=0)
    finally:
        env.close()


def test_human_mode_without_pygame_names_the_extra(monkeypatch):
    monkeypatch.setenv("SDL_VIDEODRIVER", "dummy")
    monkeypatch.setitem(sys.modules, "pygame", None)  # what Python does when it is missing
    with pytest.raises(
        NoWindowError, match=r"pygame is not installed: pip install 'sfa-gym\[human\]'"
    ):
        OmniRoverNavEnv(render_mode="human")


def test_human_mode_shows_each_step_in_the_window(monkeypatch):
    pytest.importorskip("pygame")
    monkeypatch.setenv("SDL_VIDEODRIVER", "dummy")  # a real window of SDL, without a display
    env = gym.make("sfa_gym/OmniRoverNav-v0", panorama=SMALL, render_mode="human", render_size=96)
    nav = env.unwrapped
    try:
        assert nav.window.shown() is None  # the window opens with the first frame
        env.reset(seed=3)
        first = nav.window.shown()
        assert first.shape == (96, 96, 3)
        for _ in range(3):
            env.step(FORWARD)
        shown = nav.window.shown()
        np.testing.assert_array_equal(shown, nav.view.render(nav.data, **nav._marks()))
        assert not np.array_equal(shown, first)
        assert env.render() is None  # human mode shows; it returns nothing
    finally:
        env.close()
    assert nav.window.shown() is None


def test_closing_the_window_drops_later_frames_and_the_episode_goes_on(monkeypatch):
    pygame = pytest.importorskip("pygame")
    monkeypatch.setenv("SDL_VIDEODRIVER", "dummy")
    env = OmniRoverEnv(panorama=SMALL, render_mode="human", render_size=64)
    try:
        env.reset(seed=0)
        assert env.window.shown() is not None
        pygame.event.post(pygame.event.Event(pygame.QUIT))  # the user closes the window
        observation, *_ = env.step(np.array([0.4, 0.0], np.float32))
        assert env.window.closed and env.window.shown() is None
        assert observation.shape == env.observation_space.shape
        env.step(np.array([0.4, 0.0], np.float32))
        assert env.window.shown() is None  # not opened again
    finally:
        env.close()
