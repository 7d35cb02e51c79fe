"""Study: the slow-feature-gradient controller under several settings, over world seeds and
episode sets.

A controller setting that helps on the 100 episodes of one world may only have moved the weave's
random phase: success on 100 episodes moves by +-5 points from that alone. This script runs each
named variant of :class:`~sfa_gym.navigation.controllers.GradientSettings` on the SFA feature
field of every ``sfa-gym navigate`` output folder given (one per world seed; the field is reused,
nothing is rendered) and on every episode set, and prints success and SPL (all pairs, interior
pairs) per (world, set) and their mean; ``--json`` writes them.

Backs docs/navigation.md (the controller's settings, the search out of stalls, the graph
features); its result files are ``published/studies/nav_controller_settings*.json``,
``nav_graph_features.json``, ``nav_hilbert_sfa*.json`` and ``nav_walk_sfa*.json`` (the command
behind each is in ``published/README.md``).

Usage (from the repository root; the folders from ``sfa-gym navigate --out results/nav
--world-seed 0``, and so on)::

    .venv/bin/python -m eval.studies.nav_controller_settings --nav results/nav results/nav_w1 \
        results/nav_w2 --sets 1000 2000 --episodes 200 \
        --variant 'before={"memory": 0.5, "window": 1.5, "probe_leg": 0}' --variant default={}
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any

import gymnasium as gym
import numpy as np
import tyro

import sfa_gym  # noqa: F401  (registers the ids)
from sfa_gym.files import write_json_atomic
from sfa_gym.navigation.controllers import GradientController, GradientSettings
from sfa_gym.navigation.evaluate import run_episodes, summarize
from sfa_gym.navigation.field import FeatureField


@dataclass(frozen=True)
class Args:
    nav: tuple[Path, ...]
    """sfa-gym navigate output folders (with field_<features>.npz and results.json)"""
    variant: Annotated[tuple[str, ...], tyro.conf.UseAppendAction]
    """name=JSON of GradientSettings fields, e.g. default={}; repeat for more variants"""
    features: str = "sfa"
    """the field the controller runs on: field_<features>.npz of each folder (sfa_graph after
    --train-order walk)"""
    sets: tuple[int, ...] = (1000, 2000)
    """first episode seed of each episode set"""
    episodes: int = 200
    """episodes per set"""
    json: Path | None = None
    """write the figures here"""


def parse_variant(text: str) -> tuple[str, GradientSettings]:
    """``name={"field": value, ...}`` -> (name, settings).

    Raises:
        ValueError: not ``name=JSON``, or the JSON is not valid GradientSettings fields.
    """
    name, sep, spec = text.partition("=")
    if not sep or not name:
        raise ValueError(f"a variant is name=JSON, got {text!r}")
    try:
        fields = json.loads(spec)
        settings = GradientSettings(**fields)
        settings.validate()
    except (json.JSONDecodeError, TypeError, ValueError) as err:
        raise ValueError(f"variant {name!r}: {err}") from None
    return name, settings


def score(
    folder: Path, settings: GradientSettings, seeds: range, desc: str, features: str = "sfa"
) -> dict[str, Any]:
    """Success and SPL of the controller on ``folder``'s field of ``features`` over ``seeds``."""
    results = json.loads((folder / "results.json").read_text())["settings"]
    field = FeatureField.load(folder / f"field_{features}.npz")
    weights = np.asarray(field.metadata["model_info"]["cost_weights"])
    env = gym.make(results["env_id"], world_seed=results["world_seed"], feature_field=field)
    controller = GradientController.for_env(env, weights, settings=settings)
    episodes = run_episodes(env, controller, seeds, desc=desc)
    env.close()
    summary = summarize(episodes)
    return {
        "world_seed": results["world_seed"],
        "env_id": results["env_id"],
        **{
            f"{key}_{group}": summary[group][key]["mean"]
            for group in ("all", "interior")
            for key in ("success", "spl")
        },
        "interior_episodes": summary["interior"]["episodes"],
    }


def main(args: Args) -> None:
    if args.episodes < 1:
        raise SystemExit(f"--episodes must be at least 1, got {args.episodes}")
    if not args.variant:
        raise SystemExit("name at least one --variant, e.g. --variant default={}")
    try:
        variants = [parse_variant(text) for text in args.variant]
    except ValueError as err:
        raise SystemExit(str(err)) from None
    field = f"field_{args.features}.npz"
    for folder in args.nav:
        if not (folder / field).exists() or not (folder / "results.json").exists():
            raise SystemExit(f"{folder} holds no {field} and results.json of sfa-gym navigate")

    rows: list[dict[str, Any]] = []
    for name, settings in variants:
        for folder in args.nav:
            for first in args.sets:
                seeds = range(first, first + args.episodes)
                desc = f"{name} {folder.name} {first}"
                row = score(folder, settings, seeds, desc, args.features)
                rows.append(
                    {"variant": name, "folder": str(folder), "features": args.features,
                     "first_seed": first, **row}
                )  # fmt: skip
                print(
                    f"{name:<12} world {row['world_seed']:>3} seeds {first}+{args.episodes}: "
                    f"success {row['success_all']:.2f} SPL {row['spl_all']:.3f} | interior "
                    f"({row['interior_episodes']}) {row['success_interior']:.2f} "
                    f"SPL {row['spl_interior']:.3f}",
                    flush=True,
                )
    print("\n| variant | success, all | SPL, all | success, interior | SPL, interior | sets |")
    print("|---|---|---|---|---|---|")
    for name, _ in variants:
        mine = [r for r in rows if r["variant"] == name]
        cells = [
            f"{np.mean([r[k] for r in mine]):.2f} ({min(r[k] for r in mine):.2f}-"
            f"{max(r[k] for r in mine):.2f})"
            for k in ("success_all", "spl_all", "success_interior", "spl_interior")
        ]
        print(f"| {name} | " + " | ".join(cells) + f" | {len(mine)} |")
    if args.json:
        payload = {"episodes": args.episodes, "rows": rows}
        write_json_atomic(args.json, payload)


if __name__ == "__main__":
    main(tyro.cli(Args))
