"""The navigation evaluation of a leaderboard task: the slow-feature-gradient controller on a
method's features (the protocol of :mod:`sfa_gym.experiments.navigation`, for one method).

The method is fitted without labels on a grid of the arena visited in Hilbert-curve order,
skipping the cells where the rover does not fit (obstacles, maze walls); each feature is
weighted by its slowness along that sequence; a feature field of the rotation-averaged features
replaces rendering, and the gradient controller runs the track's fixed episodes. Score: the
success rate over all episodes (higher is better), with SPL beside it.

Both the training grid and the field's nodes are rendered through the shared render cache
(:class:`~sfa_gym.recording.poses.FreeGridPositions`,
:class:`~sfa_gym.recording.poses.FieldNodes`): the panoramas do not depend on the method, so
every method scored on a world reuses them and only computes its own features.
"""

from __future__ import annotations

import dataclasses
import datetime
from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import NDArray

from sfa_gym.recording.cache import RunCache, RunRequest
from sfa_gym.recording.poses import FieldNodes, FreeGridPositions, field_axes

__all__ = ["cached_feature_field", "navigation_scores"]

FIELD_BATCH = 256
"""Panoramas transformed at a time while filling a field (bounds the memory)."""


def _field_features(model: Any, panoramas: Any, rows: NDArray[np.intp]) -> NDArray[np.float64]:
    """Rotation-averaged features (every column) of ``panoramas[rows]``: ``(len(rows), k)``,
    read and transformed ``FIELD_BATCH`` panoramas at a time."""
    from sfa_gym.features import rotation_averaged_features

    parts = [
        rotation_averaged_features(model, np.asarray(panoramas[rows[s : s + FIELD_BATCH]]), step=1)
        for s in range(0, len(rows), FIELD_BATCH)
    ]
    features = np.concatenate(parts)
    if not np.all(np.isfinite(features)):
        raise ValueError(f"model {type(model).__name__} returned non-finite features")
    return features


def cached_feature_field(
    nav: Any,
    model: Any,
    spacing: float,
    cache: RunCache,
    *,
    panorama: tuple[int, int],
    seed: int,
    model_info: Any = None,
) -> Any:
    """The :class:`~sfa_gym.navigation.field.FeatureField` of ``model`` in the world of
    ``nav`` (an unwrapped navigation env) at ``spacing`` m, with the nodes' panoramas from
    ``cache``.

    The same field as ``FeatureField.build(camera, model, spacing, free=nav.occupancy.is_free)``
    (same grid, yaw 0, features averaged over every column, non-free nodes filled from the
    nearest free node, the same metadata keys), except that a node the occupancy grid calls
    free but where the rover does not fit (a rounding of the grid's cells) counts as not free
    instead of stopping the build.

    Args:
        panorama: ``(height, width)`` pixels of ``nav``'s camera.
        seed: the reset seed of the cached run (part of its key).
        model_info: JSON-serialisable description of the model, stored in the metadata.

    Raises:
        RuntimeError: the cached run does not hold the nodes the world says it should.
    """
    from scipy.ndimage import distance_transform_edt

    import sfa_gym
    from sfa_gym.navigation.field import FeatureField, world_hash

    driver = FieldNodes(spacing)
    request = RunRequest(
        world=nav.world_spec.name,
        world_seed=nav.world_seed,
        panorama=panorama,
        driver=driver,
        seed=seed,
    )
    run = cache.get(request)
    nodes, fits = driver.nodes(nav)
    if len(run) != int(fits.sum()) or not np.allclose(run.positions, nodes[fits], atol=1e-6):
        raise RuntimeError(
            f"the cached run {cache.path(request)} holds {len(run)} panoramas, not the "
            f"{int(fits.sum())} nodes of a {spacing} m field in {nav.world_spec.name!r}, world "
            f"seed {nav.world_seed}"
        )
    free = fits & np.asarray(nav.occupancy.is_free(nodes), dtype=bool)
    rows = np.flatnonzero(free[fits])  # the free nodes' frames in the run
    if not len(rows):
        raise ValueError(f"no free field node at {spacing} m in {nav.world_spec.name!r}")
    values = _field_features(model, run.panoramas, rows)
    features = np.zeros((len(nodes), values.shape[1]))
    features[free] = values
    xs, ys = field_axes(nav.arena_bounds, spacing)
    grid = features.reshape(len(ys), len(xs), -1)
    free2 = free.reshape(len(ys), len(xs))
    if not free2.all():
        # as FeatureField.build: a non-free node takes the features of the nearest free node
        _, (iy, ix) = distance_transform_edt(
            ~free2, sampling=(ys[1] - ys[0], xs[1] - xs[0]), return_indices=True
        )
        grid = grid[iy, ix]
    height, width = panorama
    metadata = {
        "world": nav.world_spec.name,
        "world_hash": world_hash(nav.world_spec),
        "world_seed": nav.world_seed,
        "panorama": dataclasses.asdict(nav.panorama),
        "panorama_height": int(height),
        "panorama_width": int(width),
        "spacing": float(spacing),
        "node_spacing": [float(xs[1] - xs[0]), float(ys[1] - ys[0])],
        "step": 1,
        "heading": 0.0,
        "n_features": int(grid.shape[2]),
        "n_nodes": int(len(nodes)),
        "n_free": int(free.sum()),
        "model": type(model).__name__,
        "model_info": model_info,
        "render_cache_key": request.key(),
        "sfa_gym_version": sfa_gym.__version__,
        "created": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
    }
    return FeatureField(grid, nav.arena_bounds, free=free2, metadata=metadata)


def navigation_scores(
    track: Any,
    params: Mapping[str, Any],
    world_seed: int,
    method: Any,
    cache: RunCache,
    controller: tuple[str | None, Mapping[str, Any]] = (None, {}),
) -> dict[str, Any]:
    """Success rate and SPL of a controller on ``method``'s features in the track's world
    ``world_seed`` over episodes ``episode_seed .. episode_seed + episodes - 1``.

    ``controller``: a controller plug-in file and its arguments
    (:mod:`sfa_gym.plugins`), or ``(None, {})`` for the track's gradient controller
    (``params.controller``). Either sees only the rover's own sensors in ``info``."""
    import gymnasium as gym

    from sfa_gym.features import rotation_averaged_features
    from sfa_gym.navigation.controllers import (
        GradientController,
        GradientSettings,
        slowness_weights,
    )
    from sfa_gym.navigation.evaluate import run_episodes, summarize
    from sfa_gym.navigation.sensors import Rover, SensorsOnly
    from sfa_gym.plugins import load_controller_plugin
    from sfa_gym.protocols.features import fit_method
    from sfa_gym.rotation import Rotation

    panorama = (int(params["panorama"][0]), int(params["panorama"][1]))
    nav = gym.make(params["env_id"], world_seed=world_seed).unwrapped
    try:
        if nav.world_spec.name != track.world:
            raise ValueError(
                f"track {track.name!r}: world {track.world!r} differs from the world of "
                f"{params['env_id']} ({nav.world_spec.name!r})"
            )
        if (nav.panorama.height, nav.panorama.width) != panorama:
            raise ValueError(
                f"track {track.name!r}: params.panorama {list(panorama)} differs from the "
                f"panorama of {params['env_id']} ({nav.panorama.height} x {nav.panorama.width})"
            )
        request = RunRequest(
            world=track.world,
            world_seed=world_seed,
            panorama=panorama,
            driver=FreeGridPositions(n=params["train_grid"], seed=track.seed, order="hilbert"),
            seed=track.seed,
        )
        run = cache.get(request)
        free = nav.occupancy.is_free(run.positions)
        train = np.asarray(run.panoramas)[free]
        fitted = fit_method(method, train, Rotation())
        weights = slowness_weights(
            rotation_averaged_features(fitted, train, step=1), params["weight_power"]
        )
        field = cached_feature_field(
            nav,
            fitted,
            params["field_spacing"],
            cache,
            panorama=panorama,
            seed=track.seed,
            model_info={"method": method.name, "cost_weights": weights.tolist()},
        )
    finally:
        nav.close()
    env = gym.make(params["env_id"], world_seed=world_seed, feature_field=field)
    try:
        path, args = controller
        if path is None:
            settings = GradientSettings(**params["controller"])
            driver = SensorsOnly(GradientController.for_env(env, weights, settings=settings))
        else:
            driver = load_controller_plugin(path)(Rover.of(env), weights, args)
        first = params["episode_seed"]
        seeds = range(first, first + params["episodes"])
        summary = summarize(run_episodes(env, driver, seeds, progress=False))
    finally:
        env.close()
    every, interior = summary["all"], summary["interior"]
    return {
        "score": every["success"]["mean"],
        "spl": every["spl"]["mean"],
        "episodes": every["episodes"],
        "interior": {
            "episodes": interior["episodes"],
            # None without an interior episode among them (a small quick size)
            "success": interior["success"]["mean"],
            "spl": interior["spl"]["mean"],
        },
        "training_positions": int(len(train)),
        "field_nodes": {"nodes": field.metadata["n_nodes"], "free": field.metadata["n_free"]},
    }
