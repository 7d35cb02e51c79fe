"""Confidence intervals that stay in the score's range, and how tables print them.

Each kind where its data call for it:

- :func:`wilson`: a success rate over episodes (each a success or not): Wilson's score
  interval, which stays in [0, 1] and keeps a width at no success and at all successes, where
  a normal or bootstrap interval shrinks to a point;
- :func:`t_interval`: the mean of a few world seeds' scores: Student's t, clipped to the
  score's range (a success rate in [0, 1], an MAE >= 0). With three to five seeds the t
  interval's half-width can exceed the mean, and a negative MAE or a success rate above 1
  says nothing more than the range's end;
- :func:`bootstrap_interval`: the mean of another per-episode quantity (SPL, distances,
  steps): the percentile bootstrap, within the values' own range by construction.

Fewer than :data:`MIN_SEEDS` seeds give no interval of the mean: with two, t's 97.5 %
quantile is 12.7 and the interval spans most of the range whatever the scores; a table prints
``(n=2)`` instead (:func:`format_interval`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

__all__ = [
    "INTERVAL",
    "LEVEL",
    "MIN_SEEDS",
    "bootstrap_interval",
    "format_interval",
    "mean_entry",
    "score_range",
    "summarize",
    "t_interval",
    "wilson",
]

LEVEL = 0.95
"""The confidence level of every interval the package reports."""

MIN_SEEDS = 3
"""The fewest values whose mean gets a t interval (see the module docstring)."""

INTERVAL = "t-clipped"
"""The interval method a leaderboard score records (:func:`summarize`)."""


def wilson(successes: int, n: int, level: float = LEVEL) -> tuple[float, float]:
    """Wilson's score interval of a success rate: ``successes`` of ``n`` trials.

    Raises:
        ValueError: ``n`` < 1 or ``successes`` outside ``0..n``.
    """
    from scipy import stats

    if n < 1 or not 0 <= successes <= n:
        raise ValueError(
            f"wilson: {successes} successes of {n} trials; expected n >= 1 and 0 <= k <= n"
        )
    ci = stats.binomtest(int(successes), int(n)).proportion_ci(level, method="wilson")
    return float(ci.low), float(ci.high)


def t_interval(
    values: ArrayLike,
    low: float = -math.inf,
    high: float = math.inf,
    level: float = LEVEL,
) -> tuple[float, float]:
    """Student's t interval of the mean of ``values``, clipped to ``[low, high]``.

    The half-width is written out (the t quantile from scipy) rather than taken from
    ``scipy.stats.t.interval``, which gives NaN for values that are all equal (a zero scale);
    here they give the point interval.

    Raises:
        ValueError: fewer than two values, or a value outside ``[low, high]``.
    """
    from scipy import stats

    x = np.asarray(values, dtype=np.float64)
    if x.size < 2:
        raise ValueError(f"t_interval: {x.size} value(s); a t interval needs at least two")
    if np.any(x < low) or np.any(x > high):
        raise ValueError(f"t_interval: values {x.tolist()} leave the range [{low}, {high}]")
    mean = float(x.mean())
    half = float(stats.t.ppf(0.5 + level / 2, x.size - 1)) * float(x.std(ddof=1))
    half /= math.sqrt(x.size)
    return max(low, mean - half), min(high, mean + half)


def score_range(higher_is_better: bool) -> tuple[float, float]:
    """The range of a leaderboard score: a navigation track's success rate (higher is better)
    lies in [0, 1], a localization track's MAE (lower is better) in [0, inf)."""
    return (0.0, 1.0) if higher_is_better else (0.0, math.inf)


def summarize(values: Sequence[float], higher_is_better: bool) -> dict[str, Any]:
    """A leaderboard score of per-world-seed ``values``: their mean, ``n``, standard deviation
    and the 95 % :func:`t_interval` clipped to the :func:`score_range` (none with fewer than
    :data:`MIN_SEEDS` seeds). The one place a score's mean and interval are computed: results
    store it, and the table, compare, publish and the HTML board read it."""
    x = np.asarray(values, dtype=np.float64)
    enough = len(x) >= MIN_SEEDS
    return {
        "mean": float(x.mean()),
        "ci95": list(t_interval(x, *score_range(higher_is_better))) if enough else None,
        "interval": INTERVAL,
        "n": int(len(x)),
        "std": float(x.std(ddof=1)) if len(x) > 1 else None,
        "higher_is_better": higher_is_better,
    }


def mean_entry(values: ArrayLike, low: float = 0.0, digits: int = 4) -> dict[str, Any]:
    """``{"mean", "interval"}`` of ``values`` over seeds (errors: ``low`` 0), rounded to
    ``digits``: the t interval (:func:`t_interval`) from :data:`MIN_SEEDS` values on, else
    None. The studies' tables read these entries."""
    x = np.asarray(values, dtype=np.float64)
    interval = t_interval(x, low=low) if x.size >= MIN_SEEDS else None
    return {
        "mean": round(float(x.mean()), digits),
        "interval": None if interval is None else [round(v, digits) for v in interval],
    }


def bootstrap_interval(
    values: ArrayLike, level: float = LEVEL, n_resamples: int = 2000, seed: int = 0
) -> tuple[float, float]:
    """Percentile bootstrap interval of the mean of ``values`` (deterministic: a fixed
    resampling seed); one value gives the point interval.

    Raises:
        ValueError: no values.
    """
    from scipy import stats

    x = np.asarray(values, dtype=np.float64)
    if x.size == 0:
        raise ValueError("bootstrap_interval: no values")
    if x.size == 1:  # scipy refuses a single observation; its resamples would all be it
        return float(x[0]), float(x[0])
    ci = stats.bootstrap(
        (x,),
        np.mean,
        confidence_level=level,
        n_resamples=n_resamples,
        method="percentile",
        rng=np.random.default_rng(seed),
    ).confidence_interval
    return float(ci.low), float(ci.high)


def format_interval(ci: Sequence[float | None] | None, n: int, digits: int = 2) -> str:
    """``[a, b]``, or ``(n=2)`` where ``n`` values gave no interval (``ci`` None)."""
    if ci is None or ci[0] is None or ci[1] is None:
        return f"(n={n})"
    return f"[{ci[0]:.{digits}f}, {ci[1]:.{digits}f}]"
