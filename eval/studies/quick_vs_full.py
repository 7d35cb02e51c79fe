"""Study: does the quick board rank the methods as the full board does?

Backs docs/leaderboard.md ("Quick and full size"); writes ``published/studies/quick_vs_full.json``.

For every track with results at both sizes, the methods present at both are ordered by their
mean score (best first, in the track's direction) and the two orders compared by Kendall's
tau-b (``scipy.stats.kendalltau``: 1 is the same order, -1 the reverse, ties counted as
ties). Each size's results are read wherever the leaderboard reads them: a results folder of
``sfa-gym leaderboard run`` or a published (gathered) file; each result is checked as the table
checks it. A track whose results at the two sizes come from different track versions is
compared all the same and flagged: the versions are printed.

Usage (from the repository root)::

    .venv/bin/python -m eval.studies.quick_vs_full --quick published/leaderboard/quick.json \\
        --full published/leaderboard/full.json
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import tyro
from scipy.stats import kendalltau

from sfa_gym.files import write_json_atomic
from sfa_gym.leaderboard.results import load_results

ROOT = Path(__file__).resolve().parents[2]


@dataclass
class Args:
    quick: Path
    """quick-size results: a results folder or a published file"""
    full: Path
    """full-size results, likewise"""
    json: Path = ROOT / "published" / "studies" / "quick_vs_full.json"
    """where to write the comparison"""
    min_tau: float = 0.8
    """the floor each track should reach (printed beside it)"""


def _means(path: Path, quick: bool) -> dict[str, dict[str, Any]]:
    """``{track: {"higher_is_better", "versions", "scores": {method: mean}}}`` of the results
    at ``path`` of one size."""
    source = path.parent if path.is_file() else path
    out: dict[str, dict[str, Any]] = {}
    for result in load_results(source):
        if path.is_file() and Path(result["_file"]).resolve() != path.resolve():
            continue
        if result["quick"] != quick:
            continue
        track = out.setdefault(
            result["track"],
            {"higher_is_better": result["score"]["higher_is_better"], "versions": set()},
        )
        track["versions"].add(result["track_version"])
        track.setdefault("scores", {})[result["method"]] = result["score"]["mean"]
    return out


def _order(scores: dict[str, float], higher_is_better: bool) -> list[str]:
    return sorted(scores, key=lambda m: -scores[m] if higher_is_better else scores[m])


def compare(quick: dict[str, dict[str, Any]], full: dict[str, dict[str, Any]]) -> list[dict]:
    """One row per track present at both sizes with at least two common methods."""
    rows = []
    for name in sorted(set(quick) & set(full)):
        q, f = quick[name], full[name]
        methods = sorted(set(q["scores"]) & set(f["scores"]))
        if len(methods) < 2:
            continue
        higher = bool(f["higher_is_better"])
        tau = kendalltau([q["scores"][m] for m in methods], [f["scores"][m] for m in methods])
        rows.append(
            {
                "track": name,
                "methods": methods,
                "quick_order": _order({m: q["scores"][m] for m in methods}, higher),
                "full_order": _order({m: f["scores"][m] for m in methods}, higher),
                "quick_scores": {m: q["scores"][m] for m in methods},
                "full_scores": {m: f["scores"][m] for m in methods},
                "kendall_tau": round(float(tau.statistic), 4),
                "versions": {"quick": sorted(q["versions"]), "full": sorted(f["versions"])},
            }
        )
    return rows


def main(args: Args) -> None:
    rows = compare(_means(args.quick, True), _means(args.full, False))
    if not rows:
        raise SystemExit(
            f"no track has results of two methods in both {args.quick} and {args.full}"
        )
    for row in rows:
        flag = "" if row["kendall_tau"] >= args.min_tau else f"  (below {args.min_tau})"
        versions = row["versions"]
        if versions["quick"] != versions["full"]:
            flag += f"  track versions differ: quick {versions['quick']}, full {versions['full']}"
        print(f"{row['track']:20s} tau {row['kendall_tau']:+.2f}{flag}")
        print(f"{'':20s} quick: {' > '.join(row['quick_order'])}")
        print(f"{'':20s} full:  {' > '.join(row['full_order'])}")
    report = {"quick": str(args.quick), "full": str(args.full), "min_tau": args.min_tau}
    report["tracks"] = rows
    write_json_atomic(args.json, report)
    print(f"wrote {args.json}")


if __name__ == "__main__":
    main(tyro.cli(Args))
