"""Benchmark: what a controller that acts on panoramas costs per navigation step.

The same episodes of the open arena (a random driver with a fixed seed and no stop, so that
every variant steps the same physics for the full 600 steps) run

* on a feature field only (what every feature controller costs: physics, no rendering);
* with ``Capabilities(panoramas=True)``: the episode runner renders the panorama at every step
  and the goal's once per episode (:func:`sfa_gym.navigation.evaluate.run_episode`);
* the average-landmark-vector controller in this process and in its worker process (the
  leaderboard's way: every step's panoramas cross the process boundary).

Prints steps per second (wall clock) and the time of a 600-step episode for each. Backs
docs/notes/2026-11-27-homing.md.

Usage (from the repository root)::

    .venv/bin/python -m eval.benchmarks.bench_homing --episodes 3
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

import sfa_gym  # noqa: F401  (registers the envs)
from sfa_gym.capabilities import Capabilities
from sfa_gym.navigation.controllers import RandomController
from sfa_gym.navigation.evaluate import run_episodes
from sfa_gym.navigation.field import FeatureField
from sfa_gym.navigation.sensors import Rover

CONTROLLERS = Path(__file__).resolve().parents[2] / "baselines" / "controllers"
ALV = CONTROLLERS / "average_landmark_vector.py"


class Driver(RandomController):
    """The random driver that never stops, with or without panoramas."""

    def __init__(self, env: Any, panoramas: bool) -> None:
        super().__init__(env.unwrapped.v_max, env.unwrapped.w_max, stop_probability=0.0)
        self.capabilities = Capabilities(panoramas=panoramas)


def _timed(env: Any, controller: Any, seeds: range) -> tuple[float, int]:
    started = time.perf_counter()
    episodes = run_episodes(env, controller, seeds, progress=False)
    return time.perf_counter() - started, sum(e["steps"] for e in episodes)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--episodes", type=int, default=3)
    options = parser.parse_args()
    field = FeatureField(np.zeros((13, 13, 1)), (-3.0, 3.0, -3.0, 3.0))
    env = gym.make("sfa_gym/OmniRoverNav-v0", feature_field=field)
    seeds = range(50000, 50000 + options.episodes)
    rows = [
        ("feature field only", Driver(env, panoramas=False)),
        ("with panoramas", Driver(env, panoramas=True)),
    ]
    from sfa_gym.plugins import load_controller_plugin
    from sfa_gym.sandbox import IsolatedController

    rows.append(("ALV, in process", load_controller_plugin(ALV)(Rover.of(env), [1.0])))
    isolated = IsolatedController(ALV, Rover.of(env), [1.0])
    rows.append(("ALV, worker process", isolated))
    print("| variant | steps/s | s per 600-step episode |\n|---|---|---|")
    try:
        for label, controller in rows:
            seconds, steps = _timed(env, controller, seeds)
            print(f"| {label} | {steps / seconds:.0f} | {600 * seconds / steps:.1f} |")
    finally:
        isolated.close()
        env.close()


if __name__ == "__main__":
    main()
