"""``sfa-gym leaderboard run`` and ``sfa-gym leaderboard table``: score methods on the versioned
tracks of ``tracks/`` and build the table (:mod:`sfa_gym.leaderboard`)."""

from __future__ import annotations

import contextlib
import json
import signal
import threading
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any, Literal

import tyro

from sfa_gym.intervals import format_interval

__all__ = ["Leaderboard", "LeaderboardRun", "LeaderboardTable"]


def _parse_args(items: tuple[str, ...], option: str = "--method-args") -> dict[str, Any]:
    """``("n_bands=4", "regressor=map")`` -> ``{"n_bands": 4, "regressor": "map"}`` (values
    read as JSON where they parse, else kept as text)."""
    out: dict[str, Any] = {}
    for item in items:
        name, sep, value = item.partition("=")
        if not sep or not name:
            raise ValueError(f"{option} takes NAME=VALUE items, got {item!r}")
        try:
            out[name] = json.loads(value)
        except json.JSONDecodeError:
            out[name] = value
    return out


@dataclass(frozen=True)
class LeaderboardRun:
    """Score methods on tracks; one result file per (track, method) with a 95 % interval
    across the track's world seeds. Each task's result is written as it finishes, and the same
    command run again runs only the tasks not finished yet; a failing task is reported at the
    end (exit status 1) without losing the others."""

    method: tuple[str, ...]
    """feature-method plug-ins: built-in names (band_means, fft_magnitude, pca, raw_pixels,
    sfa, deep_sfa, contrastive) or .py files of your own; several: a sweep"""
    track: tuple[str, ...] = ("all",)
    """track names (files of --tracks) or "all" """
    quick: bool = False
    """the tracks' reduced size (fewer world seeds, smaller grids)"""
    backend: Literal["local", "ray"] = "local"
    """local: in this process, no Ray; ray: one Ray task per (track, method, world seed)"""
    address: str | None = None
    """ray: the cluster to join ("auto", "ray://head:10001"); default: start a local Ray"""
    num_cpus: int | None = None
    """ray, local Ray only: CPUs it may use, at least 1 (default: all)"""
    method_args: tuple[str, ...] = ()
    """arguments of the methods' Args, NAME=VALUE (e.g. n_bands=4), applied to every method"""
    controller: str | None = None
    """navigation tracks only: a controller plug-in, a built-in name (run_and_tumble) or a .py
    file, that drives the rover instead of the tracks'
    gradient controller; with --track all, the navigation tracks"""
    controller_args: tuple[str, ...] = ()
    """arguments of the controller's Args, NAME=VALUE"""
    results: Path = Path("results/leaderboard")
    """results folder"""
    tracks: Path | None = None
    """folder of track files (default: tracks/ of the checkout)"""
    cache: Path | None = None
    """render cache folder (default: $SFA_GYM_CACHE, else ~/.cache/sfa-gym/runs on Linux or
    $XDG_CACHE_HOME/sfa-gym/runs where that is set); on a cluster, a folder every node sees"""
    time_limits: tuple[str, ...] = ()
    """wall-clock limits of the calls into the plug-ins, NAME=SECONDS (e.g. fit=3600
    transform=600; names: load, fit, transform, reset, act), over the tracks' time_limits, over
    the defaults"""
    memory_limit_mb: int | None = None
    """memory limit of each plug-in's worker process, MiB (default: the track's
    memory_limit_mb, else 3/4 of this machine's memory divided among the tasks that run at once:
    one per CPU on Ray)"""
    rerun: bool = False
    """compute every task again; by default a task whose file under <results>/tasks holds its
    finished result (same track version, method file, arguments and size) is reused, so that
    an interrupted sweep resumes"""

    def run(self) -> int:
        import sys

        from sfa_gym.leaderboard.backends import check_backend
        from sfa_gym.leaderboard.sweep import SweepError, run_sweep
        from sfa_gym.leaderboard.tracks import list_tracks
        from sfa_gym.sandbox import check_memory_mb, check_time_limits

        # every option checked before a track is read or a worker started
        check_backend(self.backend, self.num_cpus)
        time_limits = check_time_limits(
            _parse_args(self.time_limits, "--time-limits"), "--time-limits"
        )
        if self.memory_limit_mb is not None:
            check_memory_mb(self.memory_limit_mb, "--memory-limit-mb")
        available = {t.name: t for t in list_tracks(self.tracks)}
        if "all" in self.track:
            chosen = [
                t for t in available.values() if self.controller is None or t.kind == "navigation"
            ]
        else:
            unknown = [name for name in self.track if name not in available]
            if unknown:
                raise ValueError(
                    f"--track {unknown[0]!r} is not a track; the tracks are "
                    f"{sorted(available)} (or all)"
                )
            chosen = [available[name] for name in self.track]
        if not chosen:
            folder = self.tracks if self.tracks is not None else "the default track folder"
            kind = "navigation track" if self.controller is not None else "track file"
            raise ValueError(f"no {kind} in {folder}: nothing to score")
        args = _parse_args(self.method_args)
        stopped: list[int] = []
        try:
            with _stop_on_sigterm(stopped):
                written = run_sweep(
                    chosen,
                    [(path, args) for path in self.method],
                    self.results,
                    quick=self.quick,
                    backend=self.backend,
                    address=self.address,
                    num_cpus=self.num_cpus,
                    cache_dir=self.cache,
                    controller=None
                    if self.controller is None
                    else (self.controller, _parse_args(self.controller_args, "--controller-args")),
                    resume=not self.rerun,
                    time_limits=time_limits,
                    memory_limit_mb=self.memory_limit_mb,
                )
        except SweepError as error:
            _print_results(error.written)
            print(f"error: {error}", file=sys.stderr)
            print(
                "the other tasks' results are written; fix the failing ones and run the same "
                "command again: it runs only the tasks not yet finished",
                file=sys.stderr,
            )
            return 1
        except KeyboardInterrupt:
            signum = stopped[0] if stopped else signal.SIGINT
            print(f"stopped by {signal.Signals(signum).name}", file=sys.stderr)
            return 128 + signum
        _print_results(written)
        return 0


def _print_results(paths: list[Path]) -> None:
    """A line per result file: its mean with the interval."""
    for path in paths:
        (result,) = json.loads(path.read_text())["results"]
        score = result["score"]
        interval = format_interval(score["ci95"], score["n"], digits=3)
        # with too few seeds for an interval the count stands alone, else the method beside it
        method = f" (95 %, {score['interval']})" if score["ci95"] else ""
        print(f"{path}: {score['mean']:.3f} {interval}{method}")


@contextlib.contextmanager
def _stop_on_sigterm(stopped: list[int]) -> Iterator[None]:
    """Within: SIGTERM stops the sweep as Ctrl-C does (a KeyboardInterrupt; the signal number is
    appended to ``stopped``), so that it says what it kept and exits with 128 + 15. The
    finished tasks' files are on disk either way: they are written as each task finishes."""
    if threading.current_thread() is not threading.main_thread():
        yield  # signal handlers can be set in the main thread only
        return

    def stop(signum: int, frame: Any) -> None:
        stopped.append(signum)
        raise KeyboardInterrupt(f"signal {signum}")

    previous = signal.signal(signal.SIGTERM, stop)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


@dataclass(frozen=True)
class LeaderboardTable:
    """The table of your results beside the committed reference results (published/leaderboard),
    each row labelled by its source: LEADERBOARD.md and leaderboard.png, or --markdown. A cell
    is marked † when its result was computed with package versions other than the lock's
    (constraints.txt), ‡ when its navigation episodes differ from the reference result's (episode
    fingerprints); each marked result is named on stderr. Every result is checked before it is
    shown: a file that cannot be read, lacks a field, has a wrong type, lies in another track's
    folder or whose stored mean does not follow from its seeds' scores is skipped and named on
    stderr; a result of another track version (or other world seeds) than tracks/ holds gets a
    column of its own, also named on stderr."""

    results: Path = Path("results/leaderboard")
    """your results folder (searched recursively)"""
    tracks: Path | None = None
    """folder of the current track files (default: tracks/ of the checkout)"""
    out: Path | None = None
    """where to write the table and the chart (default: the results folder)"""
    reference: bool = True
    """show the committed reference results beside yours"""
    markdown: bool = False
    """print the markdown table only (for README.md and docs/), write no files (but --csv)"""
    csv: Path | None = None
    """also write the table to this CSV file: a line per cell (method, source, column, track,
    version, quick, mean, ci95_low, ci95_high, n, higher_is_better, marks), the numbers as
    stored in the results"""

    def run(self) -> int:
        import sys

        from sfa_gym.leaderboard.checks import check_board
        from sfa_gym.leaderboard.results import REFERENCE, YOURS, reference_folder
        from sfa_gym.leaderboard.table import load_board, markdown_table, write_board, write_csv

        reference = reference_folder() if self.reference else None
        skipped: list[str] = []
        try:
            board = load_board(self.results, reference, skipped, self.tracks)
        finally:  # named even when nothing at all is left to show
            for line in skipped:
                print(f"warning: skipped {line}", file=sys.stderr)
        for column, why in sorted(board.apart.items()):
            files = sorted(r["_file"] for r in board.cells[column].values())
            print(
                f"warning: {', '.join(files)}: {why}; shown apart in column {column!r}",
                file=sys.stderr,
            )
        if not any(source == YOURS for _, source in board.rows):
            print(f"no results of yours under {self.results}", file=sys.stderr)
        marks = check_board(board, reference=REFERENCE)
        for line in marks.warnings():
            print(f"warning: {line}", file=sys.stderr)
        if self.markdown:
            print(markdown_table(board, marks), end="")
        else:
            out = self.out if self.out is not None else self.results
            print(write_board(board, out, marks), end="")
        if self.csv is not None:
            write_csv(board, self.csv, marks)
        return 0


@dataclass(frozen=True)
class LeaderboardPublish:
    """Gather the result files of a results folder into one file, the form in which reference
    results are published (published/leaderboard/quick.json); the docs' board tables are
    generated from it (sfa-gym docs-tables)."""

    out: Path
    """the gathered file to write (e.g. published/leaderboard/quick.json)"""
    results: Path = Path("results/leaderboard")
    """the results folder of the run (searched recursively); a gathered file in it is kept
    entry by entry, so copying a published file in extends it (a result file of the same
    track, size and method replaces its entry)"""
    description: str = (
        "Per track and method the mean score over the track's world seeds, its 95 % interval, each "
        "seed's score, the parts' means and the provenance of the result file. Localization: "
        "MAE % (lower is better); navigation: success rate."
    )
    """what the file holds, stored in it"""

    def run(self) -> int:
        from sfa_gym.leaderboard.results import write_gathered

        n = write_gathered(self.results, self.out, self.description)
        print(f"{n} results of {self.results} gathered into {self.out}")
        return 0


@dataclass(frozen=True)
class LeaderboardCompare:
    """Compare a run of the board with a reference (a published file): per track, size and
    method, whether every world seed both scored, and its parts, are equal to the last stored
    digit (a gathered file keeps only the parts' means), the largest difference, and what else
    differs between the two results (method file, track version or size, CPU numerics, package
    versions). Exit status 1 when a score differs."""

    results: Path = Path("results/leaderboard")
    """the run: a results folder (searched recursively) or a gathered file"""
    reference: Path = Path("published/leaderboard/quick.json")
    """the reference: a gathered file (published/leaderboard/*.json) or a results folder"""
    all: bool = False
    """list the reference's results the run does not have too (default: only those it has)"""

    def run(self) -> int:
        from sfa_gym.leaderboard.compare import compare_results, comparison_table, read_results

        rows = compare_results(read_results(self.reference), read_results(self.results))
        if not self.all:
            rows = [r for r in rows if r.status != "reference only"]
        print(comparison_table(rows))
        return 1 if any(r.status == "differs" for r in rows) else 0


@dataclass(frozen=True)
class Leaderboard:
    """The leaderboard: score methods on versioned tracks (run), build the table (table), gather
    a run's results into one published file (publish), check a run against a published one
    (compare)."""

    command: (
        Annotated[LeaderboardRun, tyro.conf.subcommand("run")]
        | Annotated[LeaderboardTable, tyro.conf.subcommand("table")]
        | Annotated[LeaderboardPublish, tyro.conf.subcommand("publish")]
        | Annotated[LeaderboardCompare, tyro.conf.subcommand("compare")]
    )

    def run(self) -> int:
        return self.command.run()
