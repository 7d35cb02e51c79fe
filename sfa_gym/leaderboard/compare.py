"""Whether a run of the board scored what a reference run scored: result by result (track, size,
method), world seed by world seed, and each seed's parts (the outdoor tracks' conditions; their
means where one side is a gathered file).

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

from sfa_gym.leaderboard.results import load_results, mean_parts, one_per_key, result_key

__all__ = ["Comparison", "compare_results", "comparison_table", "read_results"]


@dataclass(frozen=True)
class Comparison:
    """One result of either run against its counterpart.

    Attributes:
        track, quick, method: the result's key.
        status: ``"equal"`` (every world seed both runs scored, and its parts, equal to the
            last stored digit; only the parts' means where one side is a gathered file),
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
    """The results of a results folder (its result files and gathered files) or of one
    gathered file, checked as the table checks them.

    Raises:
        FileNotFoundError: ``path`` does not exist.
        ResultError: a file that is not a valid result or gathered file.
    """
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"{path}: no such results folder or gathered file")
    return load_results(path)


def _per_seed(result: dict[str, Any]) -> dict[int, float]:
    return {int(t["world_seed"]): float(t["scores"]["score"]) for t in result["tasks"]}


def _seed_parts(result: dict[str, Any]) -> dict[int, dict[str, float]] | None:
    """Each world seed's parts of the score, where the result holds them per seed (a result
    file; a gathered entry keeps only their means)."""
    if "_entry" in result or not all("parts" in t["scores"] for t in result["tasks"]):
        return None
    return {int(t["world_seed"]): t["scores"]["parts"] for t in result["tasks"]}


def _context(result: dict[str, Any]) -> dict[str, Any]:
    """What, besides the code, decides a result's numbers, by the name the table gives it."""
    provenance = result.get("provenance") or {}
    return {
        "method file": result["method"].get("sha256"),
        "track version": result["track"].get("track_version"),
        "size": result["track"].get("size_params"),
        "cpu numerics": provenance.get("cpu_numerics"),
        "package versions": provenance.get("versions"),
    }


def _compare(reference: dict[str, Any], run: dict[str, Any]) -> Comparison:
    ours, theirs = _per_seed(reference), _per_seed(run)
    common = sorted(set(ours) & set(theirs))
    differences = [abs(ours[s] - theirs[s]) for s in common]
    seed_parts = _seed_parts(reference), _seed_parts(run)
    if seed_parts[0] is not None and seed_parts[1] is not None:  # two result files
        pairs = [(seed_parts[0][s], seed_parts[1][s]) for s in common]
    elif len(common) == len(ours) == len(theirs):  # means of the same seeds (a gathered file)
        pairs = [(mean_parts(reference) or {}, mean_parts(run) or {})]
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

    A result file replaces a gathered file's entry of the same key, as ``leaderboard publish``
    does (:func:`~sfa_gym.leaderboard.results.one_per_key`).

    Raises:
        ValueError: a run holds two result files, or two gathered entries, of one track, size
            and method.
    """
    ref, new = one_per_key(reference, "the reference"), one_per_key(run, "the run")
    rows = []
    for key in sorted(set(ref) | set(new)):
        if key in ref and key in new:
            rows.append(_compare(ref[key], new[key]))
        else:
            status = "reference only" if key in ref else "run only"
            seeds = len(ref[key]["tasks"]) if key in ref else 0
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
