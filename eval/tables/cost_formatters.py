"""Markdown tables of what a board's tasks cost, from the records of a gathered board file
(``task_seconds``, ``task_phases``, ``task_peak_rss_mb``): tracks as rows, methods as
columns. Options of both: ``tracks=a,b`` and ``methods=a,b`` choose and order rows and
columns, as for :func:`~eval.tables.formatters.board_table`. Beside them, the memory of
reading a recorded run (:func:`run_reading_table`)."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

from eval.tables.formatters import _head, _records, _row, _split

__all__ = ["board_memory_table", "board_seconds_table", "run_reading_table"]


def _grid(
    files: Sequence[dict[str, Any]],
    options: dict[str, str],
    name: str,
    per_task: Callable[[dict[str, Any]], list[Any] | None],
) -> tuple[list[str], list[str], dict[tuple[str, str], list[Any]]]:
    """The tracks, the methods and each (track, method)'s per-task values (``per_task`` of its
    record; records where it gives None are left out)."""
    records = _records(files, name)
    tracks = _split(options.get("tracks")) or list(dict.fromkeys(r["track"] for r in records))
    methods = _split(options.get("methods")) or list(dict.fromkeys(r["method"] for r in records))
    cells = {}
    for r in records:
        values = per_task(r)
        if values is not None:
            cells[(r["track"], r["method"])] = values
    return tracks, methods, cells


def _shared(record: dict[str, Any]) -> list[bool]:
    """Per world seed, whether the task was scored within another track's task (no seconds and
    no phases of its own: the grid tracks of one world share a fit, a paper outdoor track is a
    part of its appearance track's task)."""
    phases = record.get("task_phases")
    if not phases:  # written before tasks recorded their phases
        return [False] * len(record["task_seconds"])
    return [p == {} for p in phases]


def board_seconds_table(files: Sequence[dict[str, Any]], options: dict[str, str]) -> str:
    """The seconds a board's tasks took, from its file's ``task_seconds``: the mean seconds of
    a world seed's task (renders included where that task rendered) and, in the last row, each
    method's whole board (every task, one after the other). A task scored within another
    track's task costs nothing of its own: it is left out of the mean, and a cell whose every
    task was is ``shared``. Option ``phase=fit`` (or another phase of ``task_phases``): that
    phase's seconds only."""
    phase = options.get("phase")

    def per_task(record: dict[str, Any]) -> list[Any] | None:
        if phase is None:
            seconds = record["task_seconds"]
        elif not record.get("task_phases"):
            return None
        else:
            # a task without phases (written before tasks recorded them) has no seconds here
            seconds = [p.get(phase) if p else None for p in record["task_phases"]]
        shared = _shared(record)
        return ["shared" if shared[i] else v for i, v in enumerate(seconds)]

    tracks, methods, cells = _grid(files, options, "board-seconds", per_task)
    title = "track: s per world seed" if phase is None else f"track: {phase} s per world seed"
    lines = _head([title, *methods])
    total = dict.fromkeys(methods, 0.0)
    for t in tracks:
        row = [f"`{t}`"]
        for m in methods:
            values = cells.get((t, m))
            own = [v for v in values or [] if v != "shared"]
            if values and not own:
                row.append("shared")
                continue
            if not own or None in own:
                row.append("-")
                continue
            total[m] += sum(own)
            row.append(f"{sum(own) / len(own):.0f}")
        lines.append(_row(row))
    lines.append(_row(["all these tasks, minutes", *(f"{total[m] / 60:.0f}" for m in methods)]))
    return "\n".join(lines)


def board_memory_table(files: Sequence[dict[str, Any]], options: dict[str, str]) -> str:
    """The peak resident memory of a board's tasks, from its file's ``task_peak_rss_mb``: per
    track and method the largest over the world seeds, in GiB, of the plug-in's worker and, in
    parentheses, of the evaluator (:mod:`sfa_gym.memory`); ``-`` where a task did not record
    it (tasks written before the field was)."""
    tracks, methods, cells = _grid(
        files, options, "board-memory", lambda record: record.get("task_peak_rss_mb")
    )
    lines = _head(["track: peak GiB, plug-in (evaluator)", *methods])
    for t in tracks:
        row = [f"`{t}`"]
        for m in methods:
            peaks = cells.get((t, m))
            if not peaks or any(p is None or p.get("plugins") is None for p in peaks):
                row.append("-")
                continue
            plugin = max(p["plugins"] for p in peaks) / 1024
            evaluator = max(p["evaluator"] for p in peaks) / 1024
            row.append(f"{plugin:.2f} ({evaluator:.2f})")
        lines.append(_row(row))
    return "\n".join(lines)


def run_reading_table(files: Sequence[dict[str, Any]], options: dict[str, str]) -> str:
    """What a process holds after reading a run's panoramas, each way in its own process
    (``eval/benchmarks/bench_run_reading.py``): the copy, the peak's rise and its ratio to the
    reference read, and the anonymous and file-backed memory added, in MB, and the read's
    seconds; per file, the commit whose reader it measured."""
    head = ["read (reader's commit)", "copy MB", "peak rise MB", "ratio"]
    lines = _head([*head, "anonymous MB", "file-backed MB", "read s"])
    for data in files:
        commit = data.get("commit") or "unknown"
        # the short hash, keeping git_commit's "+dirty": uncommitted changes were measured too
        commit = commit[:7] + commit[40:]
        for name, row in data["rows"].items():
            cells = [
                f"{row['copy_mb']:.0f}",
                f"{row['peak_growth_mb']:.0f}",
                f"{row['ratio']:.2f}",
                f"{row['anon_growth_mb']:.0f}",
                f"{row['file_growth_mb']:.0f}",
                f"{row['read_s']:.2f}",
            ]
            lines.append(_row([f"`{name}` ({commit})", *cells]))
    return "\n".join(lines)
