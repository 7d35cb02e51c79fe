"""Benchmark: what running plug-ins out of the evaluator's process costs per leaderboard task.

For each track of ``tracks/`` (or ``--tracks``) at its quick size, the task of each method
(``--methods``, default ``band_means``) on the track's first world seed runs once to fill the
render cache (not counted), then in this process alternately with the plug-in imported here
(``SFA_GYM_PLUGINS_IN_PROCESS=1``) and in its worker process (the default: confined by
bubblewrap where it works), ``--repeats`` times each; the two orders alternate so that a drift
of the machine's load does not favour one. Prints each task's median seconds both ways and
their ratio, and the ratio of the sums (the board's cost); both ways must give the same score.

Writes ``published/benchmarks/isolation_bench.json`` (``--json``). Backs the figure in
docs/plugins.md. On a shared machine the figures are noisy: the load average is recorded.

Usage (from the repository root)::

    .venv/bin/python -m eval.benchmarks.bench_isolation
    .venv/bin/python -m eval.benchmarks.bench_isolation --tracks train_test nav_open --repeats 3
"""

from __future__ import annotations

import os
import platform
import statistics
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import tyro

from eval.benchmarks.bench_leaderboard import ROOT, _load, _write, method_file, select_tracks
from sfa_gym.leaderboard.evaluate import Task, run_task
from sfa_gym.leaderboard.results import git_commit
from sfa_gym.sandbox import IN_PROCESS, isolation


def _timed(task: Task, in_process: bool) -> tuple[float, float]:
    """Seconds of ``task`` and its score, with the plug-in in this process or in a worker."""
    before = os.environ.get(IN_PROCESS)
    os.environ[IN_PROCESS] = "1" if in_process else "0"
    try:
        started = time.perf_counter()
        output = run_task(task)
        return time.perf_counter() - started, output["scores"]["score"]
    finally:
        if before is None:
            del os.environ[IN_PROCESS]
        else:
            os.environ[IN_PROCESS] = before


def isolation_costs(
    tracks: list[Any], methods: list[str], cache: str, repeats: int
) -> list[dict[str, Any]]:
    rows = []
    for track in tracks:
        seeds, _ = track.sized(True)
        for method in methods:
            task = Task(str(track.path), str(method_file(method)), {}, seeds[0], True, cache)
            _timed(task, in_process=False)  # fills the render cache
            times: dict[bool, list[float]] = {True: [], False: []}
            scores = set()
            load = _load()
            for r in range(repeats):
                for in_process in (True, False) if r % 2 == 0 else (False, True):
                    seconds, score = _timed(task, in_process)
                    times[in_process].append(seconds)
                    scores.add(score)
            inside, worker = statistics.median(times[True]), statistics.median(times[False])
            rows.append(
                {
                    "track": track.name,
                    "method": Path(method).stem,
                    "world_seed": seeds[0],
                    "in_process_seconds": round(inside, 2),
                    "worker_seconds": round(worker, 2),
                    "ratio": round(worker / inside, 3),
                    "same_score": len(scores) == 1,
                    "load_before": load,
                    "load_after": _load(),
                }
            )
            print(
                f"{track.name:18s} {Path(method).stem:14s} in-process {inside:7.2f} s, worker "
                f"{worker:7.2f} s, ratio {worker / inside:.3f}, same score: {len(scores) == 1}",
                flush=True,
            )
    return rows


@dataclass(frozen=True)
class Args:
    methods: tuple[str, ...] = ("band_means",)
    """baseline names (baselines/<name>.py) or method files"""
    tracks: tuple[str, ...] | None = None
    """track names (None: every track)"""
    repeats: int = 1
    """runs of each task each way"""
    cache: Path | None = None
    """render cache (None: a fresh temporary folder)"""
    json: Path = ROOT / "published/benchmarks/isolation_bench.json"
    """where the figures are written"""


def main(argv: list[str] | None = None) -> int:
    args = tyro.cli(Args, args=argv, description=__doc__.split("\n")[0])
    if args.repeats < 1:
        raise SystemExit(f"--repeats must be >= 1, got {args.repeats}")
    tracks = select_tracks(args.tracks)
    cache = str(args.cache or tempfile.mkdtemp(prefix="sfa-gym-bench-cache-"))
    started = time.perf_counter()
    rows = isolation_costs(tracks, args.methods, cache, args.repeats)
    inside = sum(r["in_process_seconds"] for r in rows)
    worker = sum(r["worker_seconds"] for r in rows)
    print(
        f"all tasks: in-process {inside:.1f} s, worker {worker:.1f} s, ratio {worker / inside:.3f}"
    )
    report = {
        "git_commit": git_commit(ROOT),
        "machine": platform.machine(),
        "cpus": os.cpu_count(),
        "python": platform.python_version(),
        "isolation": isolation(),
        "repeats": args.repeats,
        "tasks": rows,
        "in_process_seconds": round(inside, 2),
        "worker_seconds": round(worker, 2),
        "ratio": round(worker / inside, 3),
    }
    return _write(report, started, args.json)


if __name__ == "__main__":
    raise SystemExit(main())
