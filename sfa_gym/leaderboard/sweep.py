"""The sweep: every (track, method, world seed) as a task, then one result file per (track,
method); what ``sfa-gym leaderboard run`` does."""

from __future__ import annotations

import dataclasses
import os
import sys
import time
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from sfa_gym.leaderboard.backends import Backend, run_tasks
from sfa_gym.leaderboard.evaluate import HIGHER_IS_BETTER, Task
from sfa_gym.leaderboard.results import make_result, method_label, result_path, write_result
from sfa_gym.leaderboard.tracks import Track
from sfa_gym.plugins import file_sha256, load_controller_plugin, load_method_plugin

__all__ = ["run_sweep"]


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
    verbose: bool = True,
) -> list[Path]:
    """Score every method on every track; write one result file per (track, method).

    Args:
        tracks: loaded tracks (each must come from a file: tasks carry its path).
        methods: plug-in files with their arguments (``{}``: the defaults).
        results_dir: the results folder (``<track>/<method label>[.quick].json`` inside).
        quick: the tracks' quick size.
        backend: ``"local"`` or ``"ray"``; it, ``address`` and ``num_cpus``: see
            :func:`~sfa_gym.leaderboard.backends.run_tasks`.
        cache_dir: the render cache (None: the default one); must be reachable by every worker.
        controller: a controller plug-in file with its arguments, driving the rover on the
            navigation tracks instead of the tracks' gradient controller; every track must then
            be a navigation track. Results are labelled ``<method>+<controller>``.
        verbose: a line on stderr per finished task.

    Returns:
        The result files written, in the order of ``tracks`` x ``methods``.

    Raises:
        PluginError, ValueError: a method or controller file or its arguments are refused, or
            a controller is given for a track that is not a navigation track (before any task).
    """
    started = time.perf_counter()
    driver = None if controller is None else _describe_controller(tracks, *controller)
    described = []
    for path, args in methods:
        factory = load_method_plugin(path)
        method = _describe(factory, args, factory.arguments(args))
        if driver is not None:
            method |= {"label": f"{method['label']}+{driver['label']}", "controller": driver}
        described.append(method)
    cache = None if cache_dir is None else str(Path(cache_dir).resolve())
    tasks, owners = [], []
    for t, track in enumerate(tracks):
        if track.path is None:
            raise ValueError(f"track {track.name!r} was not loaded from a file")
        seeds, _ = track.sized(quick)
        for m, method in enumerate(described):
            for seed in seeds:
                tasks.append(
                    Task(
                        str(track.path.resolve()),
                        method["path"],
                        dict(method["args"]),
                        seed,
                        quick,
                        cache,
                        None if driver is None else driver["path"],
                        {} if driver is None else dict(driver["args"]),
                    )
                )
                owners.append((t, m))

    def report(task: Task, output: dict[str, Any]) -> None:
        if verbose:
            print(
                f"{Path(task.track_path).stem} / {Path(task.method_path).stem} / world seed "
                f"{task.world_seed}: score {output['scores']['score']:.3f} "
                f"({output['seconds']:.1f} s)",
                file=sys.stderr,
            )

    outputs = run_tasks(tasks, backend, address=address, num_cpus=num_cpus, on_done=report)
    seconds = time.perf_counter() - started
    written = []
    for t, track in enumerate(tracks):
        for m, method in enumerate(described):
            mine = [o for o, owner in zip(outputs, owners, strict=True) if owner == (t, m)]
            result = make_result(
                track=track,
                quick=quick,
                method=method,
                tasks=mine,
                higher_is_better=HIGHER_IS_BETTER[track.kind],
                backend=backend,
                seconds=seconds,
            )
            path = result_path(Path(results_dir), track.name, method["label"], quick)
            write_result(path, result)
            written.append(path)
    return written


def _describe_controller(
    tracks: Sequence[Track], path: str | os.PathLike[str], args: Mapping[str, Any]
) -> dict[str, Any]:
    """The provenance of a controller plug-in (checked, with its arguments), for the results."""
    others = [t.name for t in tracks if t.kind != "navigation"]
    if others:
        raise ValueError(
            f"a controller drives the rover on navigation tracks only; {others} are not "
            "navigation tracks (choose the nav_* tracks)"
        )
    factory = load_controller_plugin(path)
    return _describe(factory, args, factory.arguments(args))


def _describe(factory: Any, args: Mapping[str, Any], filled: dict[str, Any]) -> dict[str, Any]:
    """What a result records of a plug-in (a method or a controller): its name, label, file,
    SHA-256, the arguments given and all of them (``filled``, the defaults filled in)."""
    defaults = {f.name: f.default for f in dataclasses.fields(factory.args_type)}
    return {
        "name": factory.name,
        "label": method_label(factory.name, filled, defaults),
        "path": str(factory.path),
        "sha256": file_sha256(factory.path),
        "args": {k: args[k] for k in args},
        "all_args": filled,
    }
