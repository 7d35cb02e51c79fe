"""Study: where in the training sequence a second appearance of each place helps SFA most.

The outdoor protocol's ``--train-also -3`` drives the training path again three hours earlier
and trains every method on both runs. Hierarchical SFA sees each training frame's simulated
rotations as one sequence; the two runs can meet in that sequence in two ways:

- ``frames``: frame by frame (``--train-also-order frames``): all rotations of a frame under
  one run's light, then all rotations of the same pose under the other's, then the next frame;
- ``rotations``: inside each frame's rotation sequence (``--train-also-order rotations``):
  every rotation under both lights before the next rotation
  (:func:`sfa_gym.rotation.rotation_sequence`), so that the light changes faster than the
  heading.

Both train on the same views; only their order differs. ``one`` is the training run alone.
For each world seed this runs ``sfa-gym localize-outdoor`` (hierarchical SFA only, the quick
size of the outdoor tracks: 40 x 350 panoramas, the paper's paths sampled every 0.8 s) once per
setting, the later settings reading the runs the first one rendered, and gathers SFA's MAE per
test condition (mean of x and y, % of the test run's range, all test frames) for each
regression: the mean over the world seeds with its 95 % t interval (:mod:`sfa_gym.intervals`).

Writes ``published/studies/appearance_order.json``; docs/outdoor.md's table is generated from
it (``sfa-gym docs-tables``). A setting whose ``results.json`` is in its folder with the same
settings is read, not run again.

Usage (from the repository root; about 6 minutes per world seed on 2 cores)::

    .venv/bin/python -m eval.studies.appearance_order --runs results/appearance_order \\
        --world-seeds 10 11 12 13
"""

from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import tyro

from sfa_gym.cli.localize import OutdoorExperiment, run_outdoor_experiment
from sfa_gym.files import write_json_atomic
from sfa_gym.intervals import mean_entry

ROOT = Path(__file__).resolve().parents[2]

SETTINGS: dict[str, dict[str, Any]] = {
    "rotations": {"train_also": (-3.0,), "train_also_order": "rotations"},
    "frames": {"train_also": (-3.0,), "train_also_order": "frames"},
    "one": {},
}
"""Setting name -> the protocol's settings it changes; the first renders every run."""

QUICK = OutdoorExperiment(
    panorama=(40, 350),
    train_frames=738,
    test_frames=350,
    frame_dt=0.8,
    eval_rotations=14,
    conditions=("after", "later", "overcast", "other_day"),
)
"""The outdoor tracks' quick size, with the conditions of the appearance track but movers."""

REGRESSIONS = ("linear", "quadratic", "map")
"""SFA's regressions reported: the paper's linear one, a quadratic one and the map decoder."""


@dataclass(frozen=True)
class Args:
    """Run the study."""

    runs: Path
    """folder of the protocol's output folders (``ws<seed>/<setting>``), kept and reused"""
    world_seeds: tuple[int, ...] = (10, 11, 12, 13)
    """worlds (seeds no track uses)"""
    out: Path = ROOT / "published" / "studies" / "appearance_order.json"
    """the study's result file"""


def _config(setting: str, world_seed: int) -> OutdoorExperiment:
    return dataclasses.replace(QUICK, world_seed=world_seed, **SETTINGS[setting])


def _same_settings(results: dict[str, Any], config: OutdoorExperiment) -> bool:
    wanted = json.loads(json.dumps(dataclasses.asdict(config)))
    return results.get("config") == wanted


def run_setting(runs: Path, setting: str, world_seed: int) -> dict[str, Any]:
    """The protocol's ``results.json`` for one setting and world, run unless it is there."""
    config = _config(setting, world_seed)
    folder = runs / f"ws{world_seed}" / setting
    done = folder / "results.json"
    if done.exists():
        results = json.loads(done.read_text())
        if _same_settings(results, config):
            return results
        done.unlink()  # other settings: run again
    first = runs / f"ws{world_seed}" / next(iter(SETTINGS))
    folder.mkdir(parents=True, exist_ok=True)
    if folder != first:
        for run in first.glob("*.run"):  # the renders of the first setting, read not redone
            link = folder / run.name
            if not link.exists():
                link.symlink_to(run.resolve())
    return run_outdoor_experiment(config, folder, progress=False, figures=False)


def condition_errors(results: dict[str, Any], regression: str) -> dict[str, float]:
    """SFA's MAE per test condition: the mean of x and y, % of the range, all test frames."""
    found = results["methods"]["hierarchical_sfa"][regression]
    return {c: float(np.mean(entry["all"]["mae_percent"])) for c, entry in found.items()}


def summarise(per_seed: dict[str, list[dict[str, Any]]], conditions: list[str]) -> dict:
    """Rows of the study: per setting, SFA's largest ``eta_phi`` and per regression each
    condition's MAE and the mean over the changed conditions, as means over the worlds with
    their intervals (and the values per world, in the order of ``per_seed``)."""
    changed = [c for c in conditions if c != "after"]
    rows: dict[str, Any] = {}
    for setting, worlds in per_seed.items():
        row: dict[str, Any] = {
            "changes": json.loads(json.dumps(SETTINGS[setting])),
            "max_eta_phi": mean_entry([w["max_eta_phi"] for w in worlds]),
        }
        for regression in REGRESSIONS:
            errors = [w[regression] for w in worlds]
            values = {c: [e[c] for e in errors] for c in conditions}
            values["changed_mean"] = [float(np.mean([e[c] for c in changed])) for e in errors]
            row[regression] = {c: mean_entry(v) for c, v in values.items()}
            row[regression]["per_seed"] = {c: [round(x, 4) for x in v] for c, v in values.items()}
        rows[setting] = row
    return rows


def main(args: Args) -> None:
    per_seed: dict[str, list[dict[str, Any]]] = {s: [] for s in SETTINGS}
    for world_seed in args.world_seeds:
        for setting in SETTINGS:
            results = run_setting(args.runs, setting, world_seed)
            sfa = results["methods"]["hierarchical_sfa"]
            found = {r: condition_errors(results, r) for r in REGRESSIONS}
            found["max_eta_phi"] = float(max(sfa["eta_phi"]))
            per_seed[setting].append(found)
            print(f"world {world_seed} {setting}: {found}", flush=True)
    conditions = list(QUICK.conditions)
    study = {
        "study": "appearance_order",
        "command": "python -m eval.studies.appearance_order --world-seeds "
        + " ".join(str(s) for s in args.world_seeds),
        "settings": json.loads(json.dumps(dataclasses.asdict(QUICK))),
        "world_seeds": list(args.world_seeds),
        "conditions": conditions,
        "metric": "SFA's MAE, mean of x and y, % of the test run's range, all test frames; "
        "changed_mean: the mean over the conditions other than after; max_eta_phi: the largest "
        "variance of an output over the headings of a place (rotation invariance: 0 is best)",
        "rows": summarise(per_seed, conditions),
    }
    write_json_atomic(args.out, study)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main(tyro.cli(Args))
