"""Controller plug-ins: the protocol's errors name what is missing, a controller sees only the
rover's own sensors, the shipped run-and-tumble controller reaches goals on a cost without false
minima, and the leaderboard scores a method with a controller plug-in."""

from __future__ import annotations

import json
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import sfa_gym  # noqa: F401  (registers the envs)
from sfa_gym.navigation.evaluate import run_episodes, summarize
from sfa_gym.navigation.field import FeatureField
from sfa_gym.navigation.sensors import ROVER_SENSORS, Rover, SensorsOnly
from sfa_gym.plugins import PluginError, load_controller_plugin

ROOT = Path(__file__).resolve().parents[1]
RUN_AND_TUMBLE = ROOT / "baselines" / "controllers" / "run_and_tumble.py"

HEADER = "from dataclasses import dataclass\nimport numpy as np\n"
ARGS = "@dataclass(frozen=True)\nclass Args:\n    speed: float = 0.2\n"
CONTROLLER = """
class Straight:
    name = "straight"
    def __init__(self, speed):
        self.speed = speed
    def reset(self, obs, info):
        self.seen = sorted(info)
    def act(self, obs, info):
        return np.array([self.speed, 0.0, -1.0], dtype=np.float32)
"""
MAKE = "def make_controller(rover, weights, speed=0.2):\n    return Straight(speed)\n"


def _plugin(tmp_path: Path, text: str, name: str = "straight.py") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


ROVER = Rover(v_max=0.4, w_max=1.0, dt=0.1, range_angles=(0.0,))


def test_a_controller_file_is_refused_naming_what_is_missing(tmp_path):
    with pytest.raises(PluginError, match="no make_controller"):
        load_controller_plugin(_plugin(tmp_path, HEADER + ARGS + CONTROLLER))
    with pytest.raises(PluginError, match="no Args dataclass"):
        load_controller_plugin(_plugin(tmp_path, HEADER + CONTROLLER + MAKE))
    broken = HEADER + ARGS + "def make_controller(rover, weights, speed=0.2):\n    return 3\n"
    factory = load_controller_plugin(_plugin(tmp_path, broken))
    with pytest.raises(PluginError, match=r"not a controller.*\['name', 'reset', 'act'\]"):
        factory(ROVER, [1.0])
    with pytest.raises(FileNotFoundError, match="no controller file"):
        load_controller_plugin(tmp_path / "missing.py")
    factory = load_controller_plugin(_plugin(tmp_path, HEADER + ARGS + CONTROLLER + MAKE))
    with pytest.raises(ValueError, match="unknown argument 'sped'"):
        factory(ROVER, [1.0], {"sped": 1.0})
    assert factory.arguments({"speed": 0.3}) == {"speed": 0.3}
    assert factory.arguments({"speed": 1}) == {"speed": 1.0}  # a JSON int for a float field
    with pytest.raises(ValueError, match=r"straight\.py: argument speed must be float, got 'fast'"):
        factory(ROVER, [1.0], {"speed": "fast"})


def test_a_controller_sees_the_rover_sensors_and_no_ground_truth(tmp_path):
    spy = HEADER + ARGS + CONTROLLER.replace(
        "return np.array", "info['x']\n        return np.array"
    ) + MAKE  # fmt: skip
    env = gym.make("sfa_gym/OmniRoverNav-v0", feature_field=_position_field())
    try:
        obs, info = env.reset(seed=3)
        assert {"x", "y", "goal"} <= set(info)  # the env reports the ground truth ...
        controller = load_controller_plugin(_plugin(tmp_path, spy))(Rover.of(env), [1.0, 1.0])
        controller.reset(obs, info)
        assert controller.controller.seen == sorted(ROVER_SENSORS)  # ... the controller not
        with pytest.raises(KeyError, match="'x'"):
            controller.act(obs, info)
    finally:
        env.close()
    assert SensorsOnly.sensors({"odometry": 1, "range": 2, "x": 3}) == {"odometry": 1, "range": 2}


def _position_field() -> FeatureField:
    """A field whose features are the position itself: the cost is the squared distance to
    the goal, with no false minimum."""
    xmin, xmax, ymin, ymax = -3.0, 3.0, -3.0, 3.0
    xs, ys = np.linspace(xmin, xmax, 13), np.linspace(ymin, ymax, 13)
    gx, gy = np.meshgrid(xs, ys)
    return FeatureField(np.stack([gx, gy], axis=-1), (xmin, xmax, ymin, ymax))


def test_run_and_tumble_reaches_goals_on_a_cost_without_false_minima():
    env = gym.make("sfa_gym/OmniRoverNav-v0", feature_field=_position_field())
    try:
        assert env.unwrapped.arena_bounds == pytest.approx((-3.0, 3.0, -3.0, 3.0))
        factory = load_controller_plugin("run_and_tumble")  # the built-in, by name
        assert factory.path == RUN_AND_TUMBLE
        episodes = run_episodes(env, factory(Rover.of(env), [1.0, 1.0]), range(20), False)
        again = run_episodes(env, factory(Rover.of(env), [1.0, 1.0]), range(3), False)
    finally:
        env.close()
    scores = summarize(episodes)["all"]
    # a hill climber with random turns keeps only moves that lowered the cost: it ends much
    # closer than it started and often arrives, slowly (SPL far below the gradient's); its 60 s
    # run out on the longer episodes
    assert scores["success"]["mean"] >= 0.3
    assert 0.0 < scores["spl"]["mean"] < 0.5
    final = np.array([e["final_distance"] for e in episodes])
    start = np.array([e["shortest_path"] for e in episodes])
    assert final.mean() < 0.5 * start.mean() and np.mean(final < start) >= 0.9
    assert [e["final_distance"] for e in again] == [e["final_distance"] for e in episodes[:3]]


def test_the_leaderboard_scores_a_method_with_a_controller_plugin(tmp_path, capsys):
    from test_leaderboard import MEAN_COLOUR_PLUGIN, NAV_TINY, TINY, _write_track

    from sfa_gym.leaderboard.sweep import run_sweep
    from sfa_gym.leaderboard.tracks import load_track

    nav = load_track(_write_track(tmp_path / "tracks", NAV_TINY))
    method = _plugin(tmp_path, MEAN_COLOUR_PLUGIN, "mean_colour.py")
    results = tmp_path / "results"
    common = {"cache_dir": tmp_path / "cache", "verbose": False}
    (path,) = run_sweep(
        [nav], [(method, {})], results, controller=(RUN_AND_TUMBLE, {"patience": 3}), **common
    )
    assert path.name == "mean_colour+run_and_tumble[patience=3].json"
    (result,) = json.loads(path.read_text())["results"]
    (task,) = [json.loads(p.read_text()) for p in (results / "tasks").rglob("*.json")]
    controller = task["identity"]["controller"]
    assert controller["name"] == "run_and_tumble" and controller["args"]["patience"] == 3
    assert len(controller["sha256"]) == 64
    assert task["output"]["scores"]["episodes"] == 2
    assert 0.0 <= result["score"]["mean"] <= 1.0
    grid = load_track(_write_track(tmp_path / "tracks", TINY))
    with pytest.raises(ValueError, match=r"navigation tracks only; \['tiny'\]"):
        run_sweep([grid], [(method, {})], results, controller=(RUN_AND_TUMBLE, {}), **common)

    from sfa_gym.cli.main import main

    argv = ["leaderboard", "run", "--method", str(method), "--controller", str(RUN_AND_TUMBLE)]
    argv += ["--tracks", str(tmp_path / "tracks"), "--results", str(results), "--track", "tiny"]
    assert main(argv) != 0  # the CLI refuses it too, with the same message
    assert "navigation tracks only" in capsys.readouterr().err
