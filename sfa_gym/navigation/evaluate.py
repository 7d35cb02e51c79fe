"""Run a controller for episodes on fixed seeds and score them (success, SPL, SoftSPL, ...)."""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any

import numpy as np
from tqdm import tqdm

from sfa_gym.navigation.controllers import Controller
from sfa_gym.navigation.metrics import soft_spl, spl, summarize_episodes

__all__ = ["run_episode", "run_episodes", "summarize"]


def run_episode(env: Any, controller: Controller, seed: int) -> dict[str, Any]:
    """One episode of ``controller`` in ``env`` from ``env.reset(seed=seed)``.

    Returns the episode's scores (:data:`~sfa_gym.navigation.metrics.EPISODE_KEYS`), its start,
    goal, whether it is interior, and its ground-truth path ``(n, 2)``.
    """
    obs, info = env.reset(seed=seed)
    controller.reset(obs, info)
    path = [(info["x"], info["y"])]
    steps = 0
    terminated = truncated = False
    while not (terminated or truncated):
        obs, _, terminated, truncated, info = env.step(controller.act(obs, info))
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
