"""PPO on every observation of the navigation benchmark, several seeds, one figure and one table.

Runs ``sfa-gym agent train`` (:mod:`sfa_gym.agents`) for each (method, seed), ``workers``
processes at a time (one torch thread each), on the feature fields that ``sfa-gym navigate``
wrote, and on rendered panoramas for ``pixels`` (CnnPolicy, with its own smaller budget),
``<method>+estimate`` (the agent also sees the goal estimate of a local linear fit,
``--estimate``), and ``oracle`` (the goal's position relative to the rover from the ground
truth: the upper bound, small budget); ``+ranges`` adds the range sensor's readings
(``--ranges``). Each run keeps its learning curve and checkpoints in ``out/<method>-<seed>/``
and resumes there when started again; finished runs are skipped. Then it plots success and SPL
against training steps (mean over seeds, with the range) to ``out/learning_curves.png`` and
writes the last evaluation of each run to ``out/summary.json``.

Backs docs/navigation.md ("PPO agents": the learning curves ``docs/ppo_learning_curves*.png``
and the table of the last evaluations).

Usage (from the repository root)::

    sfa-gym navigate --out results/nav --baselines baselines/
    .venv/bin/python -m eval.studies.ppo_nav_sweep --nav results/nav --out results/ppo
    .venv/bin/python -m eval.studies.ppo_nav_sweep --out results/ppo --plot-only --at 500000
"""

from __future__ import annotations

import csv
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import tyro

from sfa_gym.files import write_json_atomic

FEATURES = ["sfa", "fft_magnitude", "band_means", "pca", "raw_pixels"]
# "<features>+estimate": the same memory plus the local linear fit's estimate of the goal;
# "+ranges" adds the range sensor's readings
EXTRAS = ["", "+estimate", "+ranges", "+estimate+ranges"]
METHODS = [m + e for e in EXTRAS for m in FEATURES] + ["pixels", "oracle"]
DEFAULT = [m + e for e in EXTRAS[:2] for m in FEATURES] + ["pixels", "oracle"]


@dataclass(frozen=True)
class Args:
    nav: Path = Path("results/nav")
    """navigate's output folder (its field_<features>.npz)"""
    out: Path = Path("results/ppo")
    """output folder"""
    methods: tuple[str, ...] = tuple(DEFAULT)
    """observations to train on: <features>[+estimate][+ranges] with features one of sfa,
    fft_magnitude, band_means, pca, raw_pixels; or pixels, oracle"""
    seeds: tuple[int, ...] = (0, 1, 2)
    """agent seeds"""
    env: str = "sfa_gym/OmniRoverNav-v0"
    """navigation env id"""
    world_seed: int = 0
    """the fields' world seed"""
    total_timesteps: int = 1_000_000
    """budget of the feature agents"""
    pixels_timesteps: int = 100_000
    """CnnPolicy budget"""
    oracle_timesteps: int = 200_000
    """oracle budget"""
    eval_every: int = 100_000
    """steps between evaluations"""
    eval_episodes: int = 50
    """episodes per evaluation"""
    workers: int = 2
    """runs at a time"""
    anneal_lr: bool = False
    """the agents' --anneal-lr"""
    plot_only: bool = False
    """plot what the runs hold"""
    at: int | None = None
    """summarize the evaluations at or before this step"""


def read_curve(run: Path) -> list[dict[str, float]]:
    path = run / "learning_curve.csv"
    if not path.exists():
        return []
    with open(path, newline="") as f:
        return [{k: float(v) for k, v in row.items()} for row in csv.DictReader(f)]


def run_one(args: Args, method: str, seed: int) -> Path:
    run = args.out / f"{method}-{seed}"
    budget = {"pixels": args.pixels_timesteps, "oracle": args.oracle_timesteps}.get(
        method, args.total_timesteps
    )
    curve = read_curve(run)
    if curve and curve[-1]["steps"] >= budget:
        return run
    command = [
        sys.executable, "-m", "sfa_gym.cli", "agent", "train", "--out", str(run),
        "--seed", str(seed),
        "--env-id", args.env, "--world-seed", str(args.world_seed),
        "--total-timesteps", str(budget), "--eval-episodes", str(args.eval_episodes),
        "--eval-every", str(min(args.eval_every, budget // 5)),
        "--quiet",
    ]  # fmt: skip
    if method == "oracle":  # ground truth; SFA's field only spares the rendering
        command += ["--oracle", "--field", str(args.nav / "field_sfa.npz")]
    elif method != "pixels":
        features, *extras = method.split("+")
        command += ["--field", str(args.nav / f"field_{features}.npz")]
        command += [f"--{extra}" for extra in extras]  # estimate, ranges
    command += ["--anneal-lr"] if args.anneal_lr else []
    run.mkdir(parents=True, exist_ok=True)
    with open(run / "log.txt", "a") as log:
        done = subprocess.run(command, stdout=log, stderr=subprocess.STDOUT, check=False)
    status = "done" if done.returncode == 0 else f"FAILED (exit {done.returncode})"
    print(f"{run.name}: {status}", flush=True)
    return run


def furthest_curves(out: Path, method: str) -> list[list[dict[str, float]]]:
    """The learning curves of a method's runs that got furthest (runs still going are left out,
    so that every seed counted had the same budget)."""
    curves = [c for run in sorted(out.glob(f"{method}-*")) if (c := read_curve(run))]
    if not curves:
        return []
    furthest = max(c[-1]["steps"] for c in curves)
    return [c for c in curves if c[-1]["steps"] == furthest]


def summarize(out: Path, methods: list[str], at: int | None = None) -> dict[str, dict[str, float]]:
    """Last evaluation of each run (or its last one at or before ``at`` steps, to compare
    methods at equal steps), and mean and range over the seeds of each method."""
    summary: dict[str, dict[str, float]] = {}
    for method in methods:
        curves = furthest_curves(out, method)
        if at is not None:
            curves = [[row for row in c if row["steps"] <= at] for c in curves]
        last = [c[-1] for c in curves if c]
        if not last:
            continue
        success = np.array([c["success"] for c in last])
        spl = np.array([c["spl"] for c in last])
        summary[method] = {
            "seeds": len(last),
            "steps": min(c["steps"] for c in last),
            "success": round(float(success.mean()), 3),
            "success_min": float(success.min()),
            "success_max": float(success.max()),
            "spl": round(float(spl.mean()), 3),
            "hours": round(max(c["seconds"] for c in last) / 3600, 2),
        }
    return summary


def plot(out: Path, methods: list[str]) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(10, 3.6), sharex=True)
    for method in methods:
        curves = furthest_curves(out, method)
        if not curves:
            continue
        n = min(len(c) for c in curves)
        steps = np.array([row["steps"] for row in curves[0][:n]])
        for ax, key in zip(axes, ("success", "spl"), strict=True):
            values = np.array([[row[key] for row in c[:n]] for c in curves])
            line = ax.plot(steps, values.mean(axis=0), label=f"{method} (seeds: {len(curves)})")
            ax.fill_between(steps, values.min(axis=0), values.max(axis=0), alpha=0.2,
                            color=line[0].get_color())  # fmt: skip
    for ax, name in zip(axes, ("success (arrival)", "SPL"), strict=True):
        ax.set(xlabel="training steps", ylabel=name, ylim=(-0.02, 1.02))
        ax.grid(alpha=0.3)
    axes[1].legend(fontsize=8, loc="upper right")  # the SPL panel has room above the curves
    fig.suptitle("PPO in the navigation env: mean over seeds, range shaded")
    fig.savefig(out / "learning_curves.png", dpi=110, bbox_inches="tight")
    plt.close(fig)


def main(args: Args) -> None:
    unknown = sorted(set(args.methods) - set(METHODS))
    if unknown:
        raise SystemExit(f"unknown --methods {unknown}; expected some of {METHODS}")
    if args.workers < 1:
        raise SystemExit(f"--workers must be at least 1, got {args.workers}")
    if args.plot_only and not args.out.is_dir():
        raise SystemExit(f"--plot-only: {args.out} is not a folder of runs")
    jobs = [(m, s) for s in args.seeds for m in args.methods]
    if not args.plot_only:
        fields = {"sfa" if m == "oracle" else m.partition("+")[0] for m, _ in jobs}
        for method in fields - {"pixels"}:
            if not (args.nav / f"field_{method}.npz").exists():
                raise SystemExit(
                    f"no field for {method!r} in {args.nav}: run sfa-gym navigate first"
                )
        with ThreadPoolExecutor(args.workers) as pool:
            list(pool.map(lambda job: run_one(args, *job), jobs))
    plot(args.out, list(args.methods))
    summary = summarize(args.out, list(args.methods), args.at)
    name = "summary.json" if args.at is None else f"summary_at_{args.at}.json"
    write_json_atomic(args.out / name, summary)
    print(f"{'method':<30}{'seeds':>6}{'steps':>10}{'success':>9}{'range':>13}{'SPL':>7}")
    for method, s in summary.items():
        print(
            f"{method:<30}{s['seeds']:>6}{s['steps']:>10.0f}{s['success']:>9.2f}"
            f"{s['success_min']:>7.2f}-{s['success_max']:.2f}{s['spl']:>7.2f}"
        )


if __name__ == "__main__":
    main(tyro.cli(Args))
