"""The paper's outdoor localization protocol on driven runs: a training run and a test run.

:func:`run_trajectory_experiment` follows section 3.2 of Metka, Franzius & Bauer-Wersing (2013):
the rover is driven along a grid-like lawn-mower trajectory (the training run) that never enters
one corner of the arena, then along a different trajectory (the test run, by default rectangular
loops) that passes through that corner. Hierarchical SFA is fitted on every simulated rotation of
the training frames, in time order; a regression from the slow features to the ground-truth
positions is fitted on the training run and applied to the test run ("in contrast to the
simulation we compute the regression [...] for the training data and apply it to SFA outputs on
the test set"). Reported per feature method and regression:

- ``train_test``: MAE over every evaluated test frame, in metres and in % of the test run's
  coordinate range, with the standard deviation of the absolute errors;
- ``excluded`` / ``visited``: the same over the test frames inside / outside the region never
  visited in training (percentages still relative to the whole test run's range), where the
  paper notes higher errors;
- ``eta_r`` / ``eta_phi``: position and orientation variance of the features over the training
  frames and their evaluation windows.

To bound the cost, every ``frame_every``-th training frame is a training location (all its
rotations train SFA) and features for the regression are computed for ``eval_rotations`` evenly
spaced rotation windows per frame; estimates are averaged over the windows of a frame, as in
the paper.
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

from sfa_gym._checks import check_int, check_positive_int, is_number
from sfa_gym.experiments.common import evaluate_methods, methods_with_sfa
from sfa_gym.experiments.report import (
    check_out_folder,
    mae_dict,
    results_header,
    write_results,
)
from sfa_gym.geometry import check_rectangle, in_rectangle
from sfa_gym.localization import mae
from sfa_gym.plugins import FeatureMethod
from sfa_gym.protocols.settings import EnvId, SFASettings, check_choice, check_env_id
from sfa_gym.rotation import Rotation, check_step, spread_indices
from sfa_gym.sfa.io import save_model

__all__ = [
    "PAPER_OUTDOOR_RESULTS",
    "TrajectoryExperiment",
    "run_trajectory_experiment",
    "trajectory_drivers",
]

PAPER_OUTDOOR_RESULTS = {
    "mae_m": [0.23, 0.175],
    "mae_percent": [5.3, 3.7],
    "std_m": [0.20, 0.13],
    "eta_phi_min": 0.0,
    "eta_phi_max": 0.05,
}
"""The paper's outdoor figures: regression fitted on the training run, MAE (x, z) on the test
run in metres and in % of its range, standard deviations (m), range of eta_phi over outputs."""

TestDriver = Literal["loop", "sweep", "random_walk"]
Pattern = Literal["rows", "columns", "grid"]


@dataclass(frozen=True)
class TrajectoryExperiment:
    """Settings of the trajectory protocol (defaults: the paper's outdoor experiment, scaled to
    the 6 x 6 m ``paper_sim`` arena)."""

    env_id: EnvId = "sfa_gym/OmniRover-v0"
    """registered env to drive in and render the panoramas with"""
    world_seed: int = 0
    """seed of the world's procedural variation"""
    panorama: tuple[int, int] | None = None
    """(height, width) of the panoramas in pixels, replacing the env's camera (e.g. small
    panoramas for quick runs); None: the env's own camera"""
    spacing: float = 0.5
    """training run: distance between the lawn-mower rows, m"""
    pattern: Pattern = "grid"
    """training run: "rows" (along x), "columns" (along y) or "grid" (rows, then columns, so that
    both axes are travelled equally, as in the paper)"""
    spin: float = 0.0
    """training run: extra rotation on the spot at each row end, rad (0: none)"""
    margin: float = 0.5
    """training run: distance kept from the arena bounds, m"""
    exclude: tuple[float, float, float, float] | None = (-3.0, -1.5, -3.0, -1.5)
    """rectangle (xmin, xmax, ymin, ymax), m, never entered by the training run (the paper's
    south-west test region); None: the training run covers the whole arena"""
    train_steps: int | None = None
    """largest number of training frames recorded (None: until the sweep is done)"""
    test_driver: TestDriver = "loop"
    """test run: "loop" (rectangular loops ``test_insets`` m from the bounds, through every
    corner), "sweep" (the lawn-mower pattern shifted by half a spacing, not excluding anything)
    or "random_walk" (needs ``test_steps``)"""
    test_insets: tuple[float, ...] = (0.5, 1.0, 1.5)
    """test run "loop": distance of each loop from the arena bounds, m"""
    test_steps: int | None = None
    """largest number of test frames recorded (None: until the test driver is done)"""
    frame_every: int = 5
    """every n-th training frame is a training location (bounds the cost of SFA)"""
    test_every: int = 1
    """every n-th test frame is evaluated"""
    step: int = 5
    """simulated rotation step, columns (must divide the panorama width)"""
    eval_rotations: int | None = 14
    """evenly spaced rotation windows per frame whose features the regression is fitted on and
    averages over (at most all windows); None: all windows"""
    sfa: SFASettings = SFASettings()
    """the hierarchical SFA network"""
    seed: int = 0
    """seed of the env resets and the drivers of both runs"""

    @property
    def rotation(self) -> Rotation:
        """The simulated rotation every method is trained and evaluated on."""
        return Rotation(step=self.step)

    def validate(self) -> None:
        """Raise ValueError (or TypeError) naming the first bad setting."""
        check_env_id("env_id", self.env_id)
        for name in ("frame_every", "test_every", "step"):
            check_positive_int(name, getattr(self, name))
        for name in ("world_seed", "seed"):
            check_int(name, getattr(self, name))
        for name in ("train_steps", "test_steps"):
            value = getattr(self, name)
            if value is not None and (check_positive_int(name, value) < 2):
                raise ValueError(f"{name} must be None or an int >= 2, got {value!r}")
        if self.eval_rotations is not None:
            check_positive_int("eval_rotations", self.eval_rotations)
        if self.panorama is not None:
            if not isinstance(self.panorama, tuple | list) or len(self.panorama) != 2:
                raise ValueError(
                    f"panorama must be None or (height, width) in pixels, got {self.panorama!r}"
                )
            for value in self.panorama:
                check_positive_int("panorama", value)
            check_step(self.panorama[1], self.step)
        for name in ("spacing", "margin"):
            value = getattr(self, name)
            if not is_number(value) or not math.isfinite(value) or value < 0:
                raise ValueError(f"{name} must be a non-negative number of metres, got {value!r}")
        if self.spacing == 0:
            raise ValueError("spacing must be positive (metres between the lawn-mower rows)")
        if not is_number(self.spin) or not math.isfinite(self.spin):
            raise ValueError(f"spin must be a finite angle in radians, got {self.spin!r}")
        check_choice("pattern", self.pattern, Pattern)
        if self.exclude is not None:
            check_rectangle("exclude", self.exclude)
        check_choice("test_driver", self.test_driver, TestDriver)
        if self.test_driver == "random_walk" and self.test_steps is None:
            raise ValueError('test_driver "random_walk" never finishes: set test_steps')
        if self.test_driver == "loop":
            insets = self.test_insets
            if (
                not isinstance(insets, tuple | list)
                or not insets
                or not all(is_number(i) and math.isfinite(i) and i >= 0 for i in insets)
            ):
                raise ValueError(
                    f"test_insets must be a non-empty tuple of distances >= 0 (m), got {insets!r}"
                )
        self.sfa.validate()


def trajectory_drivers(config: TrajectoryExperiment) -> tuple[Any, Any]:
    """The drivers of the training run and of the test run that ``config`` describes.

    Returns:
        ``(train, test)``: a :class:`~sfa_gym.recording.drivers.LawnMowerDriver` (never entering
        ``config.exclude``) and the test driver named by ``config.test_driver``.
    """
    from sfa_gym.recording.drivers import LawnMowerDriver, LoopDriver, RandomWalkDriver

    train = LawnMowerDriver(
        spacing=config.spacing,
        margin=config.margin,
        pattern=config.pattern,
        spin=config.spin,
        exclude=None if config.exclude is None else tuple(map(float, config.exclude)),
    )
    if config.test_driver == "loop":
        test: Any = LoopDriver(insets=tuple(map(float, config.test_insets)))
    elif config.test_driver == "sweep":
        # between the training rows and through the excluded region
        test = LawnMowerDriver(
            spacing=config.spacing,
            margin=config.margin,
            offset=config.spacing / 2,
            pattern=config.pattern,
        )
    else:
        test = RandomWalkDriver()
    return train, test


def record_runs(config: TrajectoryExperiment, out_dir: Path, progress: bool = True):
    """Record (or resume) ``train.run`` and ``test.run`` in ``out_dir``; returns both runs."""
    from sfa_gym.recording.recorder import record

    env_kwargs: dict[str, Any] = {"world_seed": config.world_seed}
    if config.panorama is not None:
        from sfa_gym.sim.camera import PanoramaSpec

        height, width = config.panorama
        env_kwargs["panorama"] = PanoramaSpec(width=int(width), height=int(height))
    train_driver, test_driver = trajectory_drivers(config)
    runs = []
    for name, driver, n_steps in (
        ("train", train_driver, config.train_steps),
        ("test", test_driver, config.test_steps),
    ):
        runs.append(
            record(
                config.env_id,
                driver,
                out_dir / f"{name}.run",
                n_steps=n_steps,
                seed=config.seed,
                env_kwargs=env_kwargs,
                progress=progress,
            )
        )
    return runs[0], runs[1]


def _run_summary(run: Any, used: NDArray[np.intp], inside: NDArray[np.bool_]) -> dict[str, Any]:
    path_m = float(np.linalg.norm(np.diff(run.poses[:, :2], axis=0), axis=1).sum())
    return {
        "path": run.path.name,
        "n_frames": len(run),
        "n_used": int(len(used)),
        "n_used_in_excluded": int(inside.sum()),
        "duration_s": float(run.time[-1] - run.time[0]),
        "distance_m": round(path_m, 3),
        "end_reason": run.metadata.get("end_reason"),
    }


def run_trajectory_experiment(
    config: TrajectoryExperiment,
    out_dir: str | os.PathLike[str],
    methods: Sequence[tuple[FeatureMethod, Sequence[str]]] = (),
    progress: bool = True,
    figures: bool = True,
) -> dict[str, Any]:
    """Run the trajectory protocol; write ``results.json``, ``sfa_model.npz`` and figures.

    Args:
        config: the protocol's settings.
        out_dir: output folder (created); the runs are kept there as ``train.run`` and
            ``test.run`` and reused (or resumed) by the next call with the same settings.
        methods: extra feature methods with the regressions to evaluate them with (names of
            :func:`~sfa_gym.localization.regression.make_regressor`). Hierarchical SFA comes
            first, with the linear regression (the paper), a quadratic one and the map decoder.
        progress: progress bars.
        figures: write the PNG figures (trajectories, estimates, error map, firing maps).

    Returns:
        The results, as written to ``results.json``.
    """
    config.validate()
    out = Path(out_dir)
    check_out_folder(out)
    out.mkdir(parents=True, exist_ok=True)
    train_run, test_run = record_runs(config, out, progress)
    train_idx = np.arange(0, len(train_run), config.frame_every)
    test_idx = np.arange(0, len(test_run), config.test_every)
    if len(train_idx) < 2 or len(test_idx) < 2:
        raise ValueError(
            f"need at least 2 training locations and 2 test frames, got {len(train_idx)} and "
            f"{len(test_idx)}: lower frame_every/test_every or record longer runs"
        )
    train_pan = np.asarray(train_run.panoramas[train_idx])
    test_pan = np.asarray(test_run.panoramas[test_idx])
    train_xy, test_xy = train_run.positions[train_idx], test_run.positions[test_idx]
    width = train_pan.shape[2]
    rotation = config.rotation
    windows = spread_indices(rotation.n_views(width), config.eval_rotations)
    train_inside = in_rectangle(train_xy, config.exclude)
    test_inside = in_rectangle(test_xy, config.exclude)
    test_range = test_xy.max(axis=0) - test_xy.min(axis=0)

    def score(regressor: str, f_test: NDArray, estimates: NDArray) -> dict[str, Any]:
        entry: dict[str, Any] = {}
        for part, where in (("excluded", test_inside), ("visited", ~test_inside)):
            entry[part] = (
                mae_dict(mae(estimates[where], test_xy[where], coordinate_range=test_range))
                if where.any()
                else None
            )
        return entry

    found = evaluate_methods(
        methods_with_sfa(config.sfa, rotation, methods, progress),
        train=(train_pan, train_xy),
        test=(test_pan, test_xy),
        rotation=rotation,
        score=score,
        indices=windows,
        progress=progress,
    )
    results: dict[str, Any] = {
        **results_header("trajectory", config, width, config.step),
        "eval_windows": windows.tolist(),
        "runs": {
            "train": _run_summary(train_run, train_idx, train_inside),
            "test": _run_summary(test_run, test_idx, test_inside),
        },
        "paper": PAPER_OUTDOOR_RESULTS,
        "methods": found.methods,
    }
    save_model(found.model, out / "sfa_model.npz")
    results = write_results(out / "results.json", results)
    if figures:
        from sfa_gym.experiments.figures import trajectory_figures

        trajectory_figures(
            out,
            exclude=config.exclude,
            model=found.model,
            rotation=rotation,
            train_run=train_run,
            test_run=test_run,
            train_pan=train_pan,
            train_xy=train_xy,
            test_xy=test_xy,
            test_time=test_run.time[test_idx],
            estimates=found.estimates,
        )
    return results
