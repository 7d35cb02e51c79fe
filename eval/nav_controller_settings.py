"""Benchmark: the slow-feature-gradient controller under several settings, over world seeds and
episode sets.

A controller setting that helps on the 100 episodes of one world may only have moved the weave's
random phase: success on 100 episodes moves by +-5 points from that alone. This script runs each
named variant of :class:`~sfa_gym.navigation.controllers.GradientSettings` on the SFA feature
field of every ``sfa-gym navigate`` output folder given (one per world seed; the field is reused,
nothing is rendered) and on every episode set, and prints success and SPL (all pairs, interior
pairs) per (world, set) and their mean; ``--json`` writes them.

Usage (from the repository root; the folders from ``sfa-gym navigate --out results/nav
--world-seed 0``, and so on)::

    .venv/bin/python eval/nav_controller_settings.py --nav results/nav results/nav_w1 \
        results/nav_w2 --sets 1000 2000 --episodes 200 \
        --variant 'before={"memory": 0.5, "window": 1.5, "probe_leg": 0}' --variant default={}
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:  # run as a script from a checkout
    sys.path.insert(0, str(ROOT))

import gymnasium as gym  # noqa: E402
import numpy as np  # noqa: E402
from tqdm import tqdm  # noqa: E402

import sfa_gym  # noqa: E402, F401  (registers the ids)
from sfa_gym._files import write_json_atomic  # noqa: E402
from sfa_gym.navigation.controllers import GradientController, GradientSettings  # noqa: E402
from sfa_gym.navigation.evaluate import run_episode, summarize  # noqa: E402
from sfa_gym.navigation.field import FeatureField  # noqa: E402


def parse_variant(text: str) -> tuple[str, GradientSettings]:
    """``name={"field": value, ...}`` -> (name, settings)."""
    name, sep, spec = text.partition("=")
    if not sep or not name:
        raise argparse.ArgumentTypeError(f"a variant is name=JSON, got {text!r}")
    try:
        fields = json.loads(spec)
        settings = GradientSettings(**fields)
        settings.validate()
    except (json.JSONDecodeError, TypeError, ValueError) as err:
        raise argparse.ArgumentTypeError(f"variant {name!r}: {err}") from None
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
    episodes = [run_episode(env, controller, s) for s in tqdm(seeds, desc=desc, leave=False)]
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


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--nav", type=Path, nargs="+", required=True,
                        help="sfa-gym navigate output folders (with field_sfa.npz)")  # fmt: skip
    parser.add_argument("--features", default="sfa",
                        help="the field the controller runs on: field_<features>.npz of each "
                             "folder (sfa_graph after --train-order walk)")  # fmt: skip
    parser.add_argument("--sets", type=int, nargs="+", default=[1000, 2000],
                        help="first episode seed of each episode set")  # fmt: skip
    parser.add_argument("--episodes", type=int, default=200, help="episodes per set")
    parser.add_argument("--variant", type=parse_variant, action="append", required=True,
                        help='name=JSON of GradientSettings fields, e.g. default={}')  # fmt: skip
    parser.add_argument("--json", type=Path, help="write the figures here")
    args = parser.parse_args()
    if args.episodes < 1:
        parser.error(f"--episodes must be at least 1, got {args.episodes}")
    field = f"field_{args.features}.npz"
    for folder in args.nav:
        if not (folder / field).exists() or not (folder / "results.json").exists():
            parser.error(f"{folder} holds no {field} and results.json of sfa-gym navigate")

    rows: list[dict[str, Any]] = []
    for name, settings in args.variant:
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
    for name, _ in args.variant:
        mine = [r for r in rows if r["variant"] == name]
        cells = [
            f"{np.mean([r[k] for r in mine]):.2f} ({min(r[k] for r in mine):.2f}-"
            f"{max(r[k] for r in mine):.2f})"
            for k in ("success_all", "spl_all", "success_interior", "spl_interior")
        ]
        print(f"| {name} | " + " | ".join(cells) + f" | {len(mine)} |")
    if args.json:
        write_json_atomic(args.json, {"episodes": args.episodes, "rows": rows})


if __name__ == "__main__":
    main()
