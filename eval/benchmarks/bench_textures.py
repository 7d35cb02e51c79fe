"""Benchmark: what the outdoor world's generated textures cost per step and per world build.

Each pair is the same env flat and textured (``textures=True``): the registered ids
``OmniRoverOutdoor-v0`` and ``OmniRoverOutdoorTextured-v0`` (mirror camera, dynamics, sensor),
and the static outdoor world through the cylindrical camera (where the rendering is a larger
share of a step). All envs make 60 x 600 observations and drive the same commands (a slow
curve) from the same start; each is timed in interleaved batches (so that all see the same
load on a shared machine) and reported as the median CPU time of the process per step (all its
threads: the software rasteriser's too) and its ratio to the flat env of its pair, measured in
the same process; CPU time, because on a shared machine the wall-clock of a batch depends on what
else runs (the median wall-clock is in the file too). The world build (``build_world``: the
textures' generation and PNG encoding) and the env's construction (build, MuJoCo compile,
settling; the GL contexts come at the first reset) are timed in CPU seconds over a few world
seeds, flat and textured.

Usage (from the repository root)::

    .venv/bin/python -m eval.benchmarks.bench_textures [--steps 40] [--repeats 5]
"""

from __future__ import annotations

import dataclasses
import json
import statistics
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import gymnasium as gym
import tyro

import sfa_gym  # noqa: F401  (registers the ids)
from eval.benchmarks.bench_outdoor import time_steps
from sfa_gym.sim.env import OmniRoverEnv
from sfa_gym.sim.worlds import build_world, load_world_spec
from sfa_gym.sim.worlds.textures import TexturesSpec

STATIC = {"world": "paper_outdoor", "panorama": "paper_outdoor", "dynamics": False}
PAIRS: dict[str, tuple[Callable[[bool], OmniRoverEnv], str]] = {
    "OmniRoverOutdoor-v0": (
        lambda textures: gym.make("sfa_gym/OmniRoverOutdoor-v0", textures=textures).unwrapped,
        "OmniRoverOutdoorTextured-v0",
    ),
    "outdoor static, cylindrical": (
        lambda textures: OmniRoverEnv(**STATIC, textures=textures),
        "outdoor static, cylindrical, textured",
    ),
}
"""Each flat env's name: how to make it flat (False) or textured (True), the textured name."""


@dataclass(frozen=True)
class Args:
    steps: int = 40
    """steps per batch"""
    repeats: int = 5
    """interleaved batches per env"""
    build_seeds: int = 4
    """world seeds whose build and construction are timed"""
    out: Path = Path("published/benchmarks/textures.json")
    """where the figures are written"""


def _build_seconds(seeds: int) -> dict[str, dict[str, float]]:
    """Median CPU seconds of ``build_world`` and of the env's construction, flat and
    textured."""
    flat = load_world_spec("paper_outdoor")
    textured = dataclasses.replace(flat, textures=TexturesSpec())
    out = {}
    for name, spec in (("flat", flat), ("textured", textured)):
        build, construct = [], []
        for seed in range(seeds):
            start = time.process_time()
            build_world(spec, seed)
            build.append(time.process_time() - start)
            start = time.process_time()
            OmniRoverEnv(world=spec, world_seed=seed, panorama="paper_outdoor").close()
            construct.append(time.process_time() - start)
        out[name] = {
            "build_world_s": statistics.median(build),
            "env_construction_s": statistics.median(construct),
        }
    return out


def main(args: Args) -> None:
    if min(args.steps, args.repeats, args.build_seeds) < 1:
        raise SystemExit(
            f"--steps, --repeats and --build-seeds must be >= 1, got {args.steps}, "
            f"{args.repeats}, {args.build_seeds}"
        )
    envs = {}
    for flat_name, (make, textured_name) in PAIRS.items():
        envs[flat_name], envs[textured_name] = make(False), make(True)
    wall, cpu = time_steps(envs, args.steps, args.repeats)

    rows = {}
    for flat_name, (_, textured_name) in PAIRS.items():
        reference = statistics.median(cpu[flat_name])
        for name in (flat_name, textured_name):
            median = statistics.median(cpu[name])
            rows[name] = {
                "ms_per_step": 1e3 * median,
                "ratio": median / reference,
                "wall_ms_per_step": 1e3 * statistics.median(wall[name]),
            }
    build = _build_seconds(args.build_seeds)
    print(f"{'env (60 x 600)':<40} {'CPU ms/step':>11} {'ratio':>6} {'wall ms/step':>12}")
    for name, row in rows.items():
        print(
            f"{name:<40} {row['ms_per_step']:11.1f} {row['ratio']:6.2f} "
            f"{row['wall_ms_per_step']:12.1f}"
        )
    for name, row in build.items():
        print(
            f"world build {name}: {row['build_world_s']:.3f} s, env construction "
            f"{row['env_construction_s']:.3f} s"
        )
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(
        json.dumps(
            {
                "steps": args.steps,
                "repeats": args.repeats,
                "ratio_to": "the flat env of each pair",
                "ms_per_step": "median CPU time of the process per step (all its threads)",
                "build_s": "median CPU seconds",
                "rows": rows,
                "build_seeds": args.build_seeds,
                "build": build,
            },
            indent=2,
        )
        + "\n"
    )
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main(tyro.cli(Args, description=__doc__.split("\n")[0]))
