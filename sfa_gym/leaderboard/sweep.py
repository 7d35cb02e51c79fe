"""The sweep: every (track, method, world seed) as a task, each task's outcome written as soon as
it finishes, and one result file per (track, method) once all of its world seeds are done; what
``sfa-gym leaderboard run`` does.

A sweep never loses finished work: each task's file (:mod:`~sfa_gym.leaderboard.task_files`) is
written atomically the moment the task finishes, a failing task is recorded as a failure and the
others go on, and a rerun of the same sweep reuses every finished task whose identity (track
version, method file, arguments, size) is unchanged. A full board can therefore be run across
several sittings: interrupt it (Ctrl-C, SIGTERM, even SIGKILL) and run the same command again.
A track whose quick size changes only how many world seeds are scored runs the same tasks at
both sizes: a sweep at one size takes the finished tasks of the other size's sweep in the same
results folder for the world seeds both score (:func:`_same_task_other_size`).
"""

from __future__ import annotations

import json
import os
import sys
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from sfa_gym.leaderboard.backends import Backend, TaskFailure, check_backend, run_each
from sfa_gym.leaderboard.evaluate import HIGHER_IS_BETTER, Task, significant
from sfa_gym.leaderboard.results import (
    git_commit,
    make_result,
    method_label,
    result_path,
    write_results,
)
from sfa_gym.leaderboard.task_files import (
    TASKS_FOLDER,
    check_results_folder,
    read_finished,
    task_file,
    task_identity,
    task_provenance,
    write_task_file,
)
from sfa_gym.leaderboard.tracks import PROTOCOLS, Track, protocol_module
from sfa_gym.plugin_files import Kind
from sfa_gym.plugins import describe, file_sha256
from sfa_gym.recording.cache import RunCache
from sfa_gym.sandbox import Limits, check_memory_mb, check_time_limits
from sfa_gym.source_hash import package_sources_sha256

__all__ = ["SweepError", "run_sweep"]


class SweepError(RuntimeError):
    """Some tasks of a sweep failed; every other task was run and written, and every (track,
    method) whose world seeds all finished has its result file.

    Attributes:
        failures: ``(what, failure)`` per failed task in the order of the sweep, ``what``
            naming the track, the method and the world seed.
        written: the result files written (complete pairs only).
    """

    def __init__(self, failures: list[tuple[str, TaskFailure]], written: list[Path]) -> None:
        self.failures = failures
        self.written = written
        lines = [f"{what}: {failure}" for what, failure in failures]
        super().__init__(f"{len(failures)} task(s) failed:\n  " + "\n  ".join(lines))


@dataclass(frozen=True)
class _Planned:
    """A task of the sweep with what it is (for its file and for messages) and its pair."""

    task: Task
    identity: dict[str, Any]
    path: Path
    pair: tuple[int, int]
    what: str


def run_sweep(
    tracks: Sequence[Track],
    methods: Sequence[tuple[str | os.PathLike[str], Mapping[str, Any]]],
    results_dir: str | os.PathLike[str],
    *,
    quick: bool = False,
    backend: Backend = "local",
    address: str | None = None,
    num_cpus: int | None = None,
    cache_dir: str | os.PathLike[str] | None = None,
    controller: tuple[str | os.PathLike[str], Mapping[str, Any]] | None = None,
    resume: bool = True,
    verbose: bool = True,
    time_limits: Mapping[str, float] | None = None,
    memory_limit_mb: int | None = None,
) -> list[Path]:
    """Score every method on every track; write each task's file as it finishes and one result
    file per (track, method) once all its world seeds are done.

    Args:
        tracks: loaded tracks (each must come from a file: tasks carry its path).
        methods: plug-in files with their arguments (``{}``: the defaults).
        results_dir: the results folder (``<track>/<method label>[.quick].json`` inside, and
            the task files under ``tasks/``).
        quick: the tracks' quick size.
        backend: ``"local"`` or ``"ray"``; it, ``address`` and ``num_cpus``: see
            :func:`~sfa_gym.leaderboard.backends.run_each`.
        cache_dir: the render cache (None: the default one); must be reachable by every worker.
        controller: a controller plug-in file with its arguments, driving the rover on the
            navigation tracks instead of the tracks' gradient controller; every track must then
            be a navigation track. Results are labelled ``<method>+<controller>``.
        resume: reuse the finished tasks of an earlier sweep (same identity, see
            :mod:`~sfa_gym.leaderboard.task_files`); False computes every task again.
        verbose: a line on stderr per finished task.
        time_limits: seconds per kind of call into the plug-ins (``{"fit": 3600}``), over each
            track's ``time_limits``, over the defaults (:class:`~sfa_gym.sandbox.Limits`).
        memory_limit_mb: each plug-in worker's memory limit, MiB (None: each track's, else the
            default).

    Returns:
        The result files written, in the order of ``tracks`` x ``methods``.

    Raises:
        PluginError, ValueError: a method or controller file or its arguments are refused, an
            unknown backend, ``num_cpus`` below 1, a bad time or memory limit, two
            methods have the same label, or a controller is given for a track that is not a
            navigation track (before any task).
        OSError: the results folder cannot be written to (before any task).
        SweepError: some tasks failed (after every other task ran and was written).
        KeyboardInterrupt: interrupted; every finished task's file is kept.
    """
    check_backend(backend, num_cpus)
    limits = {"time_limits": check_time_limits(time_limits or {}, "--time-limits")}
    if memory_limit_mb is not None:
        limits["memory_limit_mb"] = check_memory_mb(memory_limit_mb, "--memory-limit-mb")
    limits["concurrent_tasks"] = concurrent_tasks(backend, address, num_cpus)
    # every task checks that it runs on these sources (sfa_gym.source_hash)
    limits["code_sha256"] = code = package_sources_sha256()
    # the plug-ins' workers must not read the render cache or the results either
    hidden = [RunCache(cache_dir).root, Path(results_dir)]
    driver = None if controller is None else _describe_controller(tracks, *controller, hidden)
    described = []
    for path, args in methods:
        method = _describe("method", path, args, hidden)
        if driver is not None:
            method |= {"label": f"{method['label']}+{driver['label']}", "controller": driver}
        described.append(method)
    _check_labels(described)
    for track in tracks:
        if track.path is None:
            raise ValueError(f"track {track.name!r} was not loaded from a file")
    results = check_results_folder(results_dir)
    say = _printer(verbose)

    planned = _plan(tracks, described, driver, results, quick, cache_dir, limits)
    covering = _covering_tasks(tracks, planned, quick)
    finished: dict[int, dict[str, Any]] = {}
    todo = []
    other_size: dict[int, dict[str, Any]] = {}
    for i, p in enumerate(planned):
        record, why = read_finished(p.path, p.identity) if resume else (None, "")
        same = None
        if record is None and resume:
            method = described[p.pair[1]]
            same = _same_task_other_size(tracks[p.pair[0]], method, driver, results, quick, p)
        if record is not None:
            finished[i] = record
        elif same is not None:
            other_size[i] = same
        elif i not in covering:
            todo.append(i)
            if why:
                say(f"{p.what}: computed again ({why})")
    joined = _scored_together(tracks, planned, quick, todo)
    covering.update({k: by for k, (by, _) in joined.items()})
    todo = [i for i in todo if i not in joined]
    if finished:
        say(
            f"{len(finished)} of {len(planned)} task(s) finished before (files under "
            f"{results / TASKS_FOLDER}); {len(todo)} to run"
        )
        other = [
            planned[i].what
            for i, r in finished.items()
            if r["provenance"].get("code_sha256") not in (None, code)
        ]
        if other:  # kept, as any finished task is; said, so that --rerun is a choice
            say(
                f"{len(other)} of them ran on other sfa_gym sources than these (e.g. "
                f"{other[0]}; provenance.code_sha256 of the task files); --rerun computes "
                "every task again"
            )
    pairs: dict[tuple[int, int], list[int]] = {}
    for i, p in enumerate(planned):
        pairs.setdefault(p.pair, []).append(i)

    written: dict[tuple[int, int], Path] = {}

    def write_pair(pair: tuple[int, int]) -> None:
        records = [finished[i] for i in pairs[pair]]
        track, method = tracks[pair[0]], described[pair[1]]
        written[pair] = _write_pair(results, track, method, quick, records)

    failures: dict[int, tuple[str, TaskFailure]] = {}
    commit = git_commit()

    def record(i: int, outcome: dict[str, Any] | TaskFailure, provenance: dict[str, Any]) -> None:
        """Write task ``i``'s file, then those of the tasks it covers and its pair's result."""
        p = planned[i]
        if isinstance(outcome, TaskFailure):
            write_task_file(p.path, p.identity, None, outcome.describe(), provenance)
            failures[i] = (p.what, outcome)
            say(f"{p.what}: FAILED, {outcome}")
        else:
            finished[i] = write_task_file(p.path, p.identity, outcome, None, provenance)
            say(f"{p.what}: score {outcome['scores']['score']:.3f} ({outcome['seconds']:.1f} s)")
            if all(k in finished for k in pairs[p.pair]):
                write_pair(p.pair)
        for k in (k for k, by in covering.items() if by == i and k not in finished):
            shared = joined[k][1] if k in joined else None
            derived = _covered_outcome(tracks, planned, quick, k, i, outcome, shared)
            record(k, derived, {**provenance, "scored_with": p.what})

    other = "full" if quick else "quick"
    if other_size:
        say(f"{len(other_size)} task(s) taken from the {other} size's task files (the same tasks)")
    for i, same in other_size.items():  # the same task, finished by a sweep at the other size
        provenance = {**same["provenance"], "same_task_as": f"{planned[i].what}, {other} size"}
        record(i, same["output"], provenance)
    for i, by in covering.items():  # covered by a task finished in an earlier sitting
        if i not in finished and by in finished:
            derived = _covered_outcome(tracks, planned, quick, i, by, finished[by]["output"])
            provenance = {**finished[by]["provenance"], "scored_with": planned[by].what}
            record(i, derived, provenance)
    for pair, members in pairs.items():
        if all(i in finished for i in members):
            write_pair(pair)
    also = {i: [] for i in todo}
    for by, evaluation in joined.values():
        also[by].append(evaluation)
    tasks = [replace(planned[i].task, also_score=tuple(also[i])) for i in todo]
    try:
        for j, outcome in run_each(tasks, backend, address=address, num_cpus=num_cpus):
            record(todo[j], outcome, task_provenance(backend, commit, code))
    except KeyboardInterrupt:
        say(
            f"interrupted: {len(finished)} of {len(planned)} task(s) finished and kept under "
            f"{results / TASKS_FOLDER}; the same command resumes from them"
        )
        raise
    ordered = [written[pair] for pair in sorted(written)]
    if failures:
        raise SweepError([failures[i] for i in sorted(failures)], ordered)  # in the sweep's order
    return ordered


def _same_task_other_size(
    track: Track,
    method: dict[str, Any],
    driver: dict[str, Any] | None,
    results: Path,
    quick: bool,
    planned: _Planned,
) -> dict[str, Any] | None:
    """The record of ``planned``'s task finished by a sweep at the other size, when that is the
    same task: the track's parameters are the same at both sizes (its quick size scores fewer
    world seeds and changes nothing else), both sizes score this world seed, and the other
    task's identity is current (the same track version, plug-in files and arguments)."""
    seed = planned.task.world_seed
    other = not quick
    if track.sized(other)[1] != track.sized(quick)[1] or seed not in track.sized(other)[0]:
        return None
    path = task_file(results, track.name, method["label"], other, seed)
    record, _ = read_finished(path, task_identity(track, other, seed, method, driver))
    return record


def _covering_tasks(
    tracks: Sequence[Track], planned: list[_Planned], quick: bool
) -> dict[int, int]:
    """The planned tasks whose scores are a part of another planned task's, each with the task
    that gives them: the same method and world seed on a track whose protocol ``covers`` this
    track's settings (:func:`sfa_gym.protocols.outdoor.covers`: the paper's outdoor track is
    a part of the appearance track). Of two tracks with the same settings, the first runs."""
    configs = [t.config(quick) if t.evaluation in PROTOCOLS else None for t in tracks]
    by_run: dict[tuple[int, int], list[int]] = {}
    for i, p in enumerate(planned):
        by_run.setdefault((p.pair[1], p.task.world_seed), []).append(i)
    covering: dict[int, int] = {}
    for members in by_run.values():
        for i in members:
            ti = planned[i].pair[0]
            covers = getattr(protocol_module(tracks[ti].evaluation), "covers", None)
            if covers is None or configs[ti] is None:
                continue
            for j in members:
                tj = planned[j].pair[0]
                if j == i or tracks[tj].evaluation != tracks[ti].evaluation:
                    continue
                if covers(configs[tj], configs[ti]) and (
                    j < i or not covers(configs[ti], configs[tj])
                ):
                    covering[i] = j
                    break
    for i in covering:  # the task that runs, when the covering one is covered in turn
        while covering[i] in covering:
            covering[i] = covering[covering[i]]
    return covering


def _scored_together(
    tracks: Sequence[Track], planned: list[_Planned], quick: bool, todo: list[int]
) -> dict[int, tuple[int, str]]:
    """Tasks to be scored within another task still to run, each with that task and the
    evaluation it adds there: the same method, world seed and world fitted on, on tracks whose
    protocol scores both settings in one run (``scored_together``, :mod:`sfa_gym.protocols.
    grid`: the paper's splits, training -> test and few labels fit a method once). Finished
    tasks are left as they are: a task that ran alone in an earlier sitting is not joined."""
    runners: dict[tuple[Any, ...], list[int]] = {}
    joined: dict[int, tuple[int, str]] = {}
    for i in todo:
        track = tracks[planned[i].pair[0]]
        if track.evaluation not in PROTOCOLS:
            continue
        together = getattr(protocol_module(track.evaluation), "scored_together", None)
        if together is None:
            continue
        seed = planned[i].task.world_seed
        key = (planned[i].pair[1], seed, track.fit_world_seed(seed), PROTOCOLS[track.evaluation])
        config = track.config(quick)
        for by in runners.setdefault(key, []):
            runner = tracks[planned[by].pair[0]].config(quick)
            evaluations = {*runner.evaluations, *(e for b, e in joined.values() if b == by)}
            if together(runner, config) and config.evaluations[0] not in evaluations:
                joined[i] = (by, config.evaluations[0])
                break
        else:
            runners[key].append(i)
    return joined


def _covered_outcome(
    tracks: Sequence[Track],
    planned: list[_Planned],
    quick: bool,
    i: int,
    by: int,
    outcome: dict[str, Any] | TaskFailure,
    shared: str | None = None,
) -> dict[str, Any] | TaskFailure:
    """Task ``i``'s outcome from that of the task ``by`` that covers it: its part of the scores
    (its evaluation ``shared`` of the outcome's ``shared`` scores, for a task scored together
    with ``by``), or a failure naming the failed task; it costs no time of its own."""
    if isinstance(outcome, TaskFailure):
        return TaskFailure(outcome.error_type, f"scored with {planned[by].what}: {outcome}")
    own = {k: v for k, v in outcome.items() if k != "shared"}
    if shared is not None:
        return {**own, "scores": outcome["shared"][shared], "seconds": 0.0, "phases": {}}
    track = tracks[planned[i].pair[0]]
    module = protocol_module(track.evaluation)
    scores = module.covered_scores(outcome["scores"], track.config(quick), outcome["world_seed"])
    return {**own, "scores": significant(scores), "seconds": 0.0, "phases": {}}


def concurrent_tasks(backend: Backend, address: str | None, num_cpus: int | None) -> int | None:
    """How many tasks of a sweep may run at once on one machine: 1 locally, one per CPU on
    Ray (``num_cpus`` of a local Ray; on a cluster, None: each node's own CPU count)."""
    if backend == "local":
        return 1
    if address is not None:
        return None
    return num_cpus or os.cpu_count() or 1


def _plan(
    tracks: Sequence[Track],
    described: list[dict[str, Any]],
    driver: dict[str, Any] | None,
    results: Path,
    quick: bool,
    cache_dir: str | os.PathLike[str] | None,
    limits: dict[str, Any],
) -> list[_Planned]:
    """The sweep's tasks, track by track, method by method, world seed by world seed;
    ``limits`` are the :class:`~sfa_gym.leaderboard.evaluate.Task` fields every task shares
    (the run's limits, the sources' hash)."""
    cache = None if cache_dir is None else str(Path(cache_dir).resolve())
    planned = []
    for t, track in enumerate(tracks):
        assert track.path is not None
        seeds, _ = track.sized(quick)
        for m, method in enumerate(described):
            for seed in seeds:
                task = Task(
                    str(track.path.resolve()),
                    method["path"],
                    dict(method["args"]),
                    seed,
                    quick,
                    cache,
                    None if driver is None else driver["path"],
                    {} if driver is None else dict(driver["args"]),
                    **limits,
                )
                planned.append(
                    _Planned(
                        task,
                        task_identity(track, quick, seed, method, driver),
                        task_file(results, track.name, method["label"], quick, seed),
                        (t, m),
                        f"{track.name} / {method['label']} / world seed {seed}",
                    )
                )
    return planned


def _write_pair(
    results: Path,
    track: Track,
    method: dict[str, Any],
    quick: bool,
    records: list[dict[str, Any]],
) -> Path:
    """Write the result file of one track and method from its tasks' records; a file that
    already says the same is left untouched."""
    result = make_result(
        track=track,
        quick=quick,
        method=method,
        tasks=[r["output"] for r in records],
        higher_is_better=HIGHER_IS_BETTER[track.kind],
        backend="+".join(sorted({r["provenance"]["backend"] for r in records})),
        # the result of its tasks, not of this sitting: dated by its last task, so that a rerun
        # that reuses every task gives the same file
        created=max(r["provenance"]["created"] for r in records),
    )
    path = result_path(results, track.name, method["label"], quick)
    try:
        unchanged = json.loads(path.read_text())["results"] == [result]
    except (OSError, ValueError, KeyError, TypeError):
        unchanged = False
    if not unchanged:
        write_results(path, [result])
    return path


def _printer(verbose: bool) -> Any:
    def say(line: str) -> None:
        if verbose:
            print(line, file=sys.stderr, flush=True)

    return say


def _check_labels(described: list[dict[str, Any]]) -> None:
    """Refuse two methods with one label: they would write the same files."""
    paths: dict[str, list[str]] = {}
    for method in described:
        paths.setdefault(method["label"], []).append(method["path"])
    for label, same in paths.items():
        if len(same) > 1:
            raise ValueError(
                f"{len(same)} methods of the sweep are labelled {label!r} ({', '.join(same)}); "
                "their results would overwrite each other: rename one or give other arguments"
            )


def _describe_controller(
    tracks: Sequence[Track],
    path: str | os.PathLike[str],
    args: Mapping[str, Any],
    hidden: list[Path],
) -> dict[str, Any]:
    """The provenance of a controller plug-in (checked, with its arguments), for the results."""
    others = [t.name for t in tracks if t.kind != "navigation"]
    if others:
        raise ValueError(
            f"a controller drives the rover on navigation tracks only; {others} are not "
            "navigation tracks (choose the nav_* tracks)"
        )
    return _describe("controller", path, args, hidden)


def _describe(
    kind: Kind, source: str | os.PathLike[str], args: Mapping[str, Any], hidden: list[Path]
) -> dict[str, Any]:
    """What a result records of a plug-in (a method or a controller): its name, label, file,
    SHA-256, the arguments given and all of them (the defaults filled in), read by
    :func:`~sfa_gym.plugins.describe` (a worker for a file from outside: the evaluator does not
    import it). A refused argument raises here, before any task."""
    report = describe(source, kind, args, limit=Limits().load, hidden=hidden)
    return {
        "name": report["name"],
        "label": method_label(report["name"], report["arguments"], report["defaults"]),
        "path": report["path"],
        "sha256": file_sha256(report["path"]),
        "args": {k: args[k] for k in args},
        "all_args": report["arguments"],
    }
