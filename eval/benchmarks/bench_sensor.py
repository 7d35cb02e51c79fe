"""Benchmark: what the optional effects (auto white balance, vignetting, motion blur, fog, another
day's parked objects, the seasons' foliage, cast shadows, wet ground and snow, a cloud sky) and the
textured worlds (the outdoor world and the campus) cost per step.

The registered ``OmniRoverOutdoor-v0`` (mirror camera, dynamics, auto-exposure and noise: the
reference) against the same env with each effect switched on (fog: the dynamics' visibility, which
reads the depth buffer beside the colours; parked objects: the dynamics' arrangement 1; seasons:
mid-January with seasons on, whose bare crowns are see-through; shadows: the sun's depth map and
every view rendered a second time without the sun; wet ground: darker ground materials with a
specular highlight; snow: whiter ground textures; motion blur: the frame smeared along its rows by
the turn during a 1/30 s exposure; a cloud sky: the skybox drawn with clouds, sampled through its
mipmaps where the plain gradient is sampled from its nearest texel), all driving the same commands
(a slow curve) from the same start, timed in interleaved batches
(:func:`eval.benchmarks.bench_outdoor.time_steps`) and reported as the median CPU time of the
process per step and its ratio to the reference measured in the same process (CPU time: on a
shared machine a batch's wall-clock depends on what else runs; the file has the wall-clock too).

Usage (from the repository root)::

    .venv/bin/python -m eval.benchmarks.bench_sensor [--steps 40] [--repeats 5]
"""

from __future__ import annotations

import dataclasses
import statistics
from dataclasses import dataclass
from pathlib import Path

import gymnasium as gym
import tyro

import sfa_gym  # noqa: F401  (registers the ids)
from eval.benchmarks.bench_outdoor import time_steps
from sfa_gym.files import write_json_atomic
from sfa_gym.sim.camera.sensor import SensorSpec

SENSORS: dict[str, SensorSpec] = {
    "OmniRoverOutdoor-v0": SensorSpec(),
    "+ auto white balance": SensorSpec(white_balance=True),
    "+ vignetting 0.3": SensorSpec(vignetting=0.3),
    "+ both": SensorSpec(white_balance=True, vignetting=0.3),
    "+ motion blur, 1/30 s": SensorSpec(exposure_s=1 / 30),
}
"""Each env's name and sensor; the first is the reference."""

FOG_VISIBILITY_M = 100.0
"""The fog row's visibility (thick fog; the cost does not depend on it)."""


@dataclass(frozen=True)
class Args:
    steps: int = 40
    """steps per batch"""
    repeats: int = 5
    """interleaved batches per env"""
    out: Path = Path("published/benchmarks/sensor.json")
    """where the figures are written"""


def main(args: Args) -> None:
    if min(args.steps, args.repeats) < 1:
        raise SystemExit(f"--steps and --repeats must be >= 1, got {args.steps}, {args.repeats}")
    envs = {
        name: gym.make("sfa_gym/OmniRoverOutdoor-v0", sensor=sensor).unwrapped
        for name, sensor in SENSORS.items()
    }
    foggy = dataclasses.replace(envs["OmniRoverOutdoor-v0"].dynamics, visibility_m=FOG_VISIBILITY_M)
    fog = f"+ fog, visibility {FOG_VISIBILITY_M:g} m"
    envs[fog] = gym.make("sfa_gym/OmniRoverOutdoor-v0", dynamics=foggy).unwrapped
    for name, change in (
        ("+ another day's parked objects", {"arrangement": 1}),
        ("+ seasons, mid-January", {"day_of_year": 15, "seasons": True}),
        ("+ cast shadows", {"shadows": True}),
        ("+ wet ground", {"ground": "wet"}),
        ("+ snow, mid-January lawn", {"ground": "snow", "day_of_year": 15, "grass_seasons": True}),
        ("+ a cloud sky, cover 0.4", {"cloud_cover": 0.4}),
    ):
        changed = dataclasses.replace(envs["OmniRoverOutdoor-v0"].dynamics, **change)
        envs[name] = gym.make("sfa_gym/OmniRoverOutdoor-v0", dynamics=changed).unwrapped
    for env_id in ("OmniRoverOutdoorTextured-v0", "OmniRoverCampus-v0"):  # textured worlds
        envs[env_id] = gym.make(f"sfa_gym/{env_id}").unwrapped
    wall, cpu = time_steps(envs, args.steps, args.repeats)
    reference = statistics.median(cpu[next(iter(SENSORS))])
    rows = {
        name: {
            "ms_per_step": 1e3 * statistics.median(cpu[name]),
            "ratio": statistics.median(cpu[name]) / reference,
            "wall_ms_per_step": 1e3 * statistics.median(wall[name]),
        }
        for name in envs
    }
    for name, row in rows.items():
        print(f"{name:<28} {row['ms_per_step']:7.1f} CPU ms/step  ratio {row['ratio']:.2f}")
    write_json_atomic(
        args.out,
        {
            "steps": args.steps,
            "repeats": args.repeats,
            "ratio_to": "OmniRoverOutdoor-v0 (auto-exposure and noise)",
            "ms_per_step": "median CPU time of the process per step (all its threads)",
            "rows": rows,
        },
    )
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main(tyro.cli(Args))
