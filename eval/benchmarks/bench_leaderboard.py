"""Benchmark: the leaderboard's quick board per track, and the sweep's speed-up on Ray.

Two measurements in one process:

1. **Quick board, local backend**: ``band_means`` (or the ``--board-method`` methods, one after
   the other) on every track of ``tracks/`` at its quick size (``sfa-gym leaderboard run
   --quick``), one track at a time, from a **cold** render cache (a fresh folder unless
   ``--cache`` names one): the wall time per track includes rendering its runs; the renders'
   own seconds (the cache's ``renders.log``) are listed beside. The outdoor tracks share their
   drive: the second one renders only its own test runs.
2. **Ray speed-up**: the tasks (track, method, world seed) of ``band_means`` and
   ``fft_magnitude`` on the quick localization tracks of the grid and unvisited-region
   protocols (not the outdoor ones: minutes per task, they would swamp the comparison with
   the figures measured before them), with the render cache **warm** (step 1
   rendered every run they need: the cache is keyed by pixels, not by method), so it measures
   evaluation. The same tasks run on a local Ray started with ``num_cpus=1`` (one worker at a
   time), then, after ``ray.shutdown()``, with ``num_cpus=2``. Wall time of each sweep (worker
   start-up included, ``ray.init`` not), the speed-up ratio, and whether both gave the same
   scores as each other and as the local backend in step 1.

The machine's load average is recorded before and after each phase: on a shared machine the
figures are noisy. Writes ``published/benchmarks/leaderboard_bench.json`` (``--json``).

3. **Full size** (``--full-size METHOD``, instead of 1 and 2): one full-size task per track
   (its first world seed) from a cold cache, timed, with its seconds per phase (render, fit,
   features, episodes, other: :mod:`sfa_gym.phases`); the full board's time per track is
   estimated as that times the track's world seeds (each world seed renders its own runs).
   ``--compare REV`` runs each task a second time with the code of commit REV (a temporary git
   worktree, a fresh process) and prints the ratio of the two times without rendering.

Backs docs/leaderboard.md (measured times).

Usage (from the repository root; ~15-20 min on 2 cores, plus the outdoor tracks)::

    .venv/bin/python -m eval.benchmarks.bench_leaderboard
    .venv/bin/python -m eval.benchmarks.bench_leaderboard --skip-board --cache ~/.cache/sfa-gym/runs
    .venv/bin/python -m eval.benchmarks.bench_leaderboard --skip-ray --tracks outdoor_paper \
        outdoor_appearance --board-method band_means fft_magnitude sfa \
        --json published/benchmarks/leaderboard_outdoor_bench.json
    .venv/bin/python -m eval.benchmarks.bench_leaderboard --full-size band_means \
        --json published/benchmarks/leaderboard_full_bench.json
    .venv/bin/python -m eval.benchmarks.bench_leaderboard --full-size band_means --compare HEAD~1
"""

from __future__ import annotations

import contextlib
import json
import os
import platform
import tempfile
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import tyro

import sfa_gym
from sfa_gym.files import write_json_atomic
from sfa_gym.leaderboard.backends import run_tasks
from sfa_gym.leaderboard.evaluate import Task
from sfa_gym.leaderboard.results import git_commit
from sfa_gym.leaderboard.sweep import run_sweep
from sfa_gym.leaderboard.tracks import list_tracks
from sfa_gym.recording.cache import RunCache

ROOT = Path(__file__).resolve().parents[2]

BASELINES = ROOT / "baselines"


def _load() -> list[float]:
    return [round(v, 2) for v in os.getloadavg()]


def _render_seconds(cache: RunCache, before: int) -> tuple[int, float]:
    """Renders logged since line ``before`` and their seconds."""
    lines = cache.renders()[before:]
    seconds = sum(float(line.rsplit("seconds=", 1)[1]) for line in lines)
    return len(lines), round(seconds, 2)


def method_file(method: str) -> Path:
    """A method named by its file in ``baselines/`` (``band_means``) or by a path."""
    path = Path(method)
    return path if path.suffix == ".py" else BASELINES / f"{method}.py"


def quick_board(tracks: list[Any], methods: list[str], results: Path, cache: RunCache) -> list:
    """Score each method on each track at the quick size, locally; wall time per (track,
    method), renders included for the first method that needs them."""
    rows = []
    for track, method in ((t, m) for t in tracks for m in methods):
        before, load = len(cache.renders()), _load()
        started = time.perf_counter()
        (path,) = run_sweep(
            [track],
            [(method_file(method), {})],
            results,
            quick=True,
            cache_dir=cache.root,
            resume=False,  # timed: an earlier run's task files must not be reused
        )
        seconds = time.perf_counter() - started
        renders, render_s = _render_seconds(cache, before)
        (result,) = json.loads(path.read_text())["results"]
        rows.append(
            {
                "track": track.name,
                "method": Path(method).stem,
                "seconds": round(seconds, 2),
                "renders": renders,
                "render_seconds": render_s,
                "tasks": len(result["per_world_seed"]),
                "score": result["score"]["mean"],
                "scores": result["per_world_seed"],
                "load_before": load,
                "load_after": _load(),
            }
        )
        print(
            f"{track.name:18s} {Path(method).stem:14s} {seconds:7.1f} s  ({renders} renders, "
            f"{render_s:.1f} s)  score {result['score']['mean']:.3f}",
            flush=True,
        )
    return rows


# Runs one task with the sfa_gym of the working directory (a worktree of another commit) and
# prints its output as the last line: how long the same task took at that commit.
_AT_COMMIT = """
import json, sys, time
from sfa_gym.leaderboard.evaluate import Task, run_task
args = json.loads(sys.argv[1])
started = time.perf_counter()
out = run_task(Task(args["track"], args["method"], {}, args["seed"], False, args["cache"]))
print(json.dumps({"seconds": time.perf_counter() - started, "score": out["scores"]["score"]}))
"""


def task_at_commit(worktree: Path, task: Task, cache: RunCache) -> dict[str, Any]:
    """``task`` run by the code of ``worktree`` in a fresh process: its seconds, the seconds it
    spent rendering (the cache's log) and its score."""
    import subprocess
    import sys

    before = len(cache.renders())
    args = {
        "track": str(Path(task.track_path).resolve()),
        "method": str(Path(task.method_path).resolve()),
        "seed": task.world_seed,
        "cache": str(cache.root),
    }
    done = subprocess.run(
        [sys.executable, "-c", _AT_COMMIT, json.dumps(args)],
        cwd=worktree,
        env={**os.environ, "PYTHONPATH": str(worktree)},
        capture_output=True,
        text=True,
        check=True,
    )
    found = json.loads(done.stdout.strip().splitlines()[-1])
    _, render_s = _render_seconds(cache, before)
    return {**found, "render_seconds": render_s}


def full_size_tasks(
    tracks: list[Any], method: str, cache: RunCache, compare: Path | None = None
) -> list[dict[str, Any]]:
    """One full-size task per track (its first world seed), local backend, in the order of
    ``tracks``: its wall time, renders included for the first task that needs them, and the
    board's time on the track estimated as that times the track's world seeds (each world seed
    renders its own runs, so the first task's cost is every task's). With ``compare`` (a
    worktree of another commit), the same task is run right after by that commit's code, and
    the ratio of the two times without rendering is reported (the second run finds the renders
    in the cache unless the rendering code differs)."""
    rows = []
    for track in tracks:
        seeds, _ = track.sized(False)
        task = Task(str(track.path), str(method_file(method)), {}, seeds[0], False, str(cache.root))
        before, load = len(cache.renders()), _load()
        started = time.perf_counter()
        (output,) = run_tasks([task])
        seconds = time.perf_counter() - started
        renders, render_s = _render_seconds(cache, before)
        other = None if compare is None else task_at_commit(compare, task, cache)
        rows.append(
            {
                "track": track.name,
                "method": Path(method).stem,
                "world_seed": seeds[0],
                "seconds": round(seconds, 2),
                "renders": renders,
                "render_seconds": render_s,
                "world_seeds": len(seeds),
                "estimated_track_seconds": round(seconds * len(seeds), 1),
                "score": output["scores"]["score"],
                "phases": output["phases"],
                "load_before": load,
                "load_after": _load(),
            }
        )
        if other is not None:
            mine, theirs = seconds - render_s, other["seconds"] - other["render_seconds"]
            rows[-1]["compared"] = {**other, "ratio_without_rendering": round(mine / theirs, 3)}
        print(
            f"{track.name:18s} full size, world seed {seeds[0]}: {seconds:7.1f} s ({renders} "
            f"renders, {render_s:.1f} s); x {len(seeds)} world seeds = "
            f"{seconds * len(seeds) / 60:.1f} min  score {output['scores']['score']:.3f}\n"
            f"{'':18s} phases: "
            + ", ".join(f"{name} {s:.1f} s" for name, s in output["phases"].items())
            + (
                ""
                if other is None
                else f"\n{'':18s} the other commit: {other['seconds']:.1f} s "
                f"({other['render_seconds']:.1f} s rendering), score {other['score']:.3f}; "
                f"ratio without rendering {rows[-1]['compared']['ratio_without_rendering']:.2f}"
            ),
            flush=True,
        )
    return rows


@contextlib.contextmanager
def _worktree(rev: str | None) -> Iterator[Path | None]:
    """A temporary git worktree of ``rev`` (None: none), removed afterwards."""
    import subprocess

    if rev is None:
        yield None
        return
    folder = Path(tempfile.mkdtemp(prefix="sfa-gym-bench-rev-")) / "tree"
    subprocess.run(["git", "worktree", "add", "--detach", str(folder), rev], cwd=ROOT, check=True)
    try:
        yield folder
    finally:
        subprocess.run(["git", "worktree", "remove", "--force", str(folder)], cwd=ROOT, check=True)


def ray_speedup(tasks: list[Task], workers: tuple[int, ...]) -> dict[str, Any]:
    """Run ``tasks`` on a local Ray with each number of CPUs in ``workers``."""
    import ray

    out: dict[str, Any] = {"tasks": len(tasks), "runs": []}
    scores = []
    for n in workers:
        ray.init(num_cpus=n, include_dashboard=False, log_to_driver=False)
        try:
            load = _load()
            started = time.perf_counter()
            outputs = run_tasks(tasks, "ray")
            seconds = time.perf_counter() - started
        finally:
            ray.shutdown()
        scores.append([o["scores"]["score"] for o in outputs])
        out["runs"].append(
            {
                "num_cpus": n,
                "seconds": round(seconds, 2),
                "task_seconds_sum": round(sum(o["seconds"] for o in outputs), 2),
                "load_before": load,
                "load_after": _load(),
            }
        )
        print(f"ray, {n} worker(s): {seconds:.1f} s for {len(tasks)} tasks", flush=True)
    out["same_scores"] = all(s == scores[0] for s in scores)
    out["scores"] = scores[0]
    first, last = out["runs"][0]["seconds"], out["runs"][-1]["seconds"]
    out["speedup"] = round(first / last, 3)
    print(f"speed-up {workers[0]} -> {workers[-1]} workers: {out['speedup']:.2f}x", flush=True)
    return out


@dataclass(frozen=True)
class Args:
    cache: Path | None = None
    """render cache (None: a fresh temporary folder)"""
    results: Path = ROOT / "results" / "leaderboard_bench"
    """results folder of the quick board"""
    json: Path = ROOT / "published/benchmarks/leaderboard_bench.json"
    """where the figures are written"""
    board_method: tuple[str, ...] = ("band_means",)
    """methods of the quick board: names in baselines/ or plug-in paths"""
    ray_methods: tuple[str, ...] = ("band_means", "fft_magnitude")
    """methods of the Ray speed-up"""
    skip_board: bool = False
    """only the Ray speed-up"""
    skip_ray: bool = False
    """only the quick board"""
    tracks: tuple[str, ...] | None = None
    """track names (None: every track)"""
    full_size: str | None = None
    """instead of the quick board and Ray: one full-size task per track with this METHOD, timed,
    and the full board's time per track estimated from it"""
    compare: str | None = None
    """with --full-size: run each task again by the code of git commit REV (a temporary
    worktree) and print the ratio of the times without rendering"""


def select_tracks(names: tuple[str, ...] | None) -> list[Any]:
    """The tracks of ``tracks/`` named by ``names`` (None: all), in the folder's order.

    Raises:
        SystemExit: a name that is no track.
    """
    tracks = list_tracks(ROOT / "tracks")
    if names is None:
        return tracks
    unknown = sorted(set(names) - {t.name for t in tracks})
    if unknown:
        raise SystemExit(f"--tracks {unknown[0]!r} is not a track")
    return [t for t in tracks if t.name in names]


def main(argv: list[str] | None = None) -> int:
    args = tyro.cli(Args, args=argv, description=__doc__.split("\n")[0])
    cache_root = args.cache or Path(tempfile.mkdtemp(prefix="sfa-gym-bench-cache-"))
    cache = RunCache(cache_root)
    tracks = select_tracks(args.tracks)
    report: dict[str, Any] = {
        "sfa_gym_version": sfa_gym.__version__,
        "git_commit": git_commit(ROOT),
        "machine": platform.machine(),
        "cpus": os.cpu_count(),
        "python": platform.python_version(),
        "cache": str(cache_root),
        "cache_renders_at_start": len(cache.renders()),
    }
    started = time.perf_counter()
    if args.full_size:
        print(f"full size, one world seed per track, {args.full_size}, cache {cache_root}")
        with _worktree(args.compare) as other:
            rows = full_size_tasks(tracks, args.full_size, cache, other)
        report["full_size"] = {
            "compared_with": args.compare,
            "method": Path(args.full_size).stem,
            "backend": "local",
            "cache": "cold" if report["cache_renders_at_start"] == 0 else "as found",
            "tracks": rows,
            "estimated_board_seconds": round(sum(r["estimated_track_seconds"] for r in rows), 1),
        }
        return _write(report, started, args.json)
    if not args.skip_board:
        print(f"quick board, {args.board_method}, local backend, cache {cache_root}", flush=True)
        board = quick_board(tracks, args.board_method, args.results, cache)
        report["quick_board"] = {
            "methods": [Path(m).stem for m in args.board_method],
            "backend": "local",
            "cache": "cold" if report["cache_renders_at_start"] == 0 else "as found",
            "tracks": board,
            "seconds": round(sum(r["seconds"] for r in board), 2),
        }
    if args.skip_ray:
        return _write(report, started, args.json)
    localization = [t for t in tracks if t.kind == "localization" and t.evaluation != "outdoor"]
    tasks = [
        Task(str(t.path), str(BASELINES / f"{m}.py"), {}, seed, True, str(cache_root))
        for t in localization
        for m in args.ray_methods
        for seed in t.sized(True)[0]
    ]
    if args.skip_board:
        # warm the cache outside the timed sweeps: one method renders every run they need
        first = Path(tasks[0].method_path).stem
        run_tasks([t for t in tasks if Path(t.method_path).stem == first])
    before = len(cache.renders())
    report["ray"] = {
        "methods": args.ray_methods,
        "tracks": [t.name for t in localization],
        "cache": "warm",
        **ray_speedup(tasks, (1, 2)),
    }
    report["ray"]["renders_during_ray"] = len(cache.renders()) - before
    if not args.skip_board:
        local = {
            (r["track"], r["method"], int(seed)): score
            for r in report["quick_board"]["tracks"]
            for seed, score in r["scores"].items()
        }
        # every task the board also ran (same track, method and world seed)
        keys = [(Path(t.track_path).stem, Path(t.method_path).stem, t.world_seed) for t in tasks]
        report["ray"]["same_scores_as_local"] = all(
            local[key] == score
            for key, score in zip(keys, report["ray"]["scores"], strict=True)
            if key in local
        )
    return _write(report, started, args.json)


def _write(report: dict[str, Any], started: float, path: Path) -> int:
    report["seconds"] = round(time.perf_counter() - started, 2)
    path.parent.mkdir(parents=True, exist_ok=True)
    write_json_atomic(path, report)
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
