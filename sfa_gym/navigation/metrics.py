"""Navigation metrics: success, SPL and SoftSPL (Anderson et al. 2018, arXiv 1807.06757;
Habitat's SoftSPL), with confidence intervals over episodes.

For one episode with success ``S`` (0 or 1), geodesic shortest-path length ``l`` from the start
to the goal and length ``p`` of the path the agent took:

- ``SPL = S * l / max(p, l)``;
- ``SoftSPL = max(0, 1 - d / l) * l / max(p, l)``, with ``d`` the geodesic distance to the goal
  at the end: progress towards the goal instead of binary success.

The success rate's interval is Wilson's, the others' the percentile bootstrap
(:func:`confidence_interval`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sfa_gym.intervals import bootstrap_interval, wilson

__all__ = ["confidence_interval", "soft_spl", "spl", "summarize_episodes"]

EPISODE_KEYS = (
    "success",
    "spl",
    "soft_spl",
    "final_distance",
    "path_ratio",
    "collisions",
    "steps",
)
"""Per-episode quantities that :func:`summarize_episodes` averages."""


def _lengths(shortest: ArrayLike, path: ArrayLike) -> tuple[NDArray, NDArray]:
    shortest = np.asarray(shortest, dtype=np.float64)
    path = np.asarray(path, dtype=np.float64)
    if np.any(~(shortest > 0)) or np.any(~np.isfinite(shortest)):
        raise ValueError(f"shortest path lengths must be positive and finite, got {shortest!r}")
    if np.any(~(path >= 0)) or np.any(~np.isfinite(path)):
        raise ValueError(f"path lengths must be >= 0 and finite, got {path!r}")
    return shortest, path


def spl(success: ArrayLike, shortest: ArrayLike, path: ArrayLike) -> NDArray[np.float64]:
    """Success weighted by path length, per episode: ``S * l / max(p, l)``."""
    shortest, path = _lengths(shortest, path)
    s = np.asarray(success, dtype=np.float64)
    return s * shortest / np.maximum(path, shortest)


def soft_spl(
    final_distance: ArrayLike, shortest: ArrayLike, path: ArrayLike
) -> NDArray[np.float64]:
    """SoftSPL per episode: ``max(0, 1 - d / l) * l / max(p, l)``."""
    shortest, path = _lengths(shortest, path)
    d = np.asarray(final_distance, dtype=np.float64)
    return np.maximum(0.0, 1.0 - d / shortest) * shortest / np.maximum(path, shortest)


def confidence_interval(values: ArrayLike, key: str) -> tuple[float, float]:
    """The 95 % interval of the mean of one per-episode quantity ``key``: Wilson's for
    ``success`` (0 or 1 per episode), the percentile bootstrap for the others
    (:mod:`sfa_gym.intervals`); both stay within the quantity's range."""
    values = np.asarray(values, dtype=np.float64)
    if key == "success":
        return wilson(int(values.sum()), values.size)
    return bootstrap_interval(values)


def summarize_episodes(episodes: Sequence[Mapping[str, Any]]) -> dict[str, Any]:
    """Mean and 95 % interval (:func:`confidence_interval`) of each of :data:`EPISODE_KEYS`
    over ``episodes``.

    Each episode maps those keys to numbers (``success`` may be a bool). Without episodes (say,
    no interior pair among a few) a score has no mean: ``None`` and ``[None, None]``, which the
    JSON files write as null (they refuse NaN).
    """
    summary: dict[str, Any] = {"episodes": len(episodes)}
    for key in EPISODE_KEYS:
        values = np.array([float(e[key]) for e in episodes])
        summary[key] = (
            {"mean": float(values.mean()), "ci95": list(confidence_interval(values, key))}
            if values.size
            else {"mean": None, "ci95": [None, None]}
        )
    return summary
