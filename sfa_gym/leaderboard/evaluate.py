"""One leaderboard task: a method scored on one world seed of one track.

A :class:`Task` holds only plain values (paths, a dict of arguments, ints), so that it travels to
another process or machine unchanged; :func:`run_task` loads the track and the method there and
returns the task's scores as JSON types. Every evaluation is scored by its protocol's ``score``
(:mod:`sfa_gym.protocols`: grid, trajectory, outdoor, navigation), the code behind the command
line's results, with the track's ``Config``. Rendered runs come from the shared
:class:`~sfa_gym.recording.cache.RunCache`.

Every localization score is the mean of the x and y MAE in % of the test positions' coordinate
range (lower is better); the navigation score is the success rate (higher is better).
"""

from __future__ import annotations

import os
import time
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from typing import Any

from threadpoolctl import threadpool_limits

from sfa_gym.leaderboard.tracks import Track, load_track, protocol_module
from sfa_gym.memory import own_peak_mb, reset_own_peak
from sfa_gym.phases import measure
from sfa_gym.plugins import load_method
from sfa_gym.recording.cache import RunCache
from sfa_gym.sandbox import IN_PROCESS, Limits, isolation, plugins_isolated
from sfa_gym.source_hash import check_sources

__all__ = [
    "HIGHER_IS_BETTER",
    "IN_PROCESS",
    "Task",
    "isolation",
    "plugins_isolated",
    "run_task",
    "significant",
    "task_limits",
]

HIGHER_IS_BETTER = {"localization": False, "navigation": True}
"""Direction of the ``score`` of each track kind."""


@dataclass(frozen=True)
class Task:
    """One (track, method, world seed) evaluation, in plain values.

    Attributes:
        track_path: the track file.
        method_path: the method's plug-in file.
        method_args: keyword arguments of the method's ``Args`` (JSON types).
        world_seed: the scoring world seed (one of the track's).
        quick: evaluate at the track's quick size.
        cache_dir: the render cache folder (None: the default one).
        controller_path: navigation tracks: a controller plug-in file that drives the rover
            instead of the track's gradient controller (None: the track's).
        controller_args: keyword arguments of the controller's ``Args`` (JSON types).
        time_limits: seconds per kind of call into the plug-ins (``{"fit": 3600}``), over
            the track's ``time_limits``, over the defaults of :class:`~sfa_gym.sandbox.Limits`.
        memory_limit_mb: the memory limit of each plug-in's worker, MiB (None: the track's
            ``memory_limit_mb``, else the default of :class:`~sfa_gym.sandbox.Limits` shared by
            ``concurrent_tasks``).
        concurrent_tasks: how many tasks may run at the same time on the machine this one runs
            on (None: its number of CPUs, as Ray runs one task per CPU): the default memory
            limit is three quarters of the machine's memory divided among them, so that
            runaway plug-ins of all of them together cannot exhaust it.
        also_score: grid tracks: evaluations scored in the same run besides the track's own
            (other tracks' tasks, :func:`~sfa_gym.protocols.grid.scored_together`); their task
            scores go to the outcome's ``shared``, the track's own scores are unchanged.
        code_sha256: the hash of the ``sfa_gym`` sources the sweep started with
            (:func:`~sfa_gym.source_hash.package_sources_sha256`); the task fails when the
            sources it finds at its start or end differ (None: no check).
    """

    track_path: str
    method_path: str
    method_args: Mapping[str, Any] = field(default_factory=dict)
    world_seed: int = 0
    quick: bool = False
    cache_dir: str | None = None
    controller_path: str | None = None
    controller_args: Mapping[str, Any] = field(default_factory=dict)
    time_limits: Mapping[str, float] = field(default_factory=dict)
    memory_limit_mb: int | None = None
    concurrent_tasks: int | None = 1
    also_score: tuple[str, ...] = ()
    code_sha256: str | None = None


def task_limits(track: Track, task: Task) -> Limits:
    """The limits of the task's plug-ins: the task's own over the track's over the defaults."""
    memory_mb = task.memory_limit_mb
    if memory_mb is None:
        memory_mb = track.memory_limit_mb
    sharing = task.concurrent_tasks or os.cpu_count() or 1
    return Limits.of({**track.time_limits, **task.time_limits}, memory_mb, sharing)


def _protocol_scores(
    track: Track, task: Task, method: Any, cache: RunCache, controllers: list[Any], limits: Any
) -> tuple[dict[str, Any], dict[str, Any]]:
    """The task's scores from its protocol (:data:`~sfa_gym.leaderboard.tracks.PROTOCOLS`):
    ``score`` with the track's ``Config`` and the method's own regression; on
    ``unseen_worlds`` the world the method is fitted on, on navigation tracks the controller.
    Also the task scores of each of ``task.also_score``, scored in the same run."""
    protocol = protocol_module(track.evaluation)
    config = track.config(task.quick)
    if task.also_score:
        config = replace(config, evaluations=(*config.evaluations, *task.also_score))
    other: dict[str, Any] = {}
    if track.fit_world_seeds:
        other["fit_world_seed"] = track.fit_world_seed(task.world_seed)
    if track.evaluation == "navigation":
        other["controller"] = _controller(
            task.controller_path, task.controller_args, controllers, [cache.root], limits
        )
    found = protocol.score(config, method, task.world_seed, cache, **other)
    return found.task_scores(), {e: found.task_scores(e) for e in task.also_score}


def _controller(
    path: str | None, args: Mapping[str, Any], made: list[Any], hidden: list[Any], limits: Any
) -> Any:
    """``controller(env, weights)`` of a controller plug-in, or None: the track's gradient
    controller, loaded by :func:`~sfa_gym.plugins.load_controller` (it sees the features and
    the rover's own sensors, never the env); ``made`` collects them, to be closed."""
    if path is None:
        return None
    from sfa_gym.navigation.sensors import Rover
    from sfa_gym.plugins import load_controller

    def make(env: Any, weights: Any) -> Any:
        rover = Rover.of(env)
        made.append(load_controller(path, rover, weights, args, limits=limits, hidden=hidden))
        return made[-1]

    return make


def run_task(task: Task) -> dict[str, Any]:
    """Evaluate ``task``; returns ``{"world_seed", "fit_world_seed", "scores", "seconds",
    "phases", "peak_rss_mb"}``.

    ``scores["score"]`` is the track's score (see the module docstring); the other entries are
    its parts. ``seconds`` is the wall time of the task (renders included when the cache had
    no entry yet), ``phases`` its parts (:mod:`sfa_gym.phases`: render, fit, features, episodes,
    other; the plug-in's calls counted where the evaluator waits for them). ``peak_rss_mb``
    (:mod:`sfa_gym.memory`) holds the peak resident memory, MiB, of the evaluator during the
    task and the largest of its plug-in workers' (``plugins``: None when the plug-ins ran in the
    evaluator's process, whose peak then includes theirs).
    """
    with measure() as phases:
        out = _run_task(task)
    return {**out, "phases": phases.as_dict()}


def _run_task(task: Task) -> dict[str, Any]:
    started = time.perf_counter()
    reset_own_peak()  # a Ray worker runs many tasks: this one's peak only
    check_sources(task.code_sha256, "at the task's start")
    track = load_track(task.track_path)
    seeds, _ = track.sized(task.quick)
    if task.world_seed not in seeds:
        raise ValueError(
            f"world seed {task.world_seed} is not a scoring seed of track {track.name!r} "
            f"({'quick' if task.quick else 'full'} size: {list(seeds)})"
        )
    if task.controller_path is not None and track.evaluation != "navigation":
        raise ValueError(
            f"a controller drives the rover on navigation tracks only, not on {track.name!r}"
        )
    cache = RunCache(task.cache_dir)
    # A method from outside the package runs in a worker process of its own, which cannot read
    # the render cache (the recordings hold the poses); it computes with one BLAS thread too.
    limits = task_limits(track, task)
    method = load_method(task.method_path, task.method_args, limits=limits, hidden=[cache.root])
    workers: list[Any] = [method]
    try:
        # One BLAS thread wherever the task runs: multi-threaded reductions round differently,
        # and a Ray worker starts single-threaded while a local process does not, so the same
        # task would otherwise differ in the last digits between backends.
        with threadpool_limits(limits=1):
            scores, shared = _protocol_scores(track, task, method, cache, workers, limits)
    finally:
        for plugin in workers:
            plugin.close()
    peaks = [p.peak_rss_mb for p in workers if p.peak_rss_mb is not None]
    # a module imported during the task (most are imported lazily) came from these sources
    check_sources(task.code_sha256, "at the task's end")
    return {
        "world_seed": task.world_seed,
        "fit_world_seed": track.fit_world_seed(task.world_seed),
        "scores": significant(scores),
        "seconds": round(time.perf_counter() - started, 2),
        "isolation": isolation(task.method_path, task.controller_path),
        "peak_rss_mb": {"evaluator": own_peak_mb(), "plugins": max(peaks) if peaks else None},
    } | ({"shared": significant(shared)} if shared else {})


def significant(value: Any, digits: int = 10) -> Any:
    """``value`` with every float rounded to ``digits`` significant digits. Float reductions
    can round differently in the last bits from one process to another (the alignment of the
    arrays decides where SIMD sums split), so scores agree between backends only to about 1e-14
    relative; ten digits are far more than a score means."""
    if isinstance(value, float):
        return float(f"{value:.{digits}g}")
    if isinstance(value, dict):
        return {k: significant(v, digits) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [significant(v, digits) for v in value]
    return value
