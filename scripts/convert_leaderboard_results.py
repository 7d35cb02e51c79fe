"""Convert leaderboard results of schema versions 1 and 2 to schema version 3, in place.

    python scripts/convert_leaderboard_results.py FILE_OR_FOLDER...

- a gathered file (``{"description", "results": [...]}``, no format: what ``sfa-gym leaderboard
  publish`` wrote before schema 3) keeps its description and every entry as it is, value by
  value; it gains ``"format"`` and ``"schema_version": 3``;
- a result file (``"format": "sfa-gym-leaderboard-result"``, schema 1 or 2: one track and
  method, its tasks nested) becomes a file of that one result in the entry's shape of
  :mod:`sfa_gym.leaderboard.results`: what a gathered entry kept of it, the parts per world
  seed beside, the score recomputed by today's interval (:func:`sfa_gym.intervals.summarize`;
  schema 1 recorded the unclipped one), its content hash as ``result_sha256``.

Task files and files already at schema 3 are left alone. Used once, for published/leaderboard/.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

from sfa_gym.files import write_json_atomic
from sfa_gym.intervals import summarize
from sfa_gym.leaderboard.results import FORMAT, SCHEMA_VERSION, content_sha256, load_results

PROVENANCE = ("git_commit", "backend", "created", "versions", "cpu_numerics")


def _mean_parts(tasks: list[dict]) -> dict | None:
    if not all("parts" in t["scores"] for t in tasks):
        return None
    names = dict.fromkeys(p for t in tasks for p in t["scores"]["parts"])
    values = {
        p: [v for t in tasks if (v := t["scores"]["parts"].get(p)) is not None] for p in names
    }
    return {p: float(np.mean(v)) for p, v in values.items() if v}


def _entry(result: dict) -> dict:
    """A result file of schema 1 or 2 as an entry of schema 3."""
    tasks, track = result["tasks"], result["track"]
    seeds = [str(t["world_seed"]) for t in tasks]
    per_seed = {s: t["scores"]["score"] for s, t in zip(seeds, tasks, strict=True)}
    entry = {
        "track": track["name"],
        "track_version": track["track_version"],
        "quick": bool(track["quick"]),
        "size_params": track.get("size_params"),
        "method": result["method"]["label"],
        "method_sha256": result["method"].get("sha256"),
        "score": summarize(list(per_seed.values()), result["score"]["higher_is_better"]),
        "per_world_seed": per_seed,
        "parts": _mean_parts(tasks),
    }
    for field, key in (("parts_per_world_seed", "parts"), ("fingerprints", "fingerprint")):
        if all(key in t["scores"] for t in tasks):
            entry[field] = {s: t["scores"][key] for s, t in zip(seeds, tasks, strict=True)}
    if all("spl" in t["scores"] for t in tasks):
        spl = {s: float(t["scores"]["spl"]) for s, t in zip(seeds, tasks, strict=True)}
        entry["spl"] = {"mean": float(np.mean(list(spl.values()))), "per_world_seed": spl}
    entry |= {
        "task_seconds": [t.get("seconds") for t in tasks],
        "task_phases": [t.get("phases") for t in tasks],
        "task_peak_rss_mb": [t.get("peak_rss_mb") for t in tasks],
        "result_sha256": result.get("content_sha256"),
        "isolation": sorted({str(t.get("isolation")) for t in tasks}),
        **{k: result["provenance"].get(k) for k in PROVENANCE},
    }
    return entry


def convert(path: Path) -> bool:
    """Convert one file in place; whether it was converted."""
    data = json.loads(path.read_text())
    if not isinstance(data, dict):
        return False
    header = {"format": FORMAT, "schema_version": SCHEMA_VERSION}
    if "format" not in data and isinstance(data.get("results"), list):
        write_json_atomic(path, header | data)
    elif data.get("format") == "sfa-gym-leaderboard-result":
        entry = _entry(data)
        write_json_atomic(
            path, header | {"results": [entry | {"content_sha256": content_sha256(entry)}]}
        )
    else:
        return False
    load_results(path)  # reads as schema 3, every check passed
    return True


if __name__ == "__main__":
    for argument in sys.argv[1:]:
        root = Path(argument)
        for path in [root] if root.is_file() else sorted(root.rglob("*.json")):
            if convert(path):
                print(f"converted {path}")
