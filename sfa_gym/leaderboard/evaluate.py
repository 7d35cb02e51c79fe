"""One leaderboard task: a method scored on one world seed of one track.

A :class:`Task` holds only plain values (paths, a dict of arguments, ints), so that it travels to
another process or machine unchanged; :func:`run_task` loads the track and the method there and
returns the task's scores as JSON types. The evaluations reuse the protocols' code paths
(:mod:`sfa_gym.experiments`): the same position selection, the same fitting of a method on all
rotated views of the training panoramas in visiting order, the same regressions and MAE; the
outdoor and navigation tracks score with their protocols' ``score``
(:mod:`sfa_gym.protocols.outdoor`, :mod:`sfa_gym.protocols.navigation`). Rendered runs come
from the shared
:class:`~sfa_gym.recording.cache.RunCache`.

Every localization score is the mean of the x and y MAE in % of the test positions' coordinate
range (lower is better); the navigation score is the success rate (higher is better).
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray
from threadpoolctl import threadpool_limits

from sfa_gym.leaderboard.plugins import load_method
from sfa_gym.leaderboard.tracks import Track, load_track, protocol_config
from sfa_gym.recording.cache import RunCache, RunRequest

__all__ = ["HIGHER_IS_BETTER", "Task", "run_task"]

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
    """

    track_path: str
    method_path: str
    method_args: Mapping[str, Any] = field(default_factory=dict)
    world_seed: int = 0
    quick: bool = False
    cache_dir: str | None = None
    controller_path: str | None = None
    controller_args: Mapping[str, Any] = field(default_factory=dict)


def _mean_percent(result: Any) -> float:
    return float(np.mean(result.mae_percent))


def _regressor(method: Any) -> str:
    return str(getattr(method, "regressor", "linear"))


def _controller(path: str | None, args: Mapping[str, Any]) -> Any:
    """``controller(env, weights)`` of a controller plug-in file (it sees only the rover's own
    sensors), or None: the track's gradient controller."""
    if path is None:
        return None
    from sfa_gym.navigation.plugins import Rover, load_controller_file

    factory = load_controller_file(path)
    return lambda env, weights: factory(Rover.of(env), weights, args)


def _grid_run(
    track: Track, params: Mapping[str, Any], world_seed: int, cache: RunCache
) -> tuple[NDArray[np.uint8], NDArray[np.float64], NDArray[np.intp], NDArray[np.intp]]:
    """Panoramas ``(L, H, W, 3)`` and positions ``(L, 2)`` of the grid, with the training
    (visiting order) and test indices the grid protocol selects."""
    from sfa_gym.experiments.grid import GridExperiment, select_positions
    from sfa_gym.recording.drivers import GridPositions

    driver = GridPositions(n=params["grid"], seed=track.seed, order=params["order"])
    request = RunRequest(
        world=track.world,
        world_seed=world_seed,
        panorama=tuple(params["panorama"]),
        driver=driver,
        seed=track.seed,
    )
    run = cache.get(request)
    config = GridExperiment(
        world_seed=world_seed,
        grid=params["grid"],
        n_train=params["n_train"],
        n_test=params["n_test"],
        order=params["order"],
        step=params["step"],
        seed=track.seed,
    )
    train, test = select_positions(config, len(run))
    return np.asarray(run.panoramas), run.positions, train, test


def _grid_scores(
    track: Track, params: Mapping[str, Any], world_seed: int, method: Any, cache: RunCache
) -> dict[str, Any]:
    from sfa_gym.localization import fit_predict, mae, make_regressor, random_split_mae
    from sfa_gym.protocols.features import fit_method, view_features
    from sfa_gym.rotation import Rotation

    rotation = Rotation(step=params["step"])
    pan, xy, train, test = _grid_run(track, params, world_seed, cache)
    fit_seed = track.fit_world_seed(world_seed)
    if fit_seed == world_seed:
        fit_pan = pan[train]
    else:
        # unseen worlds: the method learns on another world's training positions
        other, _, other_train, _ = _grid_run(track, params, fit_seed, cache)
        fit_pan = other[other_train]
    fitted = fit_method(method, fit_pan, rotation)
    f_train = view_features(fitted, pan[train], rotation, progress=False)
    f_test = view_features(fitted, pan[test], rotation, progress=False)
    reg = _regressor(method)
    scores: dict[str, Any] = {"regressor": reg, "n_features": int(f_test.shape[2])}
    if track.evaluation == "paper_splits":
        splits = random_split_mae(
            f_test, xy[test], reg, n_splits=params["n_splits"], seed=track.seed
        )
        scores["score"] = _mean_percent(splits)
        scores["mae_percent"] = splits.mae_percent.tolist()
    elif track.evaluation == "few_labels":
        per_count = []
        for n_labels in params["labels"]:
            # each count draws its own labelled positions, the same for every method
            rng = np.random.default_rng([track.seed, world_seed, n_labels])
            chosen = np.sort(rng.choice(len(train), size=n_labels, replace=False))
            found = fit_predict(make_regressor(reg), f_train[chosen], xy[train][chosen], f_test)
            result = mae(found, xy[test])
            scores[f"labels_{n_labels}"] = _mean_percent(result)
            per_count.append(_mean_percent(result))
        scores["score"] = float(np.mean(per_count))
    else:  # train_test, unseen_worlds
        found = fit_predict(make_regressor(reg), f_train, xy[train], f_test)
        result = mae(found, xy[test])
        scores["score"] = _mean_percent(result)
        scores["mae_percent"] = result.mae_percent.tolist()
    return scores


def _region_scores(
    track: Track, params: Mapping[str, Any], world_seed: int, method: Any, cache: RunCache
) -> dict[str, Any]:
    from sfa_gym.experiments.trajectory import TrajectoryExperiment, trajectory_drivers
    from sfa_gym.geometry import in_rectangle
    from sfa_gym.localization import fit_predict, mae, make_regressor
    from sfa_gym.protocols.features import fit_method, view_features
    from sfa_gym.rotation import Rotation, spread_indices

    config = TrajectoryExperiment(
        world_seed=world_seed,
        panorama=tuple(params["panorama"]),
        spacing=params["spacing"],
        margin=params["margin"],
        exclude=tuple(params["exclude"]),
        test_insets=tuple(params["test_insets"]),
        frame_every=params["frame_every"],
        test_every=params["test_every"],
        step=params["step"],
        eval_rotations=params["eval_rotations"],
        train_steps=params["train_steps"],
        test_steps=params["test_steps"],
        seed=track.seed,
    )
    config.validate()
    runs = []
    for driver, n_steps in zip(
        trajectory_drivers(config), (config.train_steps, config.test_steps), strict=True
    ):
        request = RunRequest(
            world=track.world,
            world_seed=world_seed,
            panorama=config.panorama,
            driver=driver,
            n_steps=n_steps,
            seed=track.seed,
        )
        runs.append(cache.get(request))
    train_run, test_run = runs
    train_idx = np.arange(0, len(train_run), config.frame_every)
    test_idx = np.arange(0, len(test_run), config.test_every)
    train_pan = np.asarray(train_run.panoramas[train_idx])
    test_pan = np.asarray(test_run.panoramas[test_idx])
    train_xy, test_xy = train_run.positions[train_idx], test_run.positions[test_idx]
    rotation = Rotation(step=config.step)
    windows = spread_indices(rotation.n_views(train_pan.shape[2]), config.eval_rotations)
    fitted = fit_method(method, train_pan, rotation)
    f_train = view_features(fitted, train_pan, rotation, windows, progress=False)
    f_test = view_features(fitted, test_pan, rotation, windows, progress=False)
    reg = _regressor(method)
    found = fit_predict(make_regressor(reg), f_train, train_xy, f_test)
    test_range = test_xy.max(axis=0) - test_xy.min(axis=0)
    inside = in_rectangle(test_xy, config.exclude)
    region = mae(found[inside], test_xy[inside], coordinate_range=test_range)
    overall = mae(found, test_xy, coordinate_range=test_range)
    return {
        "regressor": reg,
        "n_features": int(f_test.shape[2]),
        "score": _mean_percent(region),
        "mae_percent": region.mae_percent.tolist(),
        "all_test_frames": _mean_percent(overall),
        "frames": {"train": len(train_idx), "test": len(test_idx), "in_region": int(inside.sum())},
    }


def run_task(task: Task) -> dict[str, Any]:
    """Evaluate ``task``; returns ``{"world_seed", "fit_world_seed", "scores", "seconds"}``.

    ``scores["score"]`` is the track's score (see the module docstring); the other entries are
    its parts. ``seconds`` is the wall time of the task (renders included when the cache had
    no entry yet).
    """
    started = time.perf_counter()
    track = load_track(task.track_path)
    seeds, params = track.sized(task.quick)
    if task.world_seed not in seeds:
        raise ValueError(
            f"world seed {task.world_seed} is not a scoring seed of track {track.name!r} "
            f"({'quick' if task.quick else 'full'} size: {list(seeds)})"
        )
    if task.controller_path is not None and track.evaluation != "navigation":
        raise ValueError(
            f"a controller drives the rover on navigation tracks only, not on {track.name!r}"
        )
    method = load_method(task.method_path, task.method_args)
    cache = RunCache(task.cache_dir)
    # One BLAS thread wherever the task runs: multi-threaded reductions round differently, and
    # a Ray worker starts single-threaded while a local process does not, so the same task
    # would otherwise differ in the last digits between backends.
    with threadpool_limits(limits=1):
        if track.evaluation == "unvisited_region":
            scores = _region_scores(track, params, task.world_seed, method, cache)
        elif track.evaluation == "outdoor":
            from sfa_gym.protocols import outdoor

            config = protocol_config("outdoor", params, track.seed)
            found = outdoor.score(config, method, task.world_seed, cache)
            scores = found.leaderboard(_regressor(method))
        elif track.evaluation == "navigation":
            from sfa_gym.protocols import navigation

            config = protocol_config("navigation", params, track.seed)
            controller = _controller(task.controller_path, task.controller_args)
            found = navigation.score(config, method, task.world_seed, cache, controller=controller)
            scores = found.leaderboard()
        else:
            scores = _grid_scores(track, params, task.world_seed, method, cache)
    return {
        "world_seed": task.world_seed,
        "fit_world_seed": track.fit_world_seed(task.world_seed),
        "scores": _significant(scores),
        "seconds": round(time.perf_counter() - started, 2),
    }


def _significant(value: Any, digits: int = 10) -> Any:
    """``value`` with every float rounded to ``digits`` significant digits. Float reductions
    can round differently in the last bits from one process to another (the alignment of the
    arrays decides where SIMD sums split), so scores agree between backends only to about 1e-14
    relative; ten digits are far more than a score means."""
    if isinstance(value, float):
        return float(f"{value:.{digits}g}")
    if isinstance(value, dict):
        return {k: _significant(v, digits) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_significant(v, digits) for v in value]
    return value
