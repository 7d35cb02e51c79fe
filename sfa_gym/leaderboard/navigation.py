"""The navigation evaluation of a leaderboard task: the slow-feature-gradient controller on a
method's features (the protocol of :mod:`sfa_gym.experiments.navigation`, for one method).

The method is fitted without labels on a grid of the arena visited in Hilbert-curve order (the
panoramas come from the shared render cache); each feature is weighted by its slowness along
that sequence; a feature field of the rotation-averaged features replaces rendering, and the
gradient controller runs the track's fixed episodes. Score: the success rate over all episodes
(higher is better), with SPL beside it.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from sfa_gym.leaderboard.cache import RunCache, RunRequest

__all__ = ["navigation_scores"]


def navigation_scores(
    track: Any, params: Mapping[str, Any], world_seed: int, method: Any, cache: RunCache
) -> dict[str, Any]:
    """Success rate and SPL of the gradient controller on ``method``'s features in the track's
    world ``world_seed`` over episodes ``episode_seed .. episode_seed + episodes - 1``."""
    import gymnasium as gym

    from sfa_gym.experiments.common import fit_method
    from sfa_gym.features import rotation_averaged_features
    from sfa_gym.navigation.controllers import GradientController, slowness_weights
    from sfa_gym.navigation.evaluate import run_episodes, summarize
    from sfa_gym.navigation.field import FeatureField
    from sfa_gym.recording.drivers import GridPositions
    from sfa_gym.rotation import Rotation
    from sfa_gym.sim.env import OmniRoverEnv

    request = RunRequest(
        world=track.world,
        world_seed=world_seed,
        panorama=tuple(params["panorama"]),
        driver=GridPositions(n=params["train_grid"], seed=track.seed, order="hilbert"),
        seed=track.seed,
    )
    nav = gym.make(params["env_id"], world_seed=world_seed).unwrapped
    spec = request.panorama_spec()
    if (nav.panorama.height, nav.panorama.width) != (spec.height, spec.width):
        raise ValueError(
            f"track {track.name!r}: params.panorama {list(params['panorama'])} differs from the "
            f"panorama of {params['env_id']} ({nav.panorama.height} x {nav.panorama.width})"
        )
    run = cache.get(request)
    free = nav.occupancy.is_free(run.positions)
    train = np.asarray(run.panoramas)[free]
    fitted = fit_method(method, train, Rotation())
    weights = slowness_weights(
        rotation_averaged_features(fitted, train, step=1), params["weight_power"]
    )
    camera = OmniRoverEnv(nav.world, nav.world_seed, nav.panorama)
    try:
        field = FeatureField.build(
            camera,
            fitted,
            spacing=params["field_spacing"],
            free=nav.occupancy.is_free,
            progress=False,
            model_info={"method": method.name, "cost_weights": weights.tolist()},
        )
    finally:
        camera.close()
    env = gym.make(params["env_id"], world_seed=world_seed, feature_field=field)
    try:
        controller = GradientController.for_env(env, weights)
        first = params["episode_seed"]
        seeds = range(first, first + params["episodes"])
        summary = summarize(run_episodes(env, controller, seeds, progress=False))
    finally:
        env.close()
        nav.close()
    every = summary["all"]
    return {
        "score": every["success"]["mean"],
        "spl": every["spl"]["mean"],
        "episodes": every["episodes"],
        "interior": {
            "episodes": summary["interior"]["episodes"],
            "success": summary["interior"]["success"]["mean"],
            "spl": summary["interior"]["spl"]["mean"],
        },
        "training_positions": int(len(train)),
    }
