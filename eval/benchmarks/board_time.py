"""Where a leaderboard sweep's time went, from the task files it wrote.

Every task file (``<results>/tasks/<track>/<method>/<world seed>.json``) records when it was
written (``provenance.created``, to the second), the task's wall seconds and their phases
(render, fit, features, episodes, other). From them this script gives, per track, when its
first task started and its last ended (minutes from the sweep's first start), the wall span,
the tasks' seconds and phases, and for the whole sweep the wall time from the first start to the
last end and how many cores the tasks kept busy (task seconds / wall). Tasks scored with another
task (``provenance.scored_with``: the paper's outdoor track within the appearance track) count
as covered, with no seconds of their own.

Run it on the results folder of a sweep that ran from start to end in one sitting (a resumed
sweep's span includes the pause)::

    /usr/bin/time sfa-gym leaderboard run --method sfa --backend ray --num-cpus 2 \\
        --results R --cache C
    .venv/bin/python -m eval.benchmarks.board_time R --method sfa \\
        --json published/benchmarks/board_time_sfa.json

Backs the per-track board times on docs/speed.md (``board-time`` tables).
"""

from __future__ import annotations

import datetime
import json
import os
import platform
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import tyro

PHASES = ("render", "fit", "features", "episodes", "other")


def _task_records(results: Path, method: str) -> list[dict[str, Any]]:
    """The finished task files of ``method`` under ``results/tasks``."""
    found = []
    for path in sorted((results / "tasks").glob(f"*/{method}/*.json")):
        record = json.loads(path.read_text())
        if record.get("output") is not None:
            found.append(record)
    if not found:
        raise ValueError(f"no finished task of method {method!r} under {results / 'tasks'}")
    return found


def board_time(results: Path, method: str) -> dict[str, Any]:
    """Per track and for the whole sweep: wall span, task seconds and phases (module docstring)."""
    records = _task_records(results, method)
    spans = []
    for r in records:
        end = datetime.datetime.fromisoformat(r["provenance"]["created"]).timestamp()
        spans.append((end - float(r["output"]["seconds"]), end))
    origin = min(start for start, _ in spans)
    tracks: dict[str, dict[str, Any]] = {}
    for r, (start, end) in zip(records, spans, strict=True):
        name = r["identity"]["track"]["name"]
        t = tracks.setdefault(
            name,
            {"track": name, "tasks": 0, "covered": 0, "from": start, "to": end, "seconds": 0.0}
            | {"phases": dict.fromkeys(PHASES, 0.0)},
        )
        if "scored_with" in r["provenance"]:
            t["covered"] += 1
            continue
        t["tasks"] += 1
        t["from"], t["to"] = min(t["from"], start), max(t["to"], end)
        t["seconds"] += float(r["output"]["seconds"])
        for phase, seconds in (r["output"].get("phases") or {}).items():
            t["phases"][phase] = t["phases"].get(phase, 0.0) + float(seconds)
    rows = []
    for t in sorted(tracks.values(), key=lambda t: (t["from"], t["track"])):
        ran = t["tasks"] > 0
        rows.append(
            {
                "track": t["track"],
                "tasks": t["tasks"],
                "covered": t["covered"],
                "from_minutes": round((t["from"] - origin) / 60, 2) if ran else None,
                "to_minutes": round((t["to"] - origin) / 60, 2) if ran else None,
                "wall_minutes": round((t["to"] - t["from"]) / 60, 2) if ran else 0.0,
                "task_seconds": round(t["seconds"], 1),
                "phases": {k: round(v, 1) for k, v in t["phases"].items()},
            }
        )
    wall = max(end for _, end in spans) - origin
    task_seconds = sum(row["task_seconds"] for row in rows)
    return {
        "method": method,
        "results": str(results),
        "tracks": rows,
        "wall_minutes": round(wall / 60, 2),
        "task_seconds": round(task_seconds, 1),
        "cores_busy": round(task_seconds / wall, 2) if wall > 0 else None,
        "git_commits": sorted({r["provenance"].get("git_commit") or "?" for r in records}),
        "machine": {"cpus": os.cpu_count(), "platform": platform.platform()},
    }


@dataclass
class Args:
    results: tyro.conf.Positional[Path]
    """the results folder of the sweep (the one given to ``sfa-gym leaderboard run``)"""
    method: str = "sfa"
    """the method's label (its folder under ``tasks/<track>/``)"""
    json: Path | None = None
    """write the figures to this file as well"""
    note: str = ""
    """how the sweep was run (command, cache, load), stored with the figures"""


def main(args: Args) -> dict[str, Any]:
    out = board_time(args.results, args.method) | {"note": args.note}
    print(f"{'track':20s} {'from':>6s} {'to':>6s} {'wall min':>8s} {'task s':>8s}  covered")
    for row in out["tracks"]:
        span = (
            f"{row['from_minutes']:6.1f} {row['to_minutes']:6.1f}"
            if row["tasks"]
            else f"{'-':>6s} {'-':>6s}"
        )
        print(
            f"{row['track']:20s} {span} {row['wall_minutes']:8.1f} "
            f"{row['task_seconds']:8.0f}  {row['covered']}"
        )
    print(
        f"whole sweep: {out['wall_minutes']:.1f} min wall, {out['task_seconds']:.0f} task s, "
        f"{out['cores_busy']} cores busy"
    )
    if args.json is not None:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(out, indent=1) + "\n")
    return out


if __name__ == "__main__":
    main(tyro.cli(Args))
