"""What the localization protocols write: ``results.json`` (its common head, MAE entries) and the
plain-text table of ``results.txt``."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path
from typing import Any

import sfa_gym
from sfa_gym.files import write_atomic
from sfa_gym.localization.metrics import mae_dict
from sfa_gym.rotation import n_rotations

__all__ = ["check_out_folder", "format_table", "mae_dict", "results_header", "write_results"]

FORMAT = "sfa-gym-localization"
VERSION = 1


def check_out_folder(out: Path) -> None:
    """ValueError unless ``out`` is a folder or does not exist yet (checked before writing)."""
    if out.exists() and not out.is_dir():
        raise ValueError(f"out_dir {str(out)!r} is a file; expected an output folder")


def results_header(protocol: str, config: Any, width: int, step: int) -> dict[str, Any]:
    """The common head of a protocol's ``results.json``; ``config`` is its settings dataclass
    (nested dataclasses become nested objects)."""
    return {
        "format": FORMAT,
        "version": VERSION,
        "sfa_gym_version": sfa_gym.__version__,
        "protocol": protocol,
        "config": dataclasses.asdict(config),
        "n_rotations": n_rotations(width, step),
    }


def write_results(path: Path, results: dict[str, Any]) -> dict[str, Any]:
    """Write ``results`` as indented JSON; returns what a reader gets back (tuples as lists)."""
    text = json.dumps(results, indent=2)
    write_atomic(path, lambda file: file.write((text + "\n").encode()))
    return json.loads(text)


def format_table(results: dict[str, Any]) -> str:
    """A plain-text table of the MAE per method and regression, for either protocol.

    Grid protocol: MAE in % of the range over the paper's random splits and fitted on the
    training positions. Trajectory protocol: MAE on the test run in metres and %, its standard
    deviation, and the MAE in % over the test frames in the region never visited in training.
    Outdoor protocol: per test condition, the MAE in % over the whole test run and inside the
    region never visited in training. The last row is the paper's.
    """
    if results.get("protocol") == "trajectory":
        return _format_trajectory_table(results)
    if results.get("protocol") == "outdoor":
        return _format_outdoor_table(results)
    lines = [
        f"{'method':<20} {'regression':<10} {'splits x %':>10} {'splits y %':>10} "
        f"{'test x %':>9} {'test y %':>9} {'max eta_phi':>11}"
    ]
    for name, entry in results["methods"].items():
        for reg, value in entry.items():
            if not isinstance(value, dict):
                continue
            # an evaluation left out of the config's evaluations is a "-"
            s, t = (
                [f"{v:.2f}" for v in value[part]["mae_percent"]] if part in value else ["-", "-"]
                for part in ("paper_splits", "train_test")
            )
            lines.append(
                f"{name:<20} {reg:<10} {s[0]:>10} {s[1]:>10} {t[0]:>9} {t[1]:>9} "
                f"{max(entry['eta_phi']):>11.3f}"
            )
    paper = results["paper"]
    lines.append(
        f"{'paper (2013)':<20} {'linear':<10} {paper['mae_percent'][0]:>10.2f} "
        f"{paper['mae_percent'][1]:>10.2f} {'-':>9} {'-':>9} {paper['eta_phi_max']:>11.3f}"
    )
    return "\n".join(lines)


def _trajectory_row(
    name: str,
    regression: str,
    test: dict[str, Any],
    excluded: dict[str, Any] | None,
    eta_phi_max: float,
) -> str:
    e = ("-", "-") if excluded is None else [f"{v:.2f}" for v in excluded["mae_percent"]]
    return (
        f"{name:<20} {regression:<10} {test['mae_m'][0]:>6.3f} {test['mae_m'][1]:>6.3f} "
        f"{test['mae_percent'][0]:>6.2f} {test['mae_percent'][1]:>6.2f} "
        f"{test['std_m'][0]:>6.3f} {test['std_m'][1]:>6.3f} {e[0]:>8} {e[1]:>8} "
        f"{eta_phi_max:>11.3f}"
    )


def _format_trajectory_table(results: dict[str, Any]) -> str:
    lines = [
        f"{'method':<20} {'regression':<10} {'x m':>6} {'y m':>6} {'x %':>6} {'y %':>6} "
        f"{'std x':>6} {'std y':>6} {'excl x %':>8} {'excl y %':>8} {'max eta_phi':>11}"
    ]
    for name, entry in results["methods"].items():
        for reg, value in entry.items():
            if isinstance(value, dict):
                lines.append(
                    _trajectory_row(
                        name, reg, value["train_test"], value["excluded"], max(entry["eta_phi"])
                    )
                )
    paper = results["paper"]
    lines.append(_trajectory_row("paper (2013)", "linear", paper, None, paper["eta_phi_max"]))
    return "\n".join(lines)


def _format_outdoor_table(results: dict[str, Any]) -> str:
    # the conditions as scored (several later offsets are one column each), "after" only when
    # the config names it
    asked = results["config"]["conditions"]
    first = next(v for v in results["methods"]["hierarchical_sfa"].values() if isinstance(v, dict))
    conditions = [c for c in first if c != "after" or "after" in asked]
    head = f"{'method':<20} {'regression':<10} {'max eta_phi':>11}"
    for c in conditions:
        head += f" | {c + ' x/y %':>15} {'unvisited':>13}"
    lines = [head]

    def pair(mae: dict[str, Any] | None) -> str:
        return "-" if mae is None else f"{mae['mae_percent'][0]:.2f}/{mae['mae_percent'][1]:.2f}"

    for name, entry in results["methods"].items():
        for reg, value in entry.items():
            if not isinstance(value, dict) or reg == "all_windows":
                continue
            row = f"{name:<20} {reg:<10} {max(entry['eta_phi']):>11.3f}"
            for c in conditions:
                row += f" | {pair(value[c]['all']):>15} {pair(value[c]['unvisited']):>13}"
            lines.append(row)
    every = results["methods"]["hierarchical_sfa"].get("all_windows")
    if every is not None:
        after = every["linear"]["after"]
        lines.append(
            f"{'hierarchical_sfa':<20} {'linear':<10} {'(120 windows)':>11} | "
            f"{pair(after['all']):>15} {pair(after['unvisited']):>13}"
        )
    paper = results["paper"]
    mae = {"mae_percent": paper["mae_percent"]}
    lines.append(
        f"{'paper (2013)':<20} {'linear':<10} {paper['eta_phi_max']:>11.3f} | {pair(mae):>15} "
        f"{'-':>13}"
    )
    return "\n".join(lines)
