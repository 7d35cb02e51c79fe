"""Leaderboard results: one JSON file per (track, method, size), and the table built from them.

A result file ``<results>/<track>/<method label>[.quick].json`` holds::

    {"format": "sfa-gym-leaderboard-result", "schema_version": 1,
     "track": {...the track file's content..., "quick": bool},
     "method": {"name", "path", "sha256", "args"},
     "score": {"mean", "ci95": [lo, hi] | null, "interval": "t", "n", "std",
               "higher_is_better"},
     "tasks": [{"world_seed", "fit_world_seed", "scores": {...}, "seconds"}, ...],
     "provenance": {"sfa_gym_version", "git_commit", "python", "platform", "machine",
                    "cpus", "backend", "created", "seconds"}}

The interval is a Student-t 95 % interval of the mean across the scoring world seeds (with one
seed there is none: ``null``). Scores are computed per world seed, so the result does not
depend on which backend ran which seed.
"""

from __future__ import annotations

import datetime
import json
import math
import os
import platform
import subprocess
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

import sfa_gym
from sfa_gym._files import write_json_atomic

__all__ = [
    "FORMAT",
    "SCHEMA_VERSION",
    "git_commit",
    "load_results",
    "make_result",
    "result_path",
    "summarize",
    "write_table",
]

FORMAT = "sfa-gym-leaderboard-result"
SCHEMA_VERSION = 1


def summarize(values: Sequence[float], higher_is_better: bool) -> dict[str, Any]:
    """Mean and Student-t 95 % interval of per-world-seed ``values``."""
    from scipy import stats

    x = np.asarray(values, dtype=np.float64)
    mean = float(x.mean())
    out: dict[str, Any] = {
        "mean": mean,
        "ci95": None,
        "interval": "t",
        "n": int(len(x)),
        "std": None,
        "higher_is_better": higher_is_better,
    }
    if len(x) > 1:
        std = float(x.std(ddof=1))
        half = float(stats.t.ppf(0.975, len(x) - 1)) * std / math.sqrt(len(x))
        out.update(std=std, ci95=[mean - half, mean + half])
    return out


def git_commit(path: str | os.PathLike[str] | None = None) -> str | None:
    """The commit of the checkout at ``path`` (default: the package's folder), ``+dirty`` if
    tracked files changed; None outside a git checkout or without git."""
    where = Path(path) if path is not None else Path(sfa_gym.__file__).resolve().parent
    try:
        head = subprocess.run(
            ["git", "rev-parse", "HEAD"], cwd=where, capture_output=True, text=True, timeout=10
        )
        if head.returncode != 0:
            return None
        dirty = subprocess.run(
            ["git", "status", "--porcelain", "--untracked-files=no"],
            cwd=where,
            capture_output=True,
            text=True,
            timeout=10,
        )
    except (OSError, subprocess.SubprocessError):
        return None
    return head.stdout.strip() + ("+dirty" if dirty.stdout.strip() else "")


def method_label(name: str, args: dict[str, Any], defaults: dict[str, Any]) -> str:
    """``name``, plus the arguments that differ from the defaults (``band_means[n_bands=4]``)."""
    changed = [f"{k}={args[k]}" for k in sorted(args) if args[k] != defaults.get(k)]
    return f"{name}[{','.join(changed)}]" if changed else name


def result_path(results: Path, track: str, label: str, quick: bool) -> Path:
    """Where the result of ``label`` on ``track`` is written."""
    safe = "".join(c if c.isalnum() or c in "-_=,.[]+" else "_" for c in label)
    return results / track / f"{safe}{'.quick' if quick else ''}.json"


def make_result(
    *,
    track: Any,
    quick: bool,
    method: dict[str, Any],
    tasks: list[dict[str, Any]],
    higher_is_better: bool,
    backend: str,
    seconds: float,
) -> dict[str, Any]:
    """The result object of one track and method (see the module docstring)."""
    tasks = sorted(tasks, key=lambda t: t["world_seed"])
    return {
        "format": FORMAT,
        "schema_version": SCHEMA_VERSION,
        "track": {**track.describe(), "quick": quick},
        "method": method,
        "score": summarize([t["scores"]["score"] for t in tasks], higher_is_better),
        "tasks": tasks,
        "provenance": {
            "sfa_gym_version": sfa_gym.__version__,
            "git_commit": git_commit(),
            "python": platform.python_version(),
            "platform": platform.platform(),
            "machine": platform.machine(),
            "node": platform.node(),
            "cpus": os.cpu_count(),
            "backend": backend,
            "created": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
            "seconds": round(seconds, 2),
        },
    }


def write_result(path: Path, result: dict[str, Any]) -> None:
    """Write ``result`` atomically (strict JSON)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    write_json_atomic(path, result)


def load_results(results: str | os.PathLike[str]) -> list[dict[str, Any]]:
    """Every result file under ``results`` (recursively), checked for format and version.

    Raises:
        ValueError: a file that is not a leaderboard result or has another schema version.
    """
    out = []
    for path in sorted(Path(results).rglob("*.json")):
        data = json.loads(path.read_text())
        if not isinstance(data, dict) or data.get("format") != FORMAT:
            continue
        if data.get("schema_version") != SCHEMA_VERSION:
            raise ValueError(
                f"{path}: result schema_version {data.get('schema_version')!r}; this sfa_gym "
                f"reads {SCHEMA_VERSION}"
            )
        data["_file"] = str(path)
        out.append(data)
    return out


def _cell(score: dict[str, Any]) -> str:
    lo_hi = score["ci95"]
    interval = f" ({lo_hi[0]:.2f}-{lo_hi[1]:.2f})" if lo_hi else ""
    return f"{score['mean']:.2f}{interval}"


def _part_mean(tasks: list[dict[str, Any]], part: str) -> str:
    values = [t["scores"]["parts"].get(part) for t in tasks]
    values = [v for v in values if v is not None]
    return f"{np.mean(values):.2f}" if values else "-"


def _parts_tables(
    columns: dict[str, dict[str, Any]], tracks: list[str], methods: list[str]
) -> list[str]:
    """Markdown lines: for each track whose tasks report ``parts`` (the outdoor tracks: each
    condition, the unvisited region), a table of each part's mean over the world seeds."""
    lines: list[str] = []
    for t in tracks:
        tasks = [task for r in columns[t].values() for task in r["tasks"]]
        if not tasks or not all("parts" in task["scores"] for task in tasks):
            continue
        parts = list(dict.fromkeys(p for task in tasks for p in task["scores"]["parts"]))
        lines += [
            "",
            f"{t}: the parts of the score (mean over the world seeds)",
            "",
            "| method | " + " | ".join(parts) + " |",
            "|---" * (len(parts) + 1) + "|",
        ]
        for m in (m for m in methods if m in columns[t]):
            cells = [_part_mean(columns[t][m]["tasks"], p) for p in parts]
            lines.append(f"| {m} | " + " | ".join(cells) + " |")
    return lines


def write_table(results_dir: str | os.PathLike[str], out: str | os.PathLike[str] | None = None):
    """Write ``LEADERBOARD.md`` and ``leaderboard.png`` (into ``out``, default the results
    folder) from every result under ``results_dir``; returns the markdown text.

    Rows are methods, columns tracks (full size and quick size kept apart); a cell is the mean
    score over the world seeds with its t-interval. Tracks whose scores have parts (the
    outdoor tracks: each condition, the unvisited region) get a table of the parts below.
    The chart has one panel per track (four a row): a bar per method (the mean, with the
    t-interval) and a dot per world seed; the axis follows the scores, so an interval wider
    than them is cut at the panel's edge.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    results = load_results(results_dir)
    if not results:
        raise ValueError(f"no leaderboard results under {results_dir}")
    out_dir = Path(out) if out is not None else Path(results_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    columns: dict[str, dict[str, Any]] = {}
    for r in results:
        key = r["track"]["name"] + (" (quick)" if r["track"]["quick"] else "")
        columns.setdefault(key, {})[r["method"]["label"]] = r
    tracks = sorted(columns)
    methods = sorted({m for col in columns.values() for m in col})
    lines = [
        "# Leaderboard",
        "",
        "Mean over the scoring world seeds, with the Student-t 95 % interval across them in "
        "brackets. Localization: MAE in % of the coordinate range, mean of x and y (lower is "
        "better); navigation: success rate (higher is better).",
        "",
        "| method | " + " | ".join(tracks) + " |",
        "|---" * (len(tracks) + 1) + "|",
    ]
    for m in methods:
        cells = [_cell(columns[t][m]["score"]) if m in columns[t] else "-" for t in tracks]
        lines.append(f"| {m} | " + " | ".join(cells) + " |")
    lines += _parts_tables(columns, tracks, methods)
    lines += ["", "| track | version | world seeds | commit |", "|---|---|---|---|"]
    for t in tracks:
        any_result = next(iter(columns[t].values()))
        seeds = [task["world_seed"] for task in any_result["tasks"]]
        commit = any_result["provenance"]["git_commit"] or "-"
        lines.append(f"| {t} | {any_result['track']['track_version']} | {seeds} | {commit} |")
    text = "\n".join(lines) + "\n"
    (out_dir / "LEADERBOARD.md").write_text(text)

    # at most four panels a row, so that a board of many tracks stays readable
    ncols = min(4, len(tracks))
    nrows = -(-len(tracks) // ncols)
    fig, axes = plt.subplots(nrows, ncols, figsize=(3.0 * ncols, 3.3 * nrows), squeeze=False)
    for ax, t in zip(axes.flat, tracks, strict=False):
        names = [m for m in methods if m in columns[t]]
        scores = [columns[t][m]["score"] for m in names]
        means = np.array([s["mean"] for s in scores])
        err = np.array(
            [
                [s["mean"] - s["ci95"][0], s["ci95"][1] - s["mean"]] if s["ci95"] else [0, 0]
                for s in scores
            ]
        ).T
        ax.bar(range(len(names)), means, yerr=err, capsize=3, color="tab:blue", alpha=0.8)
        # each world seed's score: with few seeds the t-interval is wide, the points say why
        points = [[task["scores"]["score"] for task in columns[t][m]["tasks"]] for m in names]
        for i, values in enumerate(points):
            ax.plot([i] * len(values), values, "k.", markersize=4)
        higher = scores[0]["higher_is_better"]
        top = max(max(v) for v in points)
        # the axis follows the scores, not the intervals (which may reach far beyond them)
        ax.set_ylim(0, 1.05 if higher and top <= 1 else 1.3 * top)
        ax.set_xticks(range(len(names)), names, rotation=45, ha="right", fontsize=8)
        ax.set_title(f"{t}\n({'higher' if higher else 'lower'} is better)", fontsize=9)
        ax.set_ylabel("success rate" if higher else "MAE, % of range", fontsize=8)
        ax.tick_params(axis="y", labelsize=8)
    for ax in list(axes.flat)[len(tracks) :]:
        ax.set_visible(False)
    fig.tight_layout()
    fig.savefig(out_dir / "leaderboard.png", dpi=90)
    plt.close(fig)
    return text
