"""Whether a run of the board scored what a reference run scored: result by result (track, size,
method), world seed by world seed, and each seed's parts (the outdoor tracks' conditions; their
means where one side does not record them per seed: results published before schema 3).

Same seed, same numbers is what the board promises: a rerun on this code gives every published
score to its last stored digit. Where a score differs, the comparison says what else differs
between the two results, since that is what may explain it: the method's file, the track's
version or size, the CPU's numerics (the BLAS kernels that decide the last bits; deep methods
amplify them in training) or the package versions. ``sfa-gym leaderboard compare`` is the
command.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from sfa_gym.leaderboard.results import load_results, one_per_key, result_key

__all__ = ["Comparison", "compare_results", "comparison_table", "read_results"]


@dataclass(frozen=True)
class Comparison:
    """One result of either run against its counterpart.

    Attributes:
        track, quick, method: the result's key.
        status: ``"equal"`` (every world seed both runs scored, and its parts, equal to the
            last stored digit; only the parts' means where one side has no
            ``parts_per_world_seed``),
            ``"differs"``, ``"no common world seed"``, ``"reference only"`` or ``"run only"``.
        seeds: ``(compared, the reference's)`` world seeds.
        largest_difference: the largest absolute difference of a world seed's score or of a
            part; None where nothing was compared.
        also_differs: what else differs between the two results (see the module docstring).
    """

    track: str
    quick: bool
    method: str
    status: str
    seeds: tuple[int, int]
    largest_difference: float | None
    also_differs: tuple[str, ...]


def read_results(path: str | os.PathLike[str]) -> list[dict[str, Any]]:
    """The results of a results folder or of one results file, checked as the table checks
    them.

    Raises:
        FileNotFoundError: ``path`` does not exist.
        ResultError: a file that is not a valid results file.
    """
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"{path}: no such results folder or results file")
    return load_results(path)


def _per_seed(result: dict[str, Any]) -> dict[int, float]:
    return {int(seed): float(value) for seed, value in result["per_world_seed"].items()}


def _context(result: dict[str, Any]) -> dict[str, Any]:
    """What, besides the code, decides a result's numbers, by the name the table gives it."""
    keys = ("method_sha256", "track_version", "size_params", "cpu_numerics", "versions")
    names = ("method file", "track version", "size", "cpu numerics", "package versions")
    return {name: result.get(key) for name, key in zip(names, keys, strict=True)}


def _compare(reference: dict[str, Any], run: dict[str, Any]) -> Comparison:
    ours, theirs = _per_seed(reference), _per_seed(run)
    common = sorted(set(ours) & set(theirs))
    differences = [abs(ours[s] - theirs[s]) for s in common]
    seed_parts = [r.get("parts_per_world_seed") for r in (reference, run)]
    if None not in seed_parts:  # both record each seed's parts
        pairs = [(seed_parts[0][str(s)], seed_parts[1][str(s)]) for s in common]
    elif len(common) == len(ours) == len(theirs):  # the means of the same seeds
        pairs = [(reference.get("parts") or {}, run.get("parts") or {})]
    else:
        pairs = []
    for a, b in pairs:
        differences += [abs(a[p] - b[p]) for p in set(a) & set(b)]
        if set(a) != set(b):
            differences.append(float("inf"))
    a, b = _context(reference), _context(run)
    # unrecorded on either side (results written before the field was) is not a difference
    also = tuple(n for n in a if None not in (a[n], b[n]) and a[n] != b[n])
    if not common:
        status = "no common world seed"
    else:
        status = "equal" if max(differences) == 0.0 else "differs"
    return Comparison(
        *result_key(reference),
        status=status,
        seeds=(len(common), len(ours)),
        largest_difference=max(differences) if differences else None,
        also_differs=also,
    )


def compare_results(reference: list[dict[str, Any]], run: list[dict[str, Any]]) -> list[Comparison]:
    """Every result of ``reference`` against the result of ``run`` with its key, then the
    results only ``run`` has; sorted by track, size and method.

    A sweep's result replaces a gathered result of the same key, as ``leaderboard publish``
    does (:func:`~sfa_gym.leaderboard.results.one_per_key`).

    Raises:
        ValueError: a run holds two sweep results, or two gathered results, of one track, size
            and method.
    """
    ref, new = one_per_key(reference, "the reference"), one_per_key(run, "the run")
    rows = []
    for key in sorted(set(ref) | set(new)):
        if key in ref and key in new:
            rows.append(_compare(ref[key], new[key]))
        else:
            status = "reference only" if key in ref else "run only"
            seeds = len(ref[key]["per_world_seed"]) if key in ref else 0
            rows.append(Comparison(*key, status, (0, seeds), None, ()))
    return rows


def comparison_table(rows: list[Comparison]) -> str:
    """``rows`` as a Markdown table, with a line that counts each status."""
    lines = [
        "| track | size | method | status | world seeds | largest difference | also differs |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        largest = "-" if r.largest_difference is None else f"{r.largest_difference:.3g}"
        cells = [f"`{r.track}`", "quick" if r.quick else "full", r.method, r.status]
        cells += [f"{r.seeds[0]} of {r.seeds[1]}", largest, ", ".join(r.also_differs) or "-"]
        lines.append("| " + " | ".join(cells) + " |")
    counts: dict[str, int] = {}
    for r in rows:
        counts[r.status] = counts.get(r.status, 0) + 1
    lines += ["", ", ".join(f"{n} {status}" for status, n in counts.items())]
    return "\n".join(lines)
