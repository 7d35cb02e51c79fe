"""The outdoor tracks: the paper's outdoor protocol and the appearance tracks in the outdoor
world, one task per world seed, every run rendered through the shared render cache.

A task builds the :class:`~sfa_gym.experiments.outdoor.OutdoorExperiment` of the track's
``params`` (its sizes: panorama, frames, frame period, lane spacings, start hour, ...) and asks
the cache for its runs, each keyed by the env kwargs of
:meth:`~sfa_gym.experiments.outdoor.OutdoorExperiment.env_kwargs` and the driver of
:meth:`~sfa_gym.experiments.outdoor.OutdoorExperiment.driver`:

- the drive (``part="both"``): the training frames, then, without stopping the clock, the test
  frames of the ``after`` condition (the paper's protocol). It depends on the world seed and
  the drive's sizes only, so every outdoor track with the same sizes and seeds (the paper's
  track and the appearance track) and every method reuses the one render;
- one test run (``part="test"``) per other condition: ``later``, ``overcast``, ``no_movers``,
  ``other_day``.

The method is fitted on the training frames as the outdoor experiment fits a plug-in: with
``fit_rotations`` (hierarchical SFA) on every simulated rotation of every training frame in
time order, otherwise on the evaluated rotation windows of every ``fit_every``-th training
frame (all views of 5900 panoramas would not fit in memory). Its regression (the method's
``regressor``, default linear) is fitted on the ``eval_rotations`` windows of every training
frame, and the estimate of a test frame is the mean over its windows.

Scores (MAE in % of the ``after`` test run's coordinate range, mean of x and y): per scored
condition over all its test frames, in the unvisited south-west region and in the visited rest
(:func:`~sfa_gym.experiments.outdoor.condition_scores`). The task's ``score`` is the mean over the
track's ``conditions`` of the all-frames score; ``after`` is always scored (on the appearance
track as a reference, outside the headline score).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from sfa_gym.recording.cache import RunCache, RunRequest

__all__ = ["ENV_ID", "PARAMS", "outdoor_config", "outdoor_requests", "outdoor_scores"]

# as sfa_gym.experiments.outdoor.ENV_ID, which this module imports only when it runs a track
ENV_ID = "sfa_gym/OmniRoverOutdoor-v0"

# the drive's sizes: two tracks that agree on them (and on world and seeds) share its render
DRIVE_PARAMS = (
    "panorama",
    "train_frames",
    "test_frames",
    "frame_dt",
    "spacing",
    "test_spacing",
    "start_hour",
)
PARAMS = (*DRIVE_PARAMS, "later_hours", "conditions", "step", "eval_rotations", "fit_every")
"""The ``params`` of an outdoor track: fields of ``OutdoorExperiment`` of the same names."""


def outdoor_config(params: Mapping[str, Any], world_seed: int, seed: int) -> Any:
    """The checked :class:`~sfa_gym.experiments.outdoor.OutdoorExperiment` of an outdoor
    track's ``params`` on ``world_seed``; ``seed`` seeds the env resets and the path planner.
    ``after`` is always among its conditions (it is part of the drive).

    Raises:
        ValueError, TypeError: a bad parameter, named (``OutdoorExperiment.validate``), or
            ``conditions`` that is not a non-empty list without repeats.
    """
    from sfa_gym.experiments.outdoor import OutdoorExperiment

    conditions = params["conditions"]
    if not isinstance(conditions, list | tuple) or not conditions:
        raise ValueError(f"conditions must be a non-empty list, got {conditions!r}")
    if len(set(conditions)) != len(conditions):
        raise ValueError(f"conditions {list(conditions)} repeats a condition")
    panorama = params["panorama"]
    if not isinstance(panorama, list | tuple) or len(panorama) != 2:
        raise ValueError(f"panorama must be [height, width] in pixels, got {panorama!r}")
    config = OutdoorExperiment(
        world_seed=world_seed,
        panorama=(panorama[0], panorama[1]),
        train_frames=params["train_frames"],
        test_frames=params["test_frames"],
        frame_dt=params["frame_dt"],
        spacing=params["spacing"],
        test_spacing=params["test_spacing"],
        start_hour=params["start_hour"],
        conditions=tuple(dict.fromkeys(("after", *conditions))),
        later_hours=params["later_hours"],
        step=params["step"],
        eval_rotations=params["eval_rotations"],
        fit_every=params["fit_every"],
        seed=seed,
    )
    config.validate()
    return config


def _request(config: Any, world: str, part: str, condition: str) -> RunRequest:
    kwargs = config.env_kwargs(condition)
    # world seed and panorama are fields of the request (the cache passes them on)
    world_seed, panorama = kwargs.pop("world_seed"), kwargs.pop("panorama")
    return RunRequest(
        world=world,
        world_seed=world_seed,
        panorama=(panorama.height, panorama.width),
        driver=config.driver(part),
        seed=config.seed,
        env_id=ENV_ID,
        env_kwargs=kwargs,
    )


def outdoor_requests(track: Any, params: Mapping[str, Any], world_seed: int) -> dict[str, Any]:
    """The runs of one task: ``{"drive": request, <condition>: request, ...}`` for every
    condition except ``after`` (the drive's second part).

    Raises:
        ValueError: the track's world is not the outdoor env's.
    """
    import gymnasium as gym

    world = gym.spec(ENV_ID).kwargs["world"]
    if track.world != world:
        raise ValueError(
            f"track {track.name!r}: world {track.world!r} is not the world of {ENV_ID} "
            f"({world!r}); the outdoor evaluation renders in that env"
        )
    config = outdoor_config(params, world_seed, track.seed)
    requests = {"drive": _request(config, track.world, "both", "after")}
    for condition in config.conditions:
        if condition != "after":
            requests[condition] = _request(config, track.world, "test", condition)
    return requests


def _fit(method: Any, train_pan: np.ndarray, config: Any, windows: np.ndarray) -> Any:
    """``method`` fitted on the training frames as the outdoor experiment fits it (see the
    module docstring)."""
    from sfa_gym.capabilities import get_capabilities
    from sfa_gym.protocols.features import fit_method

    rotation = config.rotation
    if get_capabilities(method).fit_rotations:
        return fit_method(method, train_pan, rotation)
    frames = np.arange(0, len(train_pan), config.fit_every)
    views = rotation.views(train_pan[frames], windows)[0]
    return method.fit(views.reshape(-1, *views.shape[2:]))


def _percent(entry: Mapping[str, Any] | None) -> float | None:
    return None if entry is None else float(np.mean(entry["mae_percent"]))


def outdoor_scores(
    track: Any, params: Mapping[str, Any], world_seed: int, method: Any, cache: RunCache
) -> dict[str, Any]:
    """Scores of ``method`` on one world seed of an outdoor track (see the module docstring).

    Returns:
        ``score`` (mean over the track's conditions of the all-frames MAE %), ``parts`` (per
        scored condition its all-frames MAE % and ``unvisited``: the ``after`` run's MAE %
        inside the south-west region), ``conditions`` (per condition ``all``, ``unvisited``,
        ``visited``: MAE in m and % per axis, as the outdoor experiment reports them),
        ``regressor``, ``n_features``, ``frames`` and the cache keys of the runs.
    """
    from sfa_gym.capabilities import get_capabilities
    from sfa_gym.experiments.outdoor import condition_scores, test_sets
    from sfa_gym.localization import make_regressor, predict_locations
    from sfa_gym.protocols.features import view_features
    from sfa_gym.recording.outdoor_path import south_west
    from sfa_gym.rotation import spread_indices

    config = outdoor_config(params, world_seed, track.seed)
    requests = outdoor_requests(track, params, world_seed)
    drive = cache.get(requests["drive"])
    runs: dict[str, Any] = {"after": None}
    runs.update({c: cache.get(r) for c, r in requests.items() if c != "drive"})
    region = south_west(drive.metadata["arena_bounds"])
    tests = test_sets(config, drive, runs, region)
    n = config.train_frames
    train_pan = np.asarray(drive.panoramas[:n])
    train_xy = np.asarray(drive.positions[:n], dtype=np.float64)
    after = tests["after"]
    test_range = after.xy.max(axis=0) - after.xy.min(axis=0)
    rotation = config.rotation
    windows = spread_indices(rotation.n_views(train_pan.shape[2]), config.eval_rotations)

    fitted = _fit(method, train_pan, config, windows)
    f_train = view_features(fitted, train_pan, rotation, windows, progress=False)
    reg = get_capabilities(method).regressor
    regressor = make_regressor(reg)
    n_views = f_train.shape[1]
    # every window of a training frame is a sample labelled with the frame's position
    regressor.fit(f_train.reshape(-1, f_train.shape[2]), np.repeat(train_xy, n_views, 0))
    conditions: dict[str, Any] = {}
    for condition, test in tests.items():
        f_test = view_features(fitted, test.panoramas, rotation, windows, progress=False)
        conditions[condition] = condition_scores(
            predict_locations(regressor, f_test), test, test_range
        )
    parts: dict[str, float | None] = {c: _percent(e["all"]) for c, e in conditions.items()}
    parts["unvisited"] = _percent(conditions["after"]["unvisited"])
    headline = [parts[c] for c in params["conditions"]]
    return {
        "score": float(np.mean(headline)),
        "parts": parts,
        "conditions": conditions,
        "regressor": reg,
        "n_features": int(f_train.shape[2]),
        "frames": {
            "train": n,
            "test": config.test_frames,
            "unvisited": int(after.inside.sum()),
            "windows": int(n_views),
        },
        "renders": {name: request.key() for name, request in requests.items()},
    }
