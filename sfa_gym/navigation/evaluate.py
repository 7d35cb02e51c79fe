"""Run a controller for episodes on fixed seeds and score them (success, SPL, SoftSPL, ...)."""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any

import numpy as np
from numpy.typing import NDArray
from tqdm import tqdm

from sfa_gym.capabilities import get_capabilities
from sfa_gym.navigation.controllers import Controller
from sfa_gym.navigation.metrics import soft_spl, spl, summarize_episodes

__all__ = ["goal_panorama", "run_episode", "run_episodes", "summarize", "with_panoramas"]


def with_panoramas(
    env: Any, obs: Mapping[str, Any], goal_panorama: NDArray[np.uint8]
) -> dict[str, Any]:
    """``obs`` with ``"panorama"`` (the camera's now: the env's own render when it observes
    pixels, else rendered now) and ``"goal_panorama"``."""
    panorama = obs["panorama"] if "panorama" in obs else env.unwrapped.render_panorama()
    return {**obs, "panorama": panorama, "goal_panorama": goal_panorama}


def goal_panorama(env: Any, obs: Mapping[str, Any], info: Mapping[str, Any]) -> NDArray[np.uint8]:
    """The panorama at the episode's goal pose: the env's own (``obs["goal"]``) when it observes
    pixels, else rendered at ``info["goal"]`` without touching the episode."""
    if "panorama" in obs and "goal" in obs:
        return np.asarray(obs["goal"])
    return env.unwrapped.render_panorama(info["goal"])


def run_episode(env: Any, controller: Controller, seed: int) -> dict[str, Any]:
    """One episode of ``controller`` in ``env`` from ``env.reset(seed=seed)``.

    A controller that declares the capability ``panoramas``
    (:class:`~sfa_gym.capabilities.Capabilities`) gets ``obs["panorama"]``, rendered at every
    step, and ``obs["goal_panorama"]``, rendered once at the goal pose, besides the env's own
    observation (the features of a feature field): real renders, also when the env observes a
    field. The physics, and so the episode of a controller that acts the same, do not change.

    Returns the episode's scores (:data:`~sfa_gym.navigation.metrics.EPISODE_KEYS`), its start,
    goal, whether it is interior, and its ground-truth path ``(n, 2)``.
    """
    panoramas = get_capabilities(controller).panoramas
    obs, info = env.reset(seed=seed)
    if panoramas:
        goal = goal_panorama(env, obs, info)
        obs = with_panoramas(env, obs, goal)
    controller.reset(obs, info)
    path = [(info["x"], info["y"])]
    steps = 0
    terminated = truncated = False
    while not (terminated or truncated):
        obs, _, terminated, truncated, info = env.step(controller.act(obs, info))
        if panoramas and not (terminated or truncated):  # the last one nobody sees
            obs = with_panoramas(env, obs, goal)
        path.append((info["x"], info["y"]))
        steps += 1
    shortest = float(info["shortest_path"])
    taken = float(info["path_length"])
    final = float(info["geodesic_distance"])
    return {
        "seed": int(seed),
        "success": bool(info["success"]),
        "spl": float(spl(info["success"], shortest, taken)),
        "soft_spl": float(soft_spl(final, shortest, taken)),
        "final_distance": final,
        "path_ratio": taken / shortest,
        "collisions": int(info["collisions"]),
        "steps": steps,
        "stopped": bool(terminated),
        "interior": bool(info["interior"]),
        "shortest_path": shortest,
        "start": [float(v) for v in info["start"]],
        "goal": [float(v) for v in info["goal"]],
        "path": np.asarray(path, dtype=np.float64),
    }


def run_episodes(
    env: Any,
    controller: Controller,
    seeds: Iterable[int],
    progress: bool = True,
    desc: str | None = None,
) -> list[dict[str, Any]]:
    """:func:`run_episode` for each seed, with a progress bar showing the success rate so far."""
    seeds = list(seeds)
    episodes: list[dict[str, Any]] = []
    bar = tqdm(seeds, desc=desc or getattr(controller, "name", "episodes"), disable=not progress)
    for seed in bar:
        episodes.append(run_episode(env, controller, seed))
        bar.set_postfix(success=f"{np.mean([e['success'] for e in episodes]):.2f}")
    return episodes


def summarize(episodes: list[Mapping[str, Any]]) -> dict[str, Any]:
    """Scores over all episodes and over the interior ones (start and goal away from walls)."""
    interior = [e for e in episodes if e["interior"]]
    return {"all": summarize_episodes(episodes), "interior": summarize_episodes(interior)}
