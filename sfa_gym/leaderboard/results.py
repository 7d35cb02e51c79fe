"""Leaderboard results: one JSON file per (track, method, size), and the table built from them.

A result file ``<results>/<track>/<method label>[.quick].json`` holds::

    {"format": "sfa-gym-leaderboard-result", "schema_version": 1,
     "track": {...the track file's content..., "quick": bool},
     "method": {"name", "path", "sha256", "args"},
     "score": {"mean", "ci95": [lo, hi] | null, "interval": "t", "n", "std",
               "higher_is_better"},
     "tasks": [{"world_seed", "fit_world_seed", "scores": {...}, "seconds"}, ...],
     "provenance": {"sfa_gym_version", "git_commit", "python", "platform", "machine",
                    "cpus", "backend", "created", "seconds", "versions", "cpu_numerics"}}

``versions`` are the installed versions of the locked packages (``constraints.txt``,
:mod:`sfa_gym.lock`) that computed the result, ``cpu_numerics`` what of the CPU decides the last
bits beside them (:func:`~sfa_gym.lock.cpu_numerics`); a navigation task's scores hold its episodes'
``fingerprint`` (:func:`~sfa_gym.protocols.navigation.episode_fingerprint`). The table marks the
results whose versions differ from the lock or whose fingerprints differ from the reference
result's (:mod:`sfa_gym.leaderboard.checks`).

The interval is a Student-t 95 % interval of the mean across the scoring world seeds (with one
seed there is none: ``null``). Scores are computed per world seed, so the result does not
depend on which backend ran which seed.

The committed reference results (:func:`reference_folder`, ``published/leaderboard/``) may also
be *gathered* files: ``{"description", "results": [...]}`` with one summary per track and method
(``track``, ``track_version``, ``quick``, ``method``, ``score``, ``per_world_seed``, ``parts``,
``git_commit``, ``versions``, ``fingerprints`` (``{world seed: fingerprint}``), ...;
:func:`gathered_entry` writes one). :func:`load_results` reads both kinds into the shape of a
result file, and the table shows each row's source: your results beside the reference ones.
"""

from __future__ import annotations

import datetime
import json
import math
import os
import platform
import subprocess
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

import sfa_gym
from sfa_gym._files import write_json_atomic

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = [
    "FORMAT",
    "REFERENCE",
    "SCHEMA_VERSION",
    "YOURS",
    "Board",
    "arrange",
    "detail_tables",
    "draw_chart",
    "gathered_entry",
    "git_commit",
    "load_board",
    "load_results",
    "make_result",
    "mean_parts",
    "markdown_table",
    "reference_folder",
    "result_path",
    "summarize",
    "write_table",
]

FORMAT = "sfa-gym-leaderboard-result"
SCHEMA_VERSION = 1
YOURS = "yours"
"""The source of the results a user ran (the results folder of ``sfa-gym leaderboard``)."""
REFERENCE = "reference"
"""The source of the committed reference results (:func:`reference_folder`)."""


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
    from sfa_gym.lock import cpu_numerics, installed_versions

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
            "versions": installed_versions(),
            "cpu_numerics": cpu_numerics(),
        },
    }


def write_result(path: Path, result: dict[str, Any]) -> None:
    """Write ``result`` atomically (strict JSON)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    write_json_atomic(path, result)


def reference_folder() -> Path:
    """The committed reference results: ``published/leaderboard`` of the checkout this sfa_gym
    runs from, else the copy inside the installed package.

    Raises:
        FileNotFoundError: neither exists (an incomplete installation).
    """
    from sfa_gym.data import data_folder

    return data_folder("published") / "leaderboard"


_GATHERED_FIELDS = ("track", "track_version", "quick", "method", "score", "per_world_seed")
_GATHERED_PROVENANCE = ("git_commit", "backend", "created", "versions", "cpu_numerics")
"""What a gathered entry keeps of a result's provenance."""


def _from_gathered(entry: Any, path: Path, source: str) -> dict[str, Any]:
    """An entry of a gathered file in the shape of a result file, as far as the table reads it.

    A gathered entry keeps each seed's score but only the mean of each part, so the parts go
    into ``parts`` beside the tasks instead of into each task's scores.
    """
    missing = [k for k in _GATHERED_FIELDS if not isinstance(entry, dict) or k not in entry]
    if missing:
        raise ValueError(
            f"{path}: an entry of 'results' lacks {missing}; expected an object with "
            f"{list(_GATHERED_FIELDS)}"
        )
    fingerprints = entry.get("fingerprints") or {}
    return {
        "track": {
            "name": entry["track"],
            "quick": bool(entry["quick"]),
            "track_version": entry["track_version"],
        },
        "method": {"label": entry["method"], "sha256": entry.get("method_sha256")},
        "score": entry["score"],
        "tasks": [
            {
                "world_seed": int(seed),
                "scores": {"score": value}
                | ({"fingerprint": fingerprints[seed]} if seed in fingerprints else {}),
            }
            for seed, value in entry["per_world_seed"].items()
        ],
        "parts": entry.get("parts"),
        "provenance": {k: entry.get(k) for k in _GATHERED_PROVENANCE},
        "_file": str(path),
        "_source": source,
    }


def gathered_entry(result: dict[str, Any]) -> dict[str, Any]:
    """The entry of a gathered file (see the module docstring) that keeps what the table reads
    of the result file ``result``: the score, each seed's score, the parts' means, the
    provenance, the package versions and the navigation tasks' episode fingerprints."""
    tasks = result["tasks"]
    provenance = result["provenance"]
    fingerprints = {
        str(t["world_seed"]): t["scores"]["fingerprint"]
        for t in tasks
        if "fingerprint" in t["scores"]
    }
    return {
        "track": result["track"]["name"],
        "track_version": result["track"]["track_version"],
        "quick": bool(result["track"]["quick"]),
        "method": result["method"]["label"],
        "method_sha256": result["method"].get("sha256"),
        "score": result["score"],
        "per_world_seed": {str(t["world_seed"]): t["scores"]["score"] for t in tasks},
        "parts": mean_parts(result),
        "task_seconds": [t.get("seconds") for t in tasks],
        **{k: provenance.get(k) for k in _GATHERED_PROVENANCE},
        **({"fingerprints": fingerprints} if fingerprints else {}),
    }


def load_results(results: str | os.PathLike[str], source: str = YOURS) -> list[dict[str, Any]]:
    """Every result under ``results`` (recursively): result files, checked for format and
    version, and the entries of gathered files (see the module docstring); each marked with
    ``source`` (``"_source"``). A folder that does not exist holds no results.

    Raises:
        ValueError: a file that is not a leaderboard result or has another schema version, or a
            gathered entry that lacks a field.
    """
    out = []
    for path in sorted(Path(results).rglob("*.json")):
        data = json.loads(path.read_text())
        if not isinstance(data, dict):
            continue
        if data.get("format") != FORMAT:
            if isinstance(data.get("results"), list):
                out += [_from_gathered(entry, path, source) for entry in data["results"]]
            continue
        if data.get("schema_version") != SCHEMA_VERSION:
            raise ValueError(
                f"{path}: result schema_version {data.get('schema_version')!r}; this sfa_gym "
                f"reads {SCHEMA_VERSION}"
            )
        data["_file"] = str(path)
        data["_source"] = source
        out.append(data)
    return out


def load_board(
    results_dir: str | os.PathLike[str], reference: str | os.PathLike[str] | None = None
) -> Board:
    """Your results under ``results_dir`` and, beside them, the reference results under
    ``reference`` (None, or the same folder: none), arranged as the table shows them.

    Raises:
        ValueError: no results in either folder.
    """
    results = load_results(results_dir)
    if reference is not None and Path(reference).resolve() != Path(results_dir).resolve():
        results += load_results(reference, REFERENCE)
    if not results:
        where = f"{results_dir} or {reference}" if reference is not None else str(results_dir)
        raise ValueError(f"no leaderboard results under {where}")
    return arrange(results)


Row = tuple[str, str]
"""A row of the table: ``(method label, source)``."""


@dataclass(frozen=True)
class Board:
    """Results as the table shows them: a column per track (full size and quick size kept
    apart, ``"<track> (quick)"``), a row per method and source; ``cells[track][row]`` is the
    result."""

    cells: dict[str, dict[Row, dict[str, Any]]]
    tracks: list[str]
    rows: list[Row]

    @property
    def several_sources(self) -> bool:
        """Whether the rows come from more than one source (yours and the reference)."""
        return len({source for _, source in self.rows}) > 1

    def name(self, row: Row) -> str:
        """The row's name in the chart: the method, with its source when there are several."""
        return f"{row[0]} ({row[1]})" if self.several_sources else row[0]

    def higher_is_better(self, track: str) -> bool:
        """Whether a higher score is better on ``track`` (navigation: success rate)."""
        return next(iter(self.cells[track].values()))["score"]["higher_is_better"]


def arrange(results: list[dict[str, Any]]) -> Board:
    """The :class:`Board` of ``results``; your rows before the reference rows of a method.

    Raises:
        ValueError: no results.
    """
    if not results:
        raise ValueError("no leaderboard results to show")
    cells: dict[str, dict[Row, dict[str, Any]]] = {}
    for r in results:
        key = r["track"]["name"] + (" (quick)" if r["track"]["quick"] else "")
        cells.setdefault(key, {})[(r["method"]["label"], r.get("_source", YOURS))] = r
    order = {YOURS: 0, REFERENCE: 1}
    rows = sorted(
        {row for col in cells.values() for row in col},
        key=lambda row: (row[0], order.get(row[1], 2), row[1]),
    )
    return Board(cells, sorted(cells), rows)


def _cell(score: dict[str, Any]) -> str:
    lo_hi = score["ci95"]
    interval = f" [{lo_hi[0]:.2f}, {lo_hi[1]:.2f}]" if lo_hi else ""
    return f"{score['mean']:.2f}{interval}"


def mean_parts(result: dict[str, Any]) -> dict[str, float] | None:
    """The mean of each part of the score over the world seeds (outdoor tracks: each condition,
    the unvisited region); None when the result's scores have no parts."""
    if result.get("parts") is not None:  # a gathered entry keeps only the means
        return result["parts"]
    tasks = result["tasks"]
    if not tasks or not all("parts" in task["scores"] for task in tasks):
        return None
    names = dict.fromkeys(p for task in tasks for p in task["scores"]["parts"])
    out = {}
    for part in names:
        values = [task["scores"]["parts"].get(part) for task in tasks]
        values = [v for v in values if v is not None]
        if values:
            out[part] = float(np.mean(values))
    return out


def _parts_tables(board: Board) -> list[str]:
    """Markdown lines: for each track whose results report ``parts`` (the outdoor tracks: each
    condition, the unvisited region), a table of each part's mean over the world seeds."""
    lines: list[str] = []
    for t in board.tracks:
        parts_of = {row: mean_parts(r) for row, r in board.cells[t].items()}
        if None in parts_of.values():
            continue
        parts = list(dict.fromkeys(p for found in parts_of.values() for p in found))
        lines += [
            "",
            f"{t}: the parts of the score (mean over the world seeds)",
            "",
            "| method | source | " + " | ".join(parts) + " |",
            "|---" * (len(parts) + 2) + "|",
        ]
        for row in (row for row in board.rows if row in parts_of):
            found = parts_of[row]
            cells = [f"{found[p]:.2f}" if p in found else "-" for p in parts]
            lines.append(f"| {row[0]} | {row[1]} | " + " | ".join(cells) + " |")
    return lines


class CellMarks(Protocol):
    """Marks on the table's cells and their footnotes
    (:class:`~sfa_gym.leaderboard.checks.Marks`)."""

    def mark(self, column: str, row: Row) -> str: ...

    def footnotes(self) -> list[str]: ...


def markdown_table(board: Board, marks: CellMarks | None = None) -> str:
    """The markdown of ``LEADERBOARD.md``: the scores (a row per method and source, a column
    per track; a cell is the mean over the world seeds with its t-interval, with its ``marks``:
    see :func:`~sfa_gym.leaderboard.checks.check_board`), the parts of the outdoor tracks'
    scores, and each track's version, world seeds and commit."""
    lines = [
        "# Leaderboard",
        "",
        "Mean over the scoring world seeds, with the Student-t 95 % interval across them in "
        "brackets. Localization: MAE in % of the coordinate range, mean of x and y (lower is "
        "better); navigation: success rate (higher is better). Source: yours (your results "
        "folder) or reference (the committed reference results).",
        "",
        "| method | source | " + " | ".join(board.tracks) + " |",
        "|---" * (len(board.tracks) + 2) + "|",
    ]
    for row in board.rows:
        cells = [
            _cell(board.cells[t][row]["score"]) + (marks.mark(t, row) if marks else "")
            if row in board.cells[t]
            else "-"
            for t in board.tracks
        ]
        lines.append(f"| {row[0]} | {row[1]} | " + " | ".join(cells) + " |")
    footnotes = marks.footnotes() if marks else []
    return "\n".join(lines + footnotes + detail_tables(board)) + "\n"


def detail_tables(board: Board) -> list[str]:
    """Markdown lines below the score table: the parts of the outdoor tracks' scores, and each
    track's version, world seeds and commit (per source)."""
    lines = _parts_tables(board)
    lines += ["", "| track | source | version | world seeds | commit |", "|---|---|---|---|---|"]
    for t in board.tracks:
        for source in dict.fromkeys(row[1] for row in board.rows if row in board.cells[t]):
            any_result = next(r for row, r in board.cells[t].items() if row[1] == source)
            seeds = [task["world_seed"] for task in any_result["tasks"]]
            commit = any_result["provenance"]["git_commit"] or "-"
            version = any_result["track"]["track_version"]
            lines.append(f"| {t} | {source} | {version} | {seeds} | {commit} |")
    return lines


def draw_chart(board: Board) -> Figure:
    """The chart of ``board``: one panel per track (four a row), a bar per row (the mean, with
    the t-interval) and a dot per world seed; the axis follows the scores, so an interval wider
    than them is cut at the panel's edge."""
    import matplotlib.pyplot as plt

    tracks = board.tracks
    # at most four panels a row, so that a board of many tracks stays readable
    ncols = min(4, len(tracks))
    nrows = -(-len(tracks) // ncols)
    fig, axes = plt.subplots(nrows, ncols, figsize=(3.0 * ncols, 3.3 * nrows), squeeze=False)
    for ax, t in zip(axes.flat, tracks, strict=False):
        rows = [row for row in board.rows if row in board.cells[t]]
        scores = [board.cells[t][row]["score"] for row in rows]
        means = np.array([s["mean"] for s in scores])
        err = np.array(
            [
                [s["mean"] - s["ci95"][0], s["ci95"][1] - s["mean"]] if s["ci95"] else [0, 0]
                for s in scores
            ]
        ).T
        # beside yours, the reference rows in grey
        gray = [board.several_sources and row[1] == REFERENCE for row in rows]
        colors = ["tab:gray" if g else "tab:blue" for g in gray]
        ax.bar(range(len(rows)), means, yerr=err, capsize=3, color=colors, alpha=0.8)
        # each world seed's score: with few seeds the t-interval is wide, the points say why
        points = [
            [task["scores"]["score"] for task in board.cells[t][row]["tasks"]] for row in rows
        ]
        for i, values in enumerate(points):
            ax.plot([i] * len(values), values, "k.", markersize=4)
        higher = board.higher_is_better(t)
        top = max(max(v) for v in points)
        # the axis follows the scores, not the intervals (which may reach far beyond them)
        ax.set_ylim(0, 1.05 if higher and top <= 1 else 1.3 * top)
        names = [board.name(row) for row in rows]
        ax.set_xticks(range(len(rows)), names, rotation=45, ha="right", fontsize=8)
        ax.set_title(f"{t}\n({'higher' if higher else 'lower'} is better)", fontsize=9)
        ax.set_ylabel("success rate" if higher else "MAE, % of range", fontsize=8)
        ax.tick_params(axis="y", labelsize=8)
    for ax in list(axes.flat)[len(tracks) :]:
        ax.set_visible(False)
    fig.tight_layout()
    return fig


def write_table(
    results_dir: str | os.PathLike[str],
    out: str | os.PathLike[str] | None = None,
    reference: str | os.PathLike[str] | None = None,
    marks: CellMarks | None = None,
) -> str:
    """Write ``LEADERBOARD.md`` and ``leaderboard.png`` (into ``out``, default the results
    folder) from every result under ``results_dir``, and
    beside them those under ``reference`` (the committed reference results, see
    :func:`reference_folder`; None: none), its cells marked by ``marks`` (see
    :func:`markdown_table`); returns the markdown text.

    Raises:
        ValueError: no results in either folder.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    board = load_board(results_dir, reference)
    out_dir = Path(out) if out is not None else Path(results_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    text = markdown_table(board, marks)
    (out_dir / "LEADERBOARD.md").write_text(text)
    fig = draw_chart(board)
    fig.savefig(out_dir / "leaderboard.png", dpi=90)
    plt.close(fig)
    return text
