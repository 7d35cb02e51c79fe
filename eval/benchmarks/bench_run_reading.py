"""Benchmark: the memory a process holds after reading a recorded run's panoramas the way the
evaluator does (``load_run(path).panoramas[:]``, and every fifth sample), against the same
panoramas read with ``np.load`` from ``panoramas.npy`` (the reference: the copy alone).

The run is a pose-list run of the outdoor tracks' test size (``--panoramas`` of 60 x 600),
written by :func:`sfa_gym.recording.recorder.record` in blocks of 500 from an env that shows
seeded random pixels: what a read holds does not depend on them, and no rendering is needed.
Every case runs in its own child process, which reports from ``/proc/self/status`` how much its
peak resident memory (``VmHWM``) rose over its resident memory before the read and, holding
the copy, how much its anonymous and its file-backed resident memory grew (``RssAnon``,
``RssFile``), and the read's wall-clock seconds. A file left memory-mapped after the read shows
as file-backed memory beside the copy: the same panoramas counted twice in the peak a
leaderboard task records (``task_peak_rss_mb``).

Usage (from the repository root; under a minute, Linux only)::

    .venv/bin/python -m eval.benchmarks.bench_run_reading [--panoramas 2800]
    .venv/bin/python -m eval.benchmarks.bench_run_reading --reader /tmp/other-checkout \
        --out published/benchmarks/run_reading_other.json

(``--reader``: a checkout that reads the same run format, version 2; the published files of
6a2d1a6 and aa72c75 were measured on the chunked format of version 1.) Writes
``published/benchmarks/run_reading.json`` (``--out``; it records the reader's commit) and
prints the table of docs/speed.md for it.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import gymnasium as gym
import numpy as np
import tyro

from sfa_gym.files import write_json_atomic
from sfa_gym.leaderboard.results import git_commit
from sfa_gym.recording.drivers import GridPositions
from sfa_gym.recording.recorder import record
from sfa_gym.recording.runfile import load_run

Case = Literal["np.load", "panoramas[:]", "panoramas[::5]"]
CASES: tuple[Case, ...] = ("np.load", "panoramas[:]", "panoramas[::5]")
SHAPE = (60, 600, 3)
CHUNK = 500


@dataclass(frozen=True)
class Args:
    panoramas: int = 2800
    """panoramas in the run (the outdoor tracks' test runs have 2800)"""
    out: Path = Path("published/benchmarks/run_reading.json")
    reader: Path = Path(__file__).resolve().parents[2]
    """the checkout whose ``sfa_gym`` the children read with (default: this one), to measure
    the reader of another commit on the same run"""
    child: Case | None = None
    """internal: read the run at --run this way and print the memory figures"""
    run: Path | None = None
    """internal: the run a child reads"""


class NoiseCamera(gym.Env):
    """Seeded random panoramas at the poses it is reset to; a pose-list run only resets."""

    arena_bounds = (0.0, 10.0, 0.0, 10.0)
    dt = 0.1
    observation_space = gym.spaces.Box(0, 255, SHAPE, np.uint8)
    action_space = gym.spaces.Box(-1.0, 1.0, (2,), np.float32)

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        super().reset(seed=seed)
        x, y, yaw = (float(v) for v in (options or {})["pose"])
        panorama = self.np_random.integers(0, 256, SHAPE, dtype=np.uint8)
        return panorama, {"x": x, "y": y, "yaw": yaw}

    def step(self, action: Any):
        raise NotImplementedError("a pose-list run only resets")


def _status_mb() -> dict[str, float]:
    # read here, not through sfa_gym.memory: a child may import an older checkout's sfa_gym
    # (--reader), which is asked for nothing but its run reader
    fields = {}
    for line in Path("/proc/self/status").read_text().splitlines():
        name, _, value = line.partition(":")
        if name in ("VmRSS", "VmHWM", "RssAnon", "RssFile"):
            fields[name] = int(value.split()[0]) / 1024
    return fields


def _read(case: Case, run_dir: Path) -> None:
    """One child: read the run, print its memory figures as JSON on one line."""
    run = load_run(run_dir)
    (run_dir / "panoramas.npy").read_bytes()  # each case starts from the same page cache
    before = _status_mb()
    start_s = time.perf_counter()
    if case == "np.load":
        kept = np.load(run_dir / "panoramas.npy", allow_pickle=False)
    else:
        kept = run.panoramas[:] if case == "panoramas[:]" else run.panoramas[::5]
    seconds = time.perf_counter() - start_s
    after = _status_mb()
    print(
        json.dumps(
            {
                "copy_mb": kept.nbytes / 2**20,
                "read_s": seconds,
                "rss_before_mb": before["VmRSS"],
                "peak_growth_mb": after["VmHWM"] - before["VmRSS"],
                "anon_growth_mb": after["RssAnon"] - before["RssAnon"],
                "file_growth_mb": after["RssFile"] - before["RssFile"],
            }
        )
    )


def _measure(case: Case, run_dir: Path, reader: Path) -> dict[str, float]:
    command = [
        sys.executable,
        str(Path(__file__).resolve()),
        "--child",
        case,
        "--run",
        str(run_dir),
    ]
    # run as a file, the script finds sfa_gym through PYTHONPATH: the reader's checkout first
    environment = {**os.environ, "PYTHONPATH": str(reader.resolve())}
    done = subprocess.run(command, capture_output=True, text=True, check=True, env=environment)
    return json.loads(done.stdout.strip().splitlines()[-1])


def main(args: Args) -> None:
    if args.child is not None:
        if args.run is None:
            raise SystemExit("--child needs --run")
        _read(args.child, args.run)
        return
    if not Path("/proc/self/status").is_file():
        raise SystemExit("this benchmark reads Linux's /proc/self/status")
    if args.panoramas < 10:
        raise SystemExit(f"--panoramas must be >= 10, got {args.panoramas}")
    side = int(np.ceil(np.sqrt(args.panoramas)))
    with tempfile.TemporaryDirectory() as tmp:
        run_dir = Path(tmp) / "noise.run"
        record(
            NoiseCamera(), GridPositions(n=side), run_dir, n_steps=args.panoramas, chunk_size=CHUNK
        )
        rows = {case: _measure(case, run_dir, args.reader) for case in CASES}
    # imported here, not at the top: a child runs this file against the --reader checkout,
    # which may predate the table
    from eval.tables.cost_formatters import run_reading_table

    reference = rows[CASES[0]]["peak_growth_mb"]
    for row in rows.values():
        row["ratio"] = row["peak_growth_mb"] / reference
    result = {
        "commit": git_commit(args.reader),
        "panoramas": args.panoramas,
        "panorama": list(SHAPE[:2]),
        "chunk_size": CHUNK,
        "ratio_to": CASES[0],
        "rows": rows,
    }
    write_json_atomic(args.out, result)
    print(run_reading_table([result], {}))
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main(tyro.cli(Args))
