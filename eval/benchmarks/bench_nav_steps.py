"""Benchmark: steps per second of the navigation env in feature-field mode, per core.

Reinforcement learning needs millions of steps; rendering a panorama costs ~8-11 ms, so the
navigation env can read the rotation-averaged features from a :class:`FeatureField` instead and
step physics only. Target: >= 2000 env steps/s per core. In one process, on one thread:

1. **Reference**: the physics alone, ``mujoco.mj_step`` for one control period (the env's
   ``frame_skip`` substeps) on the same model: what no env step can beat.
2. **Field mode**: ``gym.make(id, feature_field=...)`` with its registered wrappers (time limit,
   order and passive checkers), uniformly random actions (stop never pressed), resets at the
   end of each episode included (each draws a start and a goal, and where obstacles or walls
   stand in the arena solves the goal's distance map, one Dijkstra over the occupancy grid:
   :class:`~sfa_gym.navigation.distance_map.GeodesicMap`).
3. **Field mode + controller**: the same with the slow-feature-gradient controller choosing
   the actions (its least-squares fit every step).
4. **Rendered mode** for scale: the env rendering the current panorama every step (few steps).

The machine is shared, and its load changes within seconds: the first three run interleaved,
in blocks of ``--block`` steps in turn, so that each sees the same load and their ratios hold
even when the absolute rates do not. Printed: steps/s, the ratio to the physics and the time
an env step adds to the physics (us). The field is 8 features at 0.1 m over the arena; its
values do not change the cost of a query, so they are drawn at random instead of rendered.
``--json`` writes the figures.

Backs docs/speed.md and docs/navigation.md (steps per second in feature-field mode).

Usage (from the repository root)::

    .venv/bin/python -m eval.benchmarks.bench_nav_steps          # the three navigation envs, ~2 min
    .venv/bin/python -m eval.benchmarks.bench_nav_steps --env sfa_gym/OmniRoverNavMaze-v0
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")  # per core: no hidden threads in numpy's BLAS

import gymnasium as gym  # noqa: E402
import numpy as np  # noqa: E402
import tyro  # noqa: E402

import sfa_gym  # noqa: E402, F401  (registers the ids)
from sfa_gym.files import write_json_atomic
from sfa_gym.navigation.controllers import GradientController  # noqa: E402
from sfa_gym.navigation.field import FeatureField  # noqa: E402

ENVS = (
    "sfa_gym/OmniRoverNav-v0",
    "sfa_gym/OmniRoverNavObstacles-v0",
    "sfa_gym/OmniRoverNavMaze-v0",
)


def random_field(env_id: str, spacing: float = 0.1, k: int = 8, seed: int = 0) -> FeatureField:
    xmin, xmax, ymin, ymax = gym.make(env_id).unwrapped.arena_bounds
    nx, ny = round((xmax - xmin) / spacing) + 1, round((ymax - ymin) / spacing) + 1
    values = np.random.default_rng(seed).normal(size=(ny, nx, k))
    return FeatureField(values, (xmin, xmax, ymin, ymax))


class _Runner:
    """Steps one env (or the bare physics) in blocks, keeping its episode between blocks."""

    def __init__(self, env: gym.Env | None, physics=None, controller=None) -> None:
        self.env, self.physics, self.controller = env, physics, controller
        self.rng = np.random.default_rng(0)
        self.episode, self.seconds, self.steps = 0, 0.0, 0
        if env is not None:
            self.obs, self.info = env.reset(seed=0)
            if controller is not None:
                controller.reset(self.obs, self.info)

    def run(self, steps: int) -> None:
        started = time.perf_counter()
        if self.physics is not None:
            import mujoco

            model, data, skip = self.physics
            for _ in range(steps):
                mujoco.mj_step(model, data, nstep=skip)
        else:
            for _ in range(steps):
                self._step()
        self.seconds += time.perf_counter() - started
        self.steps += steps

    def _step(self) -> None:
        env, controller = self.env, self.controller
        if controller is None:
            action = self.rng.uniform(env.action_space.low, env.action_space.high)
            action = action.astype(np.float32)
            action[2] = -1.0  # keep driving: the stop action would end most episodes at once
        else:
            action = controller.act(self.obs, self.info)
        self.obs, _, terminated, truncated, self.info = env.step(action)
        if terminated or truncated:
            self.episode += 1
            self.obs, self.info = env.reset(seed=self.episode)
            if controller is not None:
                controller.reset(self.obs, self.info)

    @property
    def rate(self) -> float:
        return self.steps / self.seconds


def measure(env_id: str, steps: int, block: int, rendered_steps: int) -> list[tuple[str, float]]:
    field = random_field(env_id)
    bare = gym.make(env_id).unwrapped
    bare.reset(seed=0)
    env = gym.make(env_id, feature_field=field)
    driven = gym.make(env_id, feature_field=field)
    controller = GradientController.for_env(driven, np.ones(field.n_features))
    runners = {
        "physics only (mj_step per control period)": _Runner(
            None, physics=(bare.model, bare.data, bare.frame_skip)
        ),
        "field mode, random actions": _Runner(env),
        "field mode + gradient controller": _Runner(driven, controller=controller),
    }
    for runner in runners.values():  # warm up: the first reset builds the grid's graph
        runner.run(min(block, 200))
        runner.seconds, runner.steps = 0.0, 0
    for _ in range(max(1, steps // block)):
        for runner in runners.values():
            runner.run(block)
    rendered = _Runner(gym.make(env_id))
    rendered.run(rendered_steps)
    return [(name, r.rate) for name, r in runners.items()] + [("rendered panoramas", rendered.rate)]


@dataclass(frozen=True)
class Args:
    env: tuple[str, ...] = ENVS
    """navigation env ids"""
    steps: int = 20_000
    """steps per measurement"""
    block: int = 500
    """steps per interleaved block"""
    rendered_steps: int = 100
    """rendered steps"""
    json: Path | None = None
    """write the figures here (None: print them only)"""


def main(args: Args) -> None:
    results = {}
    for env_id in args.env:
        rows = measure(env_id, args.steps, args.block, args.rendered_steps)
        physics = rows[0][1]
        print(f"{env_id}, one thread")
        print(f"{'':<44}{'steps/s':>10}{'vs physics':>12}{'added us':>10}")
        for name, rate in rows:
            added = 1e6 / rate - 1e6 / physics
            print(f"{name:<44}{rate:>10.0f}{rate / physics:>12.2f}{added:>10.0f}")
        target = "met" if rows[1][1] >= 2000 else "NOT met"
        print(f"target >= 2000 steps/s per core in field mode: {target}\n")
        results[env_id] = {name: round(rate, 1) for name, rate in rows} | {
            "ratio to physics": {name: round(rate / physics, 3) for name, rate in rows},
            "added us per step": {
                name: round(1e6 / rate - 1e6 / physics, 1) for name, rate in rows[1:]
            },
        }
    if args.json:
        payload = {"steps_per_second": results}
        write_json_atomic(args.json, payload)


if __name__ == "__main__":
    main(tyro.cli(Args, description=__doc__.split("\n")[0]))
