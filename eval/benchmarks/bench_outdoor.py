"""Benchmark: what the outdoor world, its dynamics, the sensor and the mirror camera cost per step.

All envs make 60 x 600 observations and drive the same commands (a slow curve) from the same
start; each is timed in interleaved batches (so that all see the same load on a shared
machine) and reported as the median step time and its ratio to the static paper_sim world
seen by the cylindrical camera (the reference, measured in the same process):

* ``paper_sim``: the reference;
* ``outdoor static``: the outdoor world with its dynamics off, cylindrical camera;
* ``outdoor dynamics``: the same with sun, clouds and movers on;
* ``outdoor dynamics+sensor``: and the camera's auto-exposure and noise;
* ``OmniRoverOutdoor-v0``: all of it through the mirror camera (the registered id).

Backs docs/speed.md (the outdoor world's cost per step).

Usage (from the repository root)::

    .venv/bin/python -m eval.benchmarks.bench_outdoor [--steps 40] [--repeats 5]
"""

from __future__ import annotations

import json
import statistics
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import tyro
from tqdm import tqdm

import sfa_gym  # noqa: F401  (registers the ids)
from sfa_gym.sim.env import OmniRoverEnv

OUTDOOR = {"world": "paper_outdoor", "panorama": "paper_outdoor"}
CASES = {
    "paper_sim": lambda: OmniRoverEnv(world="paper_sim", panorama="paper_outdoor"),
    "outdoor static": lambda: OmniRoverEnv(**OUTDOOR, dynamics=False),
    "outdoor dynamics": lambda: OmniRoverEnv(**OUTDOOR, dynamics=True),
    "outdoor dynamics+sensor": lambda: OmniRoverEnv(**OUTDOOR, dynamics=True, sensor=True),
    "OmniRoverOutdoor-v0": lambda: gym.make("sfa_gym/OmniRoverOutdoor-v0").unwrapped,
}
REFERENCE = "paper_sim"


@dataclass(frozen=True)
class Args:
    steps: int = 40
    """steps per batch"""
    repeats: int = 5
    """interleaved batches per env"""
    out: Path = Path("published/benchmarks/outdoor.json")
    """where the figures are written"""


def time_steps(
    envs: dict[str, Any], steps: int, repeats: int
) -> tuple[dict[str, list[float]], dict[str, list[float]]]:
    """Seconds per step of each env in ``repeats`` interleaved batches of ``steps`` steps (a
    slow curve from the same start), after a first step outside the timing (GL contexts,
    texture uploads, remap tables): wall-clock and the process's CPU time (all its threads,
    the software rasteriser's among them). The envs are closed afterwards."""
    action = np.array([0.3, 0.2], np.float32)
    for env in envs.values():
        env.reset(seed=0, options={"pose": (0.0, 0.0, 0.0)})
        env.step(action)
    times: dict[str, list[float]] = {name: [] for name in envs}
    cpu: dict[str, list[float]] = {name: [] for name in envs}
    for _ in tqdm(range(repeats), desc="batches"):
        for name, env in envs.items():
            env.reset(seed=0, options={"pose": (0.0, 0.0, 0.0)})
            start, start_cpu = time.perf_counter(), time.process_time()
            for _ in range(steps):
                env.step(action)
            times[name].append((time.perf_counter() - start) / steps)
            cpu[name].append((time.process_time() - start_cpu) / steps)
    for env in envs.values():
        env.close()
    return times, cpu


def main(args: Args) -> None:
    if args.steps < 1 or args.repeats < 1:
        raise SystemExit(f"--steps and --repeats must be >= 1, got {args.steps}, {args.repeats}")

    times, _ = time_steps({name: make() for name, make in CASES.items()}, args.steps, args.repeats)

    reference = statistics.median(times[REFERENCE])
    rows = {
        name: {"ms_per_step": 1e3 * statistics.median(t), "ratio": statistics.median(t) / reference}
        for name, t in times.items()
    }
    print(f"{'env (60 x 600)':<26} {'ms/step':>8} {'ratio':>6}")
    for name, row in rows.items():
        print(f"{name:<26} {row['ms_per_step']:8.1f} {row['ratio']:6.2f}")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(
        json.dumps({"steps": args.steps, "repeats": args.repeats, "rows": rows}, indent=2) + "\n"
    )
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main(tyro.cli(Args, description=__doc__.split("\n")[0]))
