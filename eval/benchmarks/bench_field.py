"""Benchmark: the feature field (:mod:`sfa_gym.navigation.field`) against rendered features.

A navigation env in a static world can read the rotation-averaged features from a precomputed
field instead of rendering a panorama every step. How close is the field to what rendering
gives, what does it cost to build, and how fast is a query? In one process:

1. **Model.** The paper's simulator network (``SFASettings()``: 4 layers, 32-dimensional
   nodes, one node per grid row, 8 outputs) is trained as the grid protocol trains it: the
   ``paper_sim`` world, a 30 x 30 grid, 624 training positions in Hilbert order at random
   headings, 70 rotations (5 px steps). ``--quick``: 16-dimensional nodes, a 12 x 12 grid, 100
   training positions.
2. **Build.** Fields at 0.1 m and 0.05 m node spacing (``--quick``: 0.1 m only) over the 6 x 6
   m arena, features averaged over every column (``step=1``); build time per 1000 nodes (render
   and features). The 0.1 m nodes are every other 0.05 m node: their values must agree
   (rendering is deterministic).
3. **Accuracy.** At ``--poses`` random poses (uniform position over the arena, walls' edges
   included; uniform yaw; off the grid nodes almost surely): the rendered rotation-averaged
   features (``step=1``) at that pose against the field's, for every interpolation (bilinear,
   Catmull-Rom, cubic spline). Units: the *noise*, the RMS distance of the rendered features
   from their mean over ``--headings`` random headings at the same position (the field ignores
   heading, so this is the floor for comparing with one rendering), and the mean feature change
   over 0.1 m of travel (rendered at 0.1 m from each pose in a random direction, 2 headings);
   the change over 0.01 m (likewise) shows how rough the rendered features are below any node
   spacing. Printed: median and 90th percentile of ``|field - rendered| / noise`` over the
   poses, with ``rendered`` at the pose's heading and with ``rendered`` averaged over the
   headings (the interpolation error alone), and ``|field - rendered| / change``. Distances are
   Euclidean over the features.
4. **Speed.** One single-point query (``FeatureField.at(x, y)`` and ``field(points (1, 2))``)
   and a vectorised query of 10000 points, per point, in microseconds; one physics-only env
   step (``mj_step`` over a control period) for scale: target >= 2000 steps/s per core.

Backs docs/navigation.md (feature fields).

Usage (from the repository root)::

    .venv/bin/python -m eval.benchmarks.bench_field            # full, ~4 min on 2 cores
    .venv/bin/python -m eval.benchmarks.bench_field --quick    # smoke run, ~40 s

Writes ``published/benchmarks/field.json`` (``--json``) and prints a table.
"""

from __future__ import annotations

import math
import os
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import tyro
from tqdm import tqdm

from sfa_gym.cli.localize import GridExperiment
from sfa_gym.features import rotation_averaged_features
from sfa_gym.files import write_json_atomic
from sfa_gym.navigation.field import INTERPOLATIONS, FeatureField
from sfa_gym.protocols.grid import training_panoramas
from sfa_gym.protocols.settings import SFASettings
from sfa_gym.sim.env import OmniRoverEnv

ROOT = Path(__file__).resolve().parents[2]

TARGETS = {"steps_per_s_per_core_min": 2000.0, "query_us_max": 100.0}


def render(env: OmniRoverEnv, x: float, y: float, yaw: float) -> np.ndarray:
    return env.reset(options={"pose": (float(x), float(y), float(yaw))})[0]


def train_model(settings: SFASettings, grid: int, n_train: int) -> tuple[OmniRoverEnv, Any, dict]:
    """The network trained on the grid protocol's training positions; returns the env, the
    model and its description."""
    env = OmniRoverEnv()
    config = GridExperiment(
        grid=grid, n_train=n_train, n_test=min(196, grid * grid - n_train), sfa=settings
    )
    panoramas = training_panoramas(env, config)
    t0 = time.perf_counter()
    model = settings.make_model(*panoramas.shape[1:3]).fit_rotations(panoramas, step=config.step)
    info = {
        "network": settings.network,
        "node_dim": settings.node_dim,
        "n_outputs": settings.n_outputs,
        "weight_sharing": settings.weight_sharing,
        "training": (
            f"grid protocol: {grid} x {grid} grid, {n_train} positions in {config.order} "
            f"order, rotations every {config.step} columns, seed {config.seed}"
        ),
        "fit_seconds": round(time.perf_counter() - t0, 1),
    }
    return env, model, info


def build_fields(env: OmniRoverEnv, model: Any, info: dict, spacings: list[float]) -> dict:
    fields, build = {}, {}
    for spacing in spacings:
        t0 = time.perf_counter()
        field = FeatureField.build(env, model, spacing=spacing, model_info=info)
        seconds = time.perf_counter() - t0
        n = field.metadata["n_nodes"]
        with tempfile.TemporaryDirectory() as tmp:
            path = Path(tmp) / "field.npz"
            field.save(path)
            size = path.stat().st_size
            t1 = time.perf_counter()
            loaded = FeatureField.load(path)
            load_ms = (time.perf_counter() - t1) * 1e3
        assert np.array_equal(loaded.values, field.values)
        fields[spacing] = field
        build[f"{spacing:g}"] = {
            "nodes": n,
            "grid": list(field.values.shape[:2]),
            "seconds": round(seconds, 1),
            "seconds_per_1000_nodes": round(1000 * seconds / n, 2),
            "render_seconds_per_1000_nodes": round(1000 * field.metadata["render_seconds"] / n, 2),
            "feature_seconds_per_1000_nodes": round(
                1000 * field.metadata["feature_seconds"] / n, 2
            ),
            "file_mb": round(size / 1e6, 2),
            "load_ms": round(load_ms, 1),
        }
    if 0.1 in fields and 0.05 in fields:
        # every other 0.05 m node is a 0.1 m node: rendering is deterministic, so they agree
        diff = np.abs(fields[0.05].values[::2, ::2] - fields[0.1].values).max()
        build["max_diff_0.1_vs_0.05_subsampled"] = float(diff)
    return {"fields": fields, "build": build}


def _neighbours(
    positions: np.ndarray, distance: float, bounds: tuple, rng: np.random.Generator
) -> np.ndarray:
    """A point ``distance`` from each position in a random direction, inside ``bounds``."""
    xmin, xmax, ymin, ymax = bounds
    angle = rng.uniform(-math.pi, math.pi, len(positions))
    offset = distance * np.stack([np.cos(angle), np.sin(angle)], axis=1)
    out = positions + offset
    outside = (out[:, 0] < xmin) | (out[:, 0] > xmax) | (out[:, 1] < ymin) | (out[:, 1] > ymax)
    out[outside] = positions[outside] - offset[outside]  # go the other way at a wall
    return np.clip(out, (xmin, ymin), (xmax, ymax))  # corners


def sample_poses(env: OmniRoverEnv, n: int, n_headings: int, seed: int) -> dict[str, np.ndarray]:
    """Random positions with ``n_headings`` random headings each, and neighbours 0.1 m and
    0.01 m away (2 random headings each)."""
    xmin, xmax, ymin, ymax = env.arena_bounds
    rng = np.random.default_rng(seed)
    positions = rng.uniform((xmin, ymin), (xmax, ymax), (n, 2))
    return {
        "positions": positions,
        "headings": rng.uniform(-math.pi, math.pi, (n, n_headings)),
        "near_0.1": _neighbours(positions, 0.1, env.arena_bounds, rng),
        "near_0.1_headings": rng.uniform(-math.pi, math.pi, (n, 2)),
        "near_0.01": _neighbours(positions, 0.01, env.arena_bounds, rng),
        "near_0.01_headings": rng.uniform(-math.pi, math.pi, (n, 2)),
    }


def rendered_features(env: OmniRoverEnv, model: Any, poses: dict) -> dict[str, np.ndarray]:
    """Rendered rotation-averaged features (step 1): ``(n, H, k)`` at the poses and ``(n, k)``
    at the neighbours (mean over their 2 headings)."""

    def features(position: np.ndarray, headings: np.ndarray) -> np.ndarray:
        panoramas = np.stack([render(env, *position, h) for h in headings])
        return rotation_averaged_features(model, panoramas, step=1)

    out: dict[str, list] = {"here": [], "near_0.1": [], "near_0.01": []}
    for i in tqdm(range(len(poses["positions"])), desc="rendered features at random poses"):
        out["here"].append(features(poses["positions"][i], poses["headings"][i]))
        for key in ("near_0.1", "near_0.01"):
            out[key].append(features(poses[key][i], poses[f"{key}_headings"][i]).mean(axis=0))
    return {key: np.stack(value) for key, value in out.items()}


def quantiles(values: np.ndarray) -> dict[str, float]:
    return {
        "median": round(float(np.median(values)), 4),
        "p90": round(float(np.quantile(values, 0.9)), 4),
        "max": round(float(np.max(values)), 4),
    }


def accuracy(fields: dict, poses: dict, rendered: dict) -> dict:
    here = rendered["here"]  # (n, H, k)
    mean = here.mean(axis=1)
    noise = np.sqrt(((here - mean[:, None]) ** 2).sum(axis=2).mean(axis=1))  # (n,)
    change = np.linalg.norm(rendered["near_0.1"] - mean, axis=1)  # (n,)
    mean_change = float(change.mean())
    # the features' own roughness: what they change over 1 cm, below any node spacing
    small = np.linalg.norm(rendered["near_0.01"] - mean, axis=1)
    out: dict = {
        "noise": quantiles(noise),
        "change_per_0.1m": {**quantiles(change), "mean": round(mean_change, 4)},
        "change_per_0.01m": {**quantiles(small), "mean": round(float(small.mean()), 4)},
        "noise_over_change": round(float(np.sqrt((noise**2).mean()) / mean_change), 4),
        "fields": {},
    }
    for spacing, field in fields.items():
        rows = {}
        for interpolation in INTERPOLATIONS:
            f = field.with_interpolation(interpolation)(poses["positions"]).astype(np.float64)
            to_one = np.linalg.norm(f - here[:, 0], axis=1)  # the pose's own heading
            to_mean = np.linalg.norm(f - mean, axis=1)
            rows[interpolation] = {
                "vs_rendered_over_noise": quantiles(to_one / noise),
                "vs_heading_mean_over_noise": quantiles(to_mean / noise),
                "vs_rendered_over_change": quantiles(to_one / mean_change),
                "vs_heading_mean_over_change": quantiles(to_mean / mean_change),
                "rms_vs_rendered_over_rms_noise": round(
                    float(np.sqrt((to_one**2).mean() / (noise**2).mean())), 4
                ),
            }
        out["fields"][f"{spacing:g}"] = rows
    return out


def time_queries(fields: dict, env: OmniRoverEnv, n: int, repeats: int, seed: int) -> dict:
    """Microseconds per query (median of ``repeats`` batches of ``n``), process CPU time."""
    import mujoco

    xmin, xmax, ymin, ymax = env.arena_bounds
    rng = np.random.default_rng(seed)
    points = rng.uniform((xmin, ymin), (xmax, ymax), (n, 2))
    pairs = [(float(x), float(y)) for x, y in points]
    singles = [p[None] for p in points]

    def per_call(fn: Any, items: list, scale: int) -> float:
        times = []
        for _ in range(repeats):
            t0 = time.process_time()
            for item in items:
                fn(item)
            times.append((time.process_time() - t0) / (len(items) * scale) * 1e6)
        return round(float(np.median(times)), 3)

    out: dict = {"fields": {}}
    for spacing, field in fields.items():
        rows = {}
        for interpolation in INTERPOLATIONS:
            f = field.with_interpolation(interpolation)
            rows[interpolation] = {
                "at_us": per_call(lambda p, f=f: f.at(*p), pairs, 1),
                "call_1x2_us": per_call(f, singles, 1),
                "vectorised_us_per_point": per_call(f, [points] * 5, n),
            }
        out["fields"][f"{spacing:g}"] = rows
    env.reset(options={"pose": (0.0, 0.0, 0.0)})
    steps = max(n // 20, 200)
    physics = per_call(
        lambda _: mujoco.mj_step(env.model, env.data, nstep=env.frame_skip), [None] * steps, 1
    )
    out["physics_step_us"] = physics
    slowest = max(r["call_1x2_us"] for rows in out["fields"].values() for r in rows.values())
    out["steps_per_s_per_core_physics_plus_query"] = round(1e6 / (physics + slowest))
    return out


def format_table(results: dict) -> str:
    lines = ["build (per 1000 nodes: total = render + features)"]
    for spacing, b in results["build"].items():
        if not isinstance(b, dict):
            continue
        lines.append(
            f"  {spacing:>5s} m  {b['grid'][1]} x {b['grid'][0]} = {b['nodes']:5d} nodes  "
            f"{b['seconds']:7.1f} s  {b['seconds_per_1000_nodes']:6.2f} s/1000 = "
            f"{b['render_seconds_per_1000_nodes']:.2f} + {b['feature_seconds_per_1000_nodes']:.2f}"
            f"  file {b['file_mb']:.2f} MB, load {b['load_ms']:.0f} ms"
        )
    if "max_diff_0.1_vs_0.05_subsampled" in results["build"]:
        lines.append(
            "  0.1 m nodes vs every other 0.05 m node: max |diff| "
            f"{results['build']['max_diff_0.1_vs_0.05_subsampled']:.2e}"
        )
    acc = results["accuracy"]
    lines.append(
        f"\nrendered features at {results['config']['poses']} random poses: noise (RMS over "
        f"{results['config']['headings']} headings) median {acc['noise']['median']:.4f}; change "
        f"over 0.1 m mean {acc['change_per_0.1m']['mean']:.4f}; RMS noise / change "
        f"{acc['noise_over_change']:.3f}; change over 0.01 m mean "
        f"{acc['change_per_0.01m']['mean']:.4f} (median {acc['change_per_0.01m']['median']:.4f})"
    )
    lines.append(
        f"  {'spacing':>7s} {'interp':>11s}  {'|f-r|/noise med  p90':>21s}  "
        f"{'|f-mean|/noise med  p90':>24s}  {'|f-r|/change med  p90':>22s}"
    )
    for spacing, rows in acc["fields"].items():
        for interpolation, r in rows.items():
            a, b, c = (
                r["vs_rendered_over_noise"],
                r["vs_heading_mean_over_noise"],
                r["vs_rendered_over_change"],
            )
            lines.append(
                f"  {spacing:>5s} m {interpolation:>11s}  {a['median']:14.3f} {a['p90']:6.3f}  "
                f"{b['median']:17.3f} {b['p90']:6.3f}  {c['median']:15.3f} {c['p90']:6.3f}"
            )
    t = results["timing"]
    lines.append("\nqueries (process CPU time, us)")
    lines.append(
        f"  {'spacing':>7s} {'interp':>11s}  {'at(x, y)':>9s} {'f((1,2))':>9s} {'vec/pt':>7s}"
    )
    for spacing, rows in t["fields"].items():
        for interpolation, r in rows.items():
            lines.append(
                f"  {spacing:>5s} m {interpolation:>11s}  {r['at_us']:9.2f} "
                f"{r['call_1x2_us']:9.2f} {r['vectorised_us_per_point']:7.3f}"
            )
    lines.append(
        f"  physics-only env step {t['physics_step_us']:.0f} us; with the slowest single query: "
        f"{t['steps_per_s_per_core_physics_plus_query']} steps/s per core"
    )
    return "\n".join(lines)


@dataclass(frozen=True)
class Args:
    quick: bool = False
    """small smoke run"""
    poses: int | None = None
    """random poses (None: 200; quick 40)"""
    headings: int | None = None
    """headings per pose (None: 8; quick 4)"""
    seed: int = 1
    """seed of the random poses"""
    json: Path = ROOT / "published" / "benchmarks" / "field.json"
    """where the figures are written"""


def main(argv: list[str] | None = None) -> int:
    args = tyro.cli(Args, args=argv, description=__doc__.split("\n\n")[0])
    if args.quick:
        settings, grid, n_train, spacings = SFASettings(node_dim=16), 12, 100, [0.1]
    else:
        settings, grid, n_train, spacings = SFASettings(), 30, 624, [0.1, 0.05]
    n_poses = args.poses or (40 if args.quick else 200)
    n_headings = args.headings or (4 if args.quick else 8)
    print(
        f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cpus; network "
        f"{settings.network} dim {settings.node_dim}, grid {grid}, {n_train} training positions"
    )

    env, model, info = train_model(settings, grid, n_train)
    built = build_fields(env, model, info, spacings)
    poses = sample_poses(env, n_poses, n_headings, args.seed)
    rendered = rendered_features(env, model, poses)
    results: dict = {
        "config": {
            "quick": args.quick,
            "model": info,
            "spacings": spacings,
            "poses": n_poses,
            "headings": n_headings,
            "seed": args.seed,
            "step": 1,
        },
        "targets": TARGETS,
        "build": built["build"],
        "accuracy": accuracy(built["fields"], poses, rendered),
        "timing": time_queries(built["fields"], env, 20000, 5, args.seed),
    }
    env.close()
    # the method closest to rendering, per spacing, by the median distance to the heading mean
    results["closest_to_rendered"] = {
        spacing: min(rows, key=lambda i: rows[i]["vs_heading_mean_over_noise"]["median"])
        for spacing, rows in results["accuracy"]["fields"].items()
    }
    print()
    print(format_table(results))
    for spacing, rows in results["accuracy"]["fields"].items():
        medians = ", ".join(
            f"{i} {r['vs_rendered_over_change']['median']:.3f}" for i, r in rows.items()
        )
        print(
            f"{spacing} m: median |field - rendered| / change over 0.1 m: {medians}; closest "
            f"to the heading mean: {results['closest_to_rendered'][spacing]}"
        )
    args.json.parent.mkdir(parents=True, exist_ok=True)
    write_json_atomic(args.json, results)
    print(f"results: {args.json}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
