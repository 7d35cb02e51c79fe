"""The leaderboard table: results (:mod:`sfa_gym.leaderboard.results`) arranged as a column per
track and a row per method and source (yours beside the committed reference), written as
markdown (LEADERBOARD.md), detail tables and a chart (leaderboard.png), and as CSV (a line per
cell, with its numbers unformatted) for analysis elsewhere.

A column holds one experiment: one track at one size, at the version and world seeds of the
track file in ``tracks/``. A result of another track version (or, at the same version, of other
world seeds) is put in a column of its own, ``"<track> v<N>"`` (``"<track> seeds [...]"``), never
averaged or ranked with the current version's; :attr:`Board.apart` says why.
"""

from __future__ import annotations

import csv
import json
import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

from sfa_gym.intervals import format_interval
from sfa_gym.leaderboard.results import REFERENCE, YOURS, load_results

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from sfa_gym.leaderboard.tracks import Track

__all__ = [
    "Board",
    "CellMarks",
    "Row",
    "arrange",
    "column_of",
    "csv_rows",
    "current_tracks",
    "detail_tables",
    "draw_chart",
    "load_board",
    "markdown_table",
    "write_board",
    "write_csv",
    "write_table",
]


def load_board(
    results_dir: str | os.PathLike[str],
    reference: str | os.PathLike[str] | None = None,
    skipped: list[str] | None = None,
    tracks: str | os.PathLike[str] | None = None,
) -> Board:
    """Your results under ``results_dir`` and, beside them, the reference results under
    ``reference`` (None, or the same folder: none), arranged as the table shows them, each
    column at the version of the track files of ``tracks`` (default: ``tracks/``,
    :func:`current_tracks`).

    Args:
        skipped: where to note each result that cannot be shown and go on (see
            :func:`~sfa_gym.leaderboard.results.load_results`); None: raise at the first.

    Raises:
        ValueError: no results in either folder.
        ResultError: (``skipped`` None) a result that cannot be shown.
    """
    results = load_results(results_dir, skipped=skipped)
    if reference is not None and Path(reference).resolve() != Path(results_dir).resolve():
        results += load_results(reference, REFERENCE, skipped)
    if not results:
        where = f"{results_dir} or {reference}" if reference is not None else str(results_dir)
        raise ValueError(f"no leaderboard results under {where}")
    return arrange(results, current_tracks(tracks))


def current_tracks(folder: str | os.PathLike[str] | None = None) -> dict[str, Track]:
    """The track files of ``folder`` (default: ``tracks/``) by name; none where there is no such
    folder (an installation without the track files)."""
    from sfa_gym.leaderboard.tracks import list_tracks

    try:
        return {t.name: t for t in list_tracks(folder)}
    except FileNotFoundError:
        return {}


def _as_json(value: Any) -> Any:
    return json.loads(json.dumps(value))


def column_of(result: dict[str, Any], tracks: Mapping[str, Track]) -> tuple[str, str | None]:
    """The column of ``result`` and, when it is apart from the current track's column, why: its
    track, then ``" v<N>"`` when its track version is not that of ``tracks[name]``, else
    ``" seeds [...]"`` when its world seeds are not the track's at its size, else
    ``" other size"`` when a quick result's parameters are not the track file's quick size
    (``" size not recorded"`` when it does not say), then ``" (quick)"`` at the quick size. A
    track not in ``tracks`` is taken as it is."""
    name, quick, version = result["track"], result["quick"], result["track_version"]
    seeds = sorted(int(seed) for seed in result["per_world_seed"])
    track = tracks.get(name)
    why = None
    if track is not None and version != track.track_version:
        name += f" v{version}"
        why = f"track version {version}; the track file is version {track.track_version}"
    elif track is not None and seeds != sorted(track.sized(quick)[0]):
        name += f" seeds {seeds}"
        why = f"world seeds {seeds}; the track file's are {sorted(track.sized(quick)[0])}"
    elif (
        track is not None and quick and result.get("size_params") != _as_json(track.sized(True)[1])
    ):
        # the quick section changed without a new track version (it is not the track's
        # definition); a result that does not record its size is of an unknown one
        recorded = result.get("size_params")
        if recorded is None:
            name += " size not recorded"
            why = "the result does not record its quick size (written before results did)"
        else:
            name += " other size"
            why = f"quick size {recorded}; the track file's is {_as_json(track.sized(True)[1])}"
    return name + (" (quick)" if quick else ""), why


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
    apart: dict[str, str] = field(default_factory=dict)
    """``{column: why}`` for the columns of results that differ from the track file's version
    or world seeds (:func:`column_of`)."""

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


def arrange(results: list[dict[str, Any]], tracks: Mapping[str, Track] | None = None) -> Board:
    """The :class:`Board` of ``results``; your rows before the reference rows of a method;
    results of another version or seeds than ``tracks`` (by name; None: none) in columns apart
    (:func:`column_of`).

    Raises:
        ValueError: no results.
    """
    if not results:
        raise ValueError("no leaderboard results to show")
    cells: dict[str, dict[Row, dict[str, Any]]] = {}
    apart: dict[str, str] = {}
    for r in results:
        key, why = column_of(r, tracks or {})
        if why is not None:
            apart[key] = why
        cells.setdefault(key, {})[(r["method"], r.get("_source", YOURS))] = r
    order = {YOURS: 0, REFERENCE: 1}
    rows = sorted(
        {row for col in cells.values() for row in col},
        key=lambda row: (row[0], order.get(row[1], 2), row[1]),
    )
    return Board(cells, sorted(cells), rows, apart)


def _cell(score: dict[str, Any]) -> str:
    return f"{score['mean']:.2f} {format_interval(score['ci95'], score['n'])}"


def _parts_tables(board: Board) -> list[str]:
    """Markdown lines: for each track whose results report ``parts`` (the outdoor tracks: each
    condition, the unvisited region), a table of each part's mean over the world seeds."""
    lines: list[str] = []
    for t in board.tracks:
        parts_of = {row: r.get("parts") for row, r in board.cells[t].items()}
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
    per track; a cell is the mean over the world seeds with its interval, with its ``marks``:
    see :func:`~sfa_gym.leaderboard.checks.check_board`), the parts of the outdoor tracks'
    scores, and each track's version, world seeds and commit."""
    lines = [
        "# Leaderboard",
        "",
        "Mean over the scoring world seeds, with the Student-t 95 % interval across them in "
        "brackets, clipped to the score's range; with fewer than three seeds, their number "
        "instead (n=2). Localization: MAE in % of the coordinate range, mean of x and y (lower is "
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
    if board.apart:
        footnotes += ["", "Columns apart (not comparable with the track's current column):"]
        footnotes += [f"- {column}: {why}" for column, why in sorted(board.apart.items())]
    return "\n".join(lines + footnotes + detail_tables(board)) + "\n"


CSV_FIELDS = (
    "method",
    "source",
    "column",
    "track",
    "track_version",
    "quick",
    "mean",
    "ci95_low",
    "ci95_high",
    "n",
    "higher_is_better",
    "marks",
)
"""The columns of the CSV table (:func:`csv_rows`)."""


def csv_rows(board: Board, marks: CellMarks | None = None) -> list[dict[str, Any]]:
    """The cells of :func:`markdown_table` as CSV lines, in its order (row by row, then column
    by column; no line for an empty cell): the row's method and source, the table's column
    (``"<track> (quick)"``, or a column apart), the result's track, version and size, the mean
    and the ends of its 95 % interval as stored (empty when there is none: fewer than three
    seeds), the number of seeds, the score's direction and the cell's marks (``†``, ``‡``)."""
    lines = []
    for row in board.rows:
        for column in board.tracks:
            result = board.cells[column].get(row)
            if result is None:
                continue
            score = result["score"]
            low, high = score["ci95"] if score.get("ci95") else ("", "")
            lines.append(
                {
                    "method": row[0],
                    "source": row[1],
                    "column": column,
                    "track": result["track"],
                    "track_version": result["track_version"],
                    "quick": result["quick"],
                    "mean": score["mean"],
                    "ci95_low": low,
                    "ci95_high": high,
                    "n": score["n"],
                    "higher_is_better": score["higher_is_better"],
                    "marks": marks.mark(column, row) if marks else "",
                }
            )
    return lines


def write_csv(
    board: Board, path: str | os.PathLike[str], marks: CellMarks | None = None
) -> list[dict[str, Any]]:
    """Write :func:`csv_rows` of ``board`` to ``path`` (a header line, then a line per cell;
    UTF-8, for the marks); returns the rows."""
    rows = csv_rows(board, marks)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "w", newline="", encoding="utf-8") as file:
        writer = csv.DictWriter(file, fieldnames=CSV_FIELDS)
        writer.writeheader()
        writer.writerows(rows)
    return rows


def _spl_table(board: Board) -> list[str]:
    """Markdown lines: the navigation tracks' SPL (success weighted by path length), the mean over
    the world seeds, a column per navigation track; none when no result has it."""
    spl = {
        t: {row: found for row, r in board.cells[t].items() if (found := r.get("spl"))}
        for t in board.tracks
    }
    tracks = [t for t in board.tracks if spl[t]]
    if not tracks:
        return []
    lines = [
        "",
        "Navigation: SPL, success weighted by the shortest path's length over the driven one "
        "(mean over the world seeds)",
        "",
        "| method | source | " + " | ".join(tracks) + " |",
        "|---" * (len(tracks) + 2) + "|",
    ]
    for row in (row for row in board.rows if any(row in spl[t] for t in tracks)):
        cells = [f"{spl[t][row]['mean']:.2f}" if row in spl[t] else "-" for t in tracks]
        lines.append(f"| {row[0]} | {row[1]} | " + " | ".join(cells) + " |")
    return lines


def detail_tables(board: Board) -> list[str]:
    """Markdown lines below the score table: the parts of the outdoor tracks' scores, the
    navigation tracks' SPL, and each track's version, world seeds and commit (per source)."""
    lines = _parts_tables(board) + _spl_table(board)
    lines += ["", "| track | source | version | world seeds | commit |", "|---|---|---|---|---|"]
    for t in board.tracks:
        for source in dict.fromkeys(row[1] for row in board.rows if row in board.cells[t]):
            any_result = next(r for row, r in board.cells[t].items() if row[1] == source)
            seeds = [int(seed) for seed in any_result["per_world_seed"]]
            commit = any_result.get("git_commit") or "-"
            version = any_result["track_version"]
            lines.append(f"| {t} | {source} | {version} | {seeds} | {commit} |")
    return lines


def draw_chart(board: Board) -> Figure:
    """The chart of ``board``: one panel per track (four a row), a bar per row (the mean, with
    the interval) and a dot per world seed; the axis follows the scores, so an interval wider
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
        # each world seed's score: with few seeds the interval is wide or none, the points say why
        points = [list(board.cells[t][row]["per_world_seed"].values()) for row in rows]
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
        ValueError: no results in either folder, or a result that cannot be shown.
    """
    board = load_board(results_dir, reference)
    return write_board(board, out if out is not None else results_dir, marks)


def write_board(board: Board, out: str | os.PathLike[str], marks: CellMarks | None = None) -> str:
    """Write ``LEADERBOARD.md`` and ``leaderboard.png`` of ``board`` into ``out`` (see
    :func:`write_table`); returns the markdown text."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out_dir = Path(out)
    out_dir.mkdir(parents=True, exist_ok=True)
    text = markdown_table(board, marks)
    (out_dir / "LEADERBOARD.md").write_text(text)
    fig = draw_chart(board)
    fig.savefig(out_dir / "leaderboard.png", dpi=90)
    plt.close(fig)
    return text
