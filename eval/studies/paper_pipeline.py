"""Study: the paper's pipeline (hierarchical SFA + linear regression) on the simulator protocol,
and which setting moves its error toward the paper's 1.83 / 1.68 %.

The grid protocol (:mod:`sfa_gym.protocols.grid`, the main job's setting) is run with the
hierarchical SFA network of :class:`~sfa_gym.protocols.settings.SFASettings`, one setting
changed per row against the main job's reference, on several world seeds. Every row reports
the paper's evaluation (``paper_splits``: regression fitted and scored on 100 random halves of
the test positions, MAE in % of the test range) with linear regression, the paper's, and with
quadratic regression beside it. Each row's mean over the world seeds comes with a 95 % t
interval (:mod:`sfa_gym.intervals`), so that a setting is read as a lever only where its
interval leaves the reference's.

Writes ``published/studies/paper_pipeline.json``; the table on docs/localization.md is generated
from it (``sfa-gym docs-tables``).

Usage (from the repository root; renders each world's grid once, into the render cache)::

    .venv/bin/python -m eval.studies.paper_pipeline
    .venv/bin/python -m eval.studies.paper_pipeline --world-seeds 0 1 --rows reference layer_sharing
    .venv/bin/python -m eval.studies.paper_pipeline --world-seeds 0 1 2 \
        --rows serpentine_outputs_16 --merge
"""

from __future__ import annotations

import dataclasses
import json
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import tyro
from tqdm.auto import tqdm

from sfa_gym.files import write_json_atomic
from sfa_gym.intervals import mean_entry
from sfa_gym.protocols import grid
from sfa_gym.protocols.settings import SFASettings
from sfa_gym.protocols.slow_features import SlowFeatureMethod
from sfa_gym.recording.cache import RunCache

ROOT = Path(__file__).resolve().parents[2]

PAPER = (1.83, 1.68)
"""The paper's MAE (x, y) in % with linear regression on the simulator (Metka et al. 2013)."""

REFERENCE = grid.Config(evaluations=("paper_splits",))
"""The main job's grid protocol, scored by the paper's evaluation only."""

ROWS: dict[str, tuple[str, dict[str, Any], dict[str, Any]]] = {
    "reference": ("the main job's: one node per row, 32 dims, 8 outputs, Hilbert order", {}, {}),
    "layer_sharing": ("one node per layer, as in the paper", {"weight_sharing": "layer"}, {}),
    "node_dim_16": ("16 dims per node", {"node_dim": 16}, {}),
    "node_dim_48": ("48 dims per node", {"node_dim": 48}, {}),
    "outputs_4": ("4 slow features regressed", {"n_outputs": 4}, {}),
    "outputs_16": ("16 slow features regressed", {"n_outputs": 16}, {}),
    "serpentine": ("training positions in serpentine order", {}, {"order": "serpentine"}),
    "raster": ("training positions in raster order", {}, {"order": "raster"}),
    "serpentine_outputs_16": (
        "serpentine order and 16 slow features regressed",
        {"n_outputs": 16},
        {"order": "serpentine"},
    ),
    "sweeps": (
        "two sweeps: serpentine along the rows, then along the columns",
        {},
        {"order": "sweeps"},
    ),
    "sweeps_outputs_16": (
        "two sweeps and 16 slow features regressed",
        {"n_outputs": 16},
        {"order": "sweeps"},
    ),
    "sweeps_outputs_32": (
        "two sweeps and 32 slow features regressed",
        {"n_outputs": 32},
        {"order": "sweeps"},
    ),
}
"""Row name -> (what changes, SFASettings fields, grid.Config fields)."""


@dataclass
class Args:
    world_seeds: tuple[int, ...] = (0, 1, 2, 3, 4)
    """worlds of the grid protocol (the main job's is 0)"""
    rows: tuple[str, ...] = tuple(ROWS)
    """rows to run (names of ROWS)"""
    cache: Path | None = None
    """render cache (None: the default one)"""
    json: Path = ROOT / "published" / "studies" / "paper_pipeline.json"
    """where to write the figures"""
    merge: bool = False
    """keep the rows of an existing --json that this run does not run (same world seeds)"""


def run_row(name: str, world_seed: int, runs: RunCache) -> dict[str, Any]:
    """One row on one world: MAE % (x, y) of linear and quadratic regression, paper splits."""
    _, sfa_fields, config_fields = ROWS[name]
    config = dataclasses.replace(REFERENCE, **config_fields)
    settings = dataclasses.replace(SFASettings(), **sfa_fields)
    method = SlowFeatureMethod(settings, config.rotation, progress=False)
    started = time.perf_counter()
    found = grid.score(config, method, world_seed, runs, regressors=("linear", "quadratic"))
    out: dict[str, Any] = {"world_seed": world_seed}
    for regressor, scores in found.regressions.items():
        out[regressor] = [round(float(v), 4) for v in scores.paper_splits.mae_percent]
    out["seconds"] = round(time.perf_counter() - started, 1)
    return out


def summarise(runs: list[dict[str, Any]]) -> dict[str, Any]:
    """Per regression, x and y: the mean over the worlds, with its 95 % t interval from
    ``MIN_SEEDS`` worlds on (else None): :func:`~sfa_gym.intervals.mean_entry`."""
    return {
        regressor: [mean_entry(values) for values in np.array([r[regressor] for r in runs]).T]
        for regressor in ("linear", "quadratic")
    }


def main(args: Args) -> dict[str, Any]:
    unknown = [r for r in args.rows if r not in ROWS]
    if unknown:
        raise SystemExit(f"unknown rows {unknown}; expected names of {list(ROWS)}")
    kept: dict[str, Any] = {}
    if args.merge and args.json.exists():
        previous = json.loads(args.json.read_text())
        if previous["world_seeds"] != list(args.world_seeds):
            raise SystemExit(
                f"--merge: {args.json} holds world seeds {previous['world_seeds']}, this run "
                f"{list(args.world_seeds)}; rows are comparable only on the same worlds"
            )
        kept = {k: v for k, v in previous["rows"].items() if k not in args.rows}
    runs = RunCache(args.cache)
    jobs = [(name, seed) for name in args.rows for seed in args.world_seeds]
    found: dict[str, list[dict[str, Any]]] = {name: [] for name in args.rows}
    for name, seed in tqdm(jobs, desc="paper pipeline"):
        found[name].append(run_row(name, seed, runs))
    result = {
        "format": "sfa-gym-study-paper-pipeline",
        "version": 1,
        "paper_mae_percent": list(PAPER),
        "protocol": dataclasses.asdict(REFERENCE),
        "reference_sfa": dataclasses.asdict(SFASettings()),
        "world_seeds": list(args.world_seeds),
        "rows": {},
    }
    for name in ROWS:  # in the order of ROWS, whichever run they come from
        if name in found:
            result["rows"][name] = {
                "change": ROWS[name][0],
                "sfa": ROWS[name][1],
                "protocol": ROWS[name][2],
                "runs": found[name],
                **summarise(found[name]),
            }
        elif name in kept:
            result["rows"][name] = kept[name]
    write_json_atomic(args.json, result)
    print(f"wrote {args.json}")
    return result


if __name__ == "__main__":
    main(tyro.cli(Args))
