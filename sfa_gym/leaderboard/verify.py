"""The checks of a leaderboard result before the table shows it: every field the table reads,
of the right type, and the score's summary (:func:`summarize`: the mean, the 95 % interval by
the method the result records, ``n``) recomputed from the seeds' scores. A stored summary that
differs from the recomputed one beyond round-off (:data:`ROUND_OFF`) has been edited or
damaged, and since it is not known which part changed, the result is refused rather than shown
with a corrected number. Reading files, and a file's place against its content, are
:mod:`sfa_gym.leaderboard.results`'s.
"""

from __future__ import annotations

import hashlib
import json
import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from sfa_gym.intervals import MIN_SEEDS, t_interval

__all__ = [
    "INTERVAL",
    "INTERVALS",
    "ROUND_OFF",
    "ResultError",
    "check_result",
    "content_sha256",
    "score_range",
    "summarize",
]

ROUND_OFF = 1e-6
"""The relative difference allowed between a stored summary and the one recomputed from the
seeds' scores: gathered files keep ten digits of each; an edit of a shown digit is far beyond."""

INTERVALS = ("t", "t-clipped")
"""The interval methods a result's ``score.interval`` may record (see :func:`summarize`)."""
INTERVAL = "t-clipped"
"""The interval method of new results and of every shown score."""


class ResultError(ValueError):
    """A result file or gathered entry that cannot be shown; the message names the file and what
    is wrong with it."""


def score_range(higher_is_better: bool) -> tuple[float, float]:
    """The range of a leaderboard score: a navigation track's success rate (higher is better)
    lies in [0, 1], a localization track's MAE (lower is better) in [0, inf). Each kind of track
    has its one direction (:data:`~sfa_gym.leaderboard.evaluate.HIGHER_IS_BETTER`), which every
    result (gathered entries too) records, so the direction names the range."""
    return (0.0, 1.0) if higher_is_better else (0.0, math.inf)


def summarize(
    values: Sequence[float], higher_is_better: bool, interval: str = INTERVAL
) -> dict[str, Any]:
    """Mean and 95 % interval of per-world-seed ``values`` by the method ``interval``
    (:data:`INTERVALS`): ``"t-clipped"``, what new results record, Student's t clipped to the
    :func:`score_range`, none with fewer than :data:`~sfa_gym.intervals.MIN_SEEDS` seeds;
    ``"t"``, what results of schema version 1 record, Student's t as it falls, from two seeds.

    Raises:
        ValueError: ``interval`` is not one of :data:`INTERVALS`.
    """
    if interval not in INTERVALS:
        raise ValueError(f"interval {interval!r}; expected one of {list(INTERVALS)}")
    x = np.asarray(values, dtype=np.float64)
    out: dict[str, Any] = {
        "mean": float(x.mean()),
        "ci95": None,
        "interval": interval,
        "n": int(len(x)),
        "std": None,
        "higher_is_better": higher_is_better,
    }
    if len(x) > 1:
        out["std"] = float(x.std(ddof=1))
    if interval == "t" and len(x) > 1:
        out["ci95"] = list(t_interval(x))
    elif interval == "t-clipped" and len(x) >= MIN_SEEDS:
        out["ci95"] = list(t_interval(x, *score_range(higher_is_better)))
    return out


def _get(where: str, data: Any, dotted: str, kind: str) -> Any:
    """``data[a][b]`` for ``dotted`` ``"a.b"``, checked to be of ``kind`` (``"text"``,
    ``"bool"``, ``"int"``, ``"number"`` (finite), ``"object"``, ``"list"``).

    Raises:
        ResultError: the field is missing or of another type (named with ``where``).
    """
    value, keys = data, dotted.split(".")
    for i, key in enumerate(keys):
        if not isinstance(value, dict):
            raise ResultError(f"{where}: {'.'.join(keys[:i])!r} is {value!r}; expected object")
        if key not in value:
            raise ResultError(f"{where} lacks {'.'.join(keys[: i + 1])!r}")
        value = value[key]
    ok = {
        "text": isinstance(value, str),
        "bool": isinstance(value, bool),
        "int": isinstance(value, int) and not isinstance(value, bool),
        "number": _finite(value),
        "object": isinstance(value, dict),
        "list": isinstance(value, list),
    }[kind]
    if not ok:
        raise ResultError(f"{where}: {dotted!r} is {value!r}; expected {kind}")
    return value


def _finite(value: Any) -> bool:
    """Whether ``value`` is a finite JSON number (not a bool)."""
    number = isinstance(value, int | float) and not isinstance(value, bool)
    return number and math.isfinite(value)


def _close(stored: Any, fresh: Any) -> bool:
    """Whether a stored summary value is the recomputed one up to :data:`ROUND_OFF`."""
    if fresh is None or stored is None:
        return stored is None and fresh is None
    if isinstance(fresh, list):
        return (
            isinstance(stored, list)
            and len(stored) == len(fresh)
            and all(_close(a, b) for a, b in zip(stored, fresh, strict=True))
        )
    number = isinstance(stored, int | float) and not isinstance(stored, bool)
    return number and math.isclose(stored, fresh, rel_tol=ROUND_OFF, abs_tol=ROUND_OFF)


def content_sha256(result: dict[str, Any]) -> str:
    """The SHA-256 of a result's content (canonical JSON, without ``content_sha256`` itself and
    the keys the loader adds, ``_source`` and ``_file``): an edit after the file was written
    changes it."""
    content = {k: v for k, v in result.items() if k != "content_sha256" and not k.startswith("_")}
    # NaN hashes as NaN; the field checks refuse it with its place named
    text = json.dumps(content, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()


def check_result(result: dict[str, Any], where: str) -> dict[str, Any]:
    """``result`` (a result file's content or a gathered entry's, :func:`_from_gathered`)
    checked field by field, its score's mean, interval and ``n`` recomputed from its seeds'
    scores by the interval method it records (:func:`summarize`), and its ``score`` replaced by
    the summary by today's method (:data:`INTERVAL`) for showing.

    Raises:
        ResultError: a field is missing or of a wrong type, a world seed repeats, a seed's
            score leaves the :func:`score_range`, the interval method is unknown, or the stored
            mean, interval or ``n`` differ from the recomputed ones beyond :data:`ROUND_OFF`
            (both named, with ``where``).
    """
    recorded = result.get("content_sha256")
    # a gathered entry records no hash of its own: nothing to hash it against
    actual = None if recorded is None else content_sha256(result)
    if recorded is not None and recorded != actual:
        raise ResultError(
            f"{where}: its content was changed after it was written (content_sha256 "
            f"{str(recorded)[:16]}... does not match the content's {actual[:16]}...)"
        )
    _get(where, result, "track.name", "text")
    _get(where, result, "track.quick", "bool")
    if _get(where, result, "track.track_version", "int") < 1:
        raise ResultError(f"{where}: 'track.track_version' must be >= 1")
    _get(where, result, "method.label", "text")
    _get(where, result, "provenance", "object")
    higher = _get(where, result, "score.higher_is_better", "bool")
    tasks = _get(where, result, "tasks", "list")
    if not tasks:
        raise ResultError(f"{where}: 'tasks' is empty; expected a task per world seed")
    values, seeds = [], []
    for i, task in enumerate(tasks):
        seeds.append(_get(f"{where}, task {i}", task, "world_seed", "int"))
        values.append(_get(f"{where}, task {i}", task, "scores.score", "number"))
    if len(set(seeds)) < len(seeds):
        raise ResultError(f"{where}: world seeds {seeds} repeat")
    for i, task in enumerate(tasks):  # navigation's SPL, which the table shows beside
        if "spl" in task["scores"]:
            spl = _get(f"{where}, task {i}", task, "scores.spl", "number")
            if not 0.0 <= spl <= 1.0:
                raise ResultError(f"{where}, task {i}: 'scores.spl' is {spl!r}; expected [0, 1]")
    # what else the table reads: each part's score, the recorded versions
    parts = [(f"{where}, task {i}", t["scores"].get("parts")) for i, t in enumerate(tasks)]
    for place, found in [*parts, (where, result.get("parts"))]:
        if found is not None and not (
            isinstance(found, dict) and all(v is None or _finite(v) for v in found.values())
        ):
            raise ResultError(f"{place}: 'parts' is {found!r}; expected {{part: number}}")
    versions = result["provenance"].get("versions")
    if versions is not None and not isinstance(versions, dict):
        raise ResultError(f"{where}: 'provenance.versions' is {versions!r}; expected an object")
    low, high = score_range(higher)
    outside = [(s, v) for s, v in zip(seeds, values, strict=True) if not low <= v <= high]
    if outside:
        raise ResultError(
            f"{where}: world seed {outside[0][0]}'s score {outside[0][1]!r} leaves the score's "
            f"range [{low}, {high}] ({'success rate' if higher else 'MAE'})"
        )
    method = _get(where, result, "score.interval", "text")
    if method not in INTERVALS:
        raise ResultError(
            f"{where}: 'score.interval' is {method!r}; expected one of {list(INTERVALS)}"
        )
    # checked by the method the result records (older results: "t"), shown by today's
    stored, fresh = result["score"], summarize(values, higher, method)
    differ = [
        f"score.{k} is {stored.get(k)!r} but its seeds' scores give {fresh[k]!r}"
        for k in ("mean", "n", "ci95")
        if not _close(stored.get(k), fresh[k])
    ]
    if differ:
        raise ResultError(f"{where}: {'; '.join(differ)}")
    # shown: the numbers recomputed by today's method, never the stored ones, so that every
    # interval in a table is of one kind and within the score's range
    result["score"] = {**stored, **summarize(values, higher)}
    return result
