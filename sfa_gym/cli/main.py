"""The ``sfa-gym`` command line.

``sfa-gym record``: drive the rover along a scripted trajectory and record the run (panoramas,
poses, time, actions), with a panorama strip and a trajectory plot next to it.

``sfa-gym localize``: the paper's simulator experiment (grid protocol), hierarchical SFA beside
the baseline methods of a folder of plug-in files, results as JSON, a table and figures.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

DRIVERS = ("lawnmower", "loop", "randomwalk", "grid")


def _make_driver(name: str, args: argparse.Namespace) -> Any:
    from sfa_gym.recording import drivers

    if name == "lawnmower":
        return drivers.LawnMowerDriver(spacing=args.spacing, spin=args.spin)
    if name == "loop":
        return drivers.LoopDriver()
    if name == "randomwalk":
        return drivers.RandomWalkDriver(turn_probability=args.turn_probability)
    return drivers.GridPositions(n=args.grid, seed=args.seed, order="hilbert")


def panorama_strip(panoramas: Any, n: int = 8) -> np.ndarray:
    """``n`` panoramas evenly spaced over a run, stacked top to bottom with 2 px gaps."""
    idx = np.unique(np.linspace(0, len(panoramas) - 1, n).round().astype(int))
    rows = []
    for i in idx:
        rows.append(np.asarray(panoramas[int(i)]))
        rows.append(np.full((2, rows[-1].shape[1], 3), 255, dtype=np.uint8))
    return np.concatenate(rows[:-1])


def _save_png(path: Path, rgb: np.ndarray, scale: int = 2) -> None:
    import cv2

    big = cv2.resize(rgb, None, fx=scale, fy=scale, interpolation=cv2.INTER_NEAREST)
    if not cv2.imwrite(str(path), cv2.cvtColor(big, cv2.COLOR_RGB2BGR)):
        raise OSError(f"could not write {path}")


def cmd_record(args: argparse.Namespace) -> int:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from sfa_gym.localization.plots import trajectory
    from sfa_gym.recording.recorder import record

    out = Path(args.out)
    run = record(
        args.env,
        _make_driver(args.driver, args),
        out,
        n_steps=args.steps,
        seed=args.seed,
        env_kwargs={"world_seed": args.world_seed},
        overwrite=args.overwrite,
        progress=not args.quiet,
    )
    strip = out.with_name(out.stem + "_panoramas.png")
    _save_png(strip, panorama_strip(run.panoramas))
    fig, _ = trajectory(run.poses, bounds=tuple(run.metadata.get("arena_bounds") or ()) or None)
    plot = out.with_name(out.stem + "_trajectory.png")
    fig.savefig(plot, dpi=110, bbox_inches="tight")
    plt.close(fig)
    print(f"recorded {len(run)} samples into {out}")
    print(f"wrote {strip} and {plot}")
    return 0


def cmd_localize(args: argparse.Namespace) -> int:
    from sfa_gym.experiments import GridExperiment, run_grid_experiment

    config = _settings(GridExperiment, args, env_id=args.env)
    config.validate()
    results = run_grid_experiment(config, args.out, _baselines(args), progress=not args.quiet)
    return _report(results, args.out)


def cmd_localize_run(args: argparse.Namespace) -> int:
    from sfa_gym.experiments import TrajectoryExperiment, run_trajectory_experiment

    config = _settings(
        TrajectoryExperiment,
        args,
        env_id=args.env,
        exclude=None if args.no_exclude else tuple(args.exclude),
    )
    config.validate()
    results = run_trajectory_experiment(config, args.out, _baselines(args), progress=not args.quiet)
    return _report(results, args.out)


def _settings(cls: type, args: argparse.Namespace, **given: Any) -> Any:
    """A protocol's settings dataclass from the options of the same names, and ``given``."""
    names = {f.name for f in dataclasses.fields(cls)} - set(given)
    return cls(**{name: getattr(args, name) for name in names if hasattr(args, name)}, **given)


def _add_sfa_options(parser: argparse.ArgumentParser, defaults: Any) -> None:
    """Options of the hierarchical SFA network, shared by both protocols."""
    from sfa_gym.experiments.common import NETWORKS, WEIGHT_SHARING

    parser.add_argument("--network", default=defaults.network, choices=sorted(NETWORKS))
    parser.add_argument("--node-dim", type=int, default=defaults.node_dim)
    parser.add_argument("--n-outputs", type=int, default=defaults.n_outputs)
    parser.add_argument(
        "--weight-sharing",
        default=defaults.weight_sharing,
        choices=sorted(WEIGHT_SHARING),
        help="one node per grid row (rows), per layer (layer, the paper) or per position (none)",
    )


def _baselines(args: argparse.Namespace) -> list[tuple[Any, tuple[str, ...]]]:
    """The feature methods of the baselines folder, each with the linear regression, the
    regression it is paired with and the ones it lists in ``extra_regressors``."""
    from sfa_gym.localization.methods import list_method_files, load_method_file

    folder = None if args.no_baselines else _baselines_folder(args.baselines)
    methods = []
    if folder is not None:
        for path in list_method_files(folder):
            method = load_method_file(path)()
            regressors = ("linear", getattr(method, "regressor", "linear"))
            methods.append((method, regressors + tuple(getattr(method, "extra_regressors", ()))))
    return methods


def _report(results: dict[str, Any], out: str) -> int:
    from sfa_gym.experiments import format_table

    table = format_table(results)
    Path(out, "results.txt").write_text(table + "\n")
    print(table)
    print(f"results in {Path(out) / 'results.json'}; figures in {out}")
    return 0


def _baselines_folder(given: str | None) -> Path | None:
    if given is not None:
        if not Path(given).is_dir():
            raise SystemExit(f"error: --baselines {given!r} is not a folder")
        return Path(given)
    # a checkout has baselines/ next to the package; an installed wheel has none
    default = Path(__file__).resolve().parents[1] / "baselines"
    return default if default.is_dir() else None


def build_parser() -> argparse.ArgumentParser:
    from sfa_gym.experiments import GridExperiment

    parser = argparse.ArgumentParser(prog="sfa-gym", description=__doc__.split("\n\n")[0])
    sub = parser.add_subparsers(dest="command", required=True)

    rec = sub.add_parser("record", help="record a run of the rover along a scripted trajectory")
    rec.add_argument("--env", default="sfa_gym/OmniRover-v0", help="registered env id")
    rec.add_argument("--driver", choices=DRIVERS, default="lawnmower")
    rec.add_argument("--steps", type=int, default=None, help="samples (default: until done)")
    rec.add_argument("--out", required=True, help="run directory, ending in .run")
    rec.add_argument("--seed", type=int, default=0)
    rec.add_argument("--world-seed", type=int, default=0)
    rec.add_argument("--spacing", type=float, default=0.5, help="lawn-mower row spacing (m)")
    rec.add_argument("--spin", type=float, default=0.0, help="extra spin at row ends (rad)")
    rec.add_argument("--turn-probability", type=float, default=0.5, help="random walk")
    rec.add_argument("--grid", type=int, default=30, help="grid positions per side")
    rec.add_argument("--overwrite", action="store_true", help="replace an existing run")
    rec.add_argument("--quiet", action="store_true", help="no progress bar")
    rec.set_defaults(func=cmd_record)

    defaults = GridExperiment()
    loc = sub.add_parser("localize", help="the paper's simulator localization experiment")
    loc.add_argument("--out", required=True, help="output folder")
    loc.add_argument("--env", default=defaults.env_id)
    loc.add_argument("--world-seed", type=int, default=defaults.world_seed)
    loc.add_argument("--grid", type=int, default=defaults.grid)
    loc.add_argument("--n-train", type=int, default=defaults.n_train)
    loc.add_argument("--n-test", type=int, default=defaults.n_test)
    loc.add_argument("--order", default=defaults.order, choices=("hilbert", "serpentine", "raster"))
    loc.add_argument("--step", type=int, default=defaults.step)
    _add_sfa_options(loc, defaults)
    loc.add_argument("--n-splits", type=int, default=defaults.n_splits)
    loc.add_argument("--seed", type=int, default=defaults.seed)
    loc.add_argument("--baselines", default=None, help="folder of feature-method files")
    loc.add_argument("--no-baselines", action="store_true", help="hierarchical SFA only")
    loc.add_argument("--quiet", action="store_true", help="no progress bars")
    loc.set_defaults(func=cmd_localize)

    from sfa_gym.experiments import TrajectoryExperiment

    traj = TrajectoryExperiment()
    run = sub.add_parser(
        "localize-run",
        help="the paper's outdoor protocol: fit on a training run, test on a separate run "
        "through a region never visited in training",
    )
    run.add_argument("--out", required=True, help="output folder")
    run.add_argument("--env", default=traj.env_id)
    run.add_argument("--world-seed", type=int, default=traj.world_seed)
    run.add_argument("--spacing", type=float, default=traj.spacing, help="training sweep rows (m)")
    run.add_argument("--spin", type=float, default=traj.spin, help="spin at row ends (rad)")
    run.add_argument(
        "--exclude",
        type=float,
        nargs=4,
        default=list(traj.exclude or ()),
        metavar=("XMIN", "XMAX", "YMIN", "YMAX"),
        help="region the training run never enters (m)",
    )
    run.add_argument("--no-exclude", action="store_true", help="training run visits everything")
    run.add_argument("--frame-every", type=int, default=traj.frame_every)
    run.add_argument("--eval-rotations", type=int, default=traj.eval_rotations)
    _add_sfa_options(run, traj)
    run.add_argument("--seed", type=int, default=traj.seed)
    run.add_argument("--baselines", default=None, help="folder of feature-method files")
    run.add_argument("--no-baselines", action="store_true", help="hierarchical SFA only")
    run.add_argument("--quiet", action="store_true", help="no progress bars")
    run.set_defaults(func=cmd_localize_run)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except (ValueError, FileNotFoundError) as error:
        print(f"error: {error}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
