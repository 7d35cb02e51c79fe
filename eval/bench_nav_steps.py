"""Benchmark: steps per second of the navigation env in feature-field mode, per core.

Reinforcement learning needs millions of steps; rendering a panorama costs ~8-11 ms, so the
navigation env can read the rotation-averaged features from a :class:`FeatureField` instead and
step physics only. Target: >= 2000 env steps/s per core. In one process, on one thread:

1. **Reference**: the physics alone, ``mujoco.mj_step`` for one control period (the env's
   ``frame_skip`` substeps) on the same model: what no env step can beat.
2. **Field mode**: ``gym.make(id, feature_field=...)`` with its registered wrappers (time limit,
   order and passive checkers), uniformly random actions (stop never pressed), resets at the
   end of each episode included (each draws a start and a goal and solves the geodesic).
3. **Field mode + controller**: the same with the slow-feature-gradient controller choosing
   the actions (its least-squares fit every step).
4. **Rendered mode** for scale: the env rendering the current panorama every step (few steps).

The field is 8 features at 0.1 m over the arena; its values do not change the cost of a
query, so they are drawn at random instead of rendered. Printed: steps/s and the ratio to the
physics reference. ``--json`` writes the figures. Where obstacles or walls stand in the arena,
each step also solves the exact geodesic distance to the goal (the reward and ``info``) over
the occupancy grid's corner graph, which costs about as much as the physics; in the open arena
it is the straight line.

Usage (from the repository root)::

    .venv/bin/python eval/bench_nav_steps.py          # the three navigation envs, ~2 min
    .venv/bin/python eval/bench_nav_steps.py --env sfa_gym/OmniRoverNavMaze-v0
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")  # per core: no hidden threads in numpy's BLAS

import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:  # run as a script from a checkout
    sys.path.insert(0, str(ROOT))

import gymnasium as gym  # noqa: E402

import sfa_gym  # noqa: E402, F401  (registers the ids)
from sfa_gym._files import write_json_atomic  # noqa: E402
from sfa_gym.navigation.controllers import GradientController  # noqa: E402
from sfa_gym.navigation.field import FeatureField  # noqa: E402

ENVS = [
    "sfa_gym/OmniRoverNav-v0",
    "sfa_gym/OmniRoverNavObstacles-v0",
    "sfa_gym/OmniRoverNavMaze-v0",
]


def random_field(env_id: str, spacing: float = 0.1, k: int = 8, seed: int = 0) -> FeatureField:
    xmin, xmax, ymin, ymax = gym.make(env_id).unwrapped.arena_bounds
    nx, ny = round((xmax - xmin) / spacing) + 1, round((ymax - ymin) / spacing) + 1
    values = np.random.default_rng(seed).normal(size=(ny, nx, k))
    return FeatureField(values, (xmin, xmax, ymin, ymax))


def physics_rate(env_id: str, steps: int) -> float:
    import mujoco

    env = gym.make(env_id).unwrapped
    env.reset(seed=0)
    started = time.perf_counter()
    for _ in range(steps):
        mujoco.mj_step(env.model, env.data, nstep=env.frame_skip)
    return steps / (time.perf_counter() - started)


def env_rate(env: gym.Env, steps: int, controller=None) -> float:
    rng = np.random.default_rng(0)
    low, high = env.action_space.low, env.action_space.high
    obs, info = env.reset(seed=0)
    if controller is not None:
        controller.reset(obs, info)
    episode = 0
    started = time.perf_counter()
    for _ in range(steps):
        if controller is None:
            action = rng.uniform(low, high).astype(np.float32)
            action[2] = -1.0  # keep driving: the stop action would end most episodes at once
        else:
            action = controller.act(obs, info)
        obs, _, terminated, truncated, info = env.step(action)
        if terminated or truncated:
            episode += 1
            obs, info = env.reset(seed=episode)
            if controller is not None:
                controller.reset(obs, info)
    return steps / (time.perf_counter() - started)


def measure(env_id: str, steps: int, rendered_steps: int) -> list[tuple[str, float]]:
    field = random_field(env_id)
    physics = physics_rate(env_id, steps)
    env = gym.make(env_id, feature_field=field)
    field_mode = env_rate(env, steps)
    controller = GradientController.for_env(env, np.ones(field.n_features))
    with_controller = env_rate(env, steps // 4, controller)
    rendered = env_rate(gym.make(env_id), rendered_steps)
    return [
        ("physics only (mj_step per control period)", physics),
        ("field mode, random actions", field_mode),
        ("field mode + gradient controller", with_controller),
        ("rendered panoramas", rendered),
    ]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--env", nargs="+", default=ENVS, help="navigation env ids")
    parser.add_argument("--steps", type=int, default=20_000, help="steps per measurement")
    parser.add_argument("--rendered-steps", type=int, default=100, help="rendered steps")
    parser.add_argument("--json", type=Path, default=None, help="write the figures here")
    args = parser.parse_args()

    results = {}
    for env_id in args.env:
        rows = measure(env_id, args.steps, args.rendered_steps)
        physics = rows[0][1]
        print(f"{env_id}, one thread")
        print(f"{'':<44}{'steps/s':>10}{'vs physics':>12}")
        for name, rate in rows:
            print(f"{name:<44}{rate:>10.0f}{rate / physics:>12.2f}")
        target = "met" if rows[1][1] >= 2000 else "NOT met"
        print(f"target >= 2000 steps/s per core in field mode: {target}\n")
        results[env_id] = {name: round(rate, 1) for name, rate in rows}
    if args.json:
        write_json_atomic(args.json, {"steps_per_second": results})


if __name__ == "__main__":
    main()
