"""The paper's simulator localization protocol: a grid of positions.

:func:`run_grid_experiment` is the simulator protocol of Metka, Franzius & Bauer-Wersing (2013):
the rover is placed on a regular grid of positions with random headings; a training subset of
the positions, visited along a space-filling curve, and a disjoint test subset are rendered;
hierarchical SFA is fitted on every simulated rotation of the training panoramas (all windows of
one location, then the next location); a regression maps the slow features to metres. Two
evaluations are reported:

- ``paper_splits``: the paper's protocol, regression fitted and evaluated on 100 random 50/50
  splits of the test positions (MAE in % of the test set's coordinate range);
- ``train_test``: regression fitted on the training positions and applied to the test positions.

Every feature method (hierarchical SFA and the plug-ins of ``baselines/``) sees the same views,
is fitted on the same training sequence and is evaluated by the same regressions
(:func:`~sfa_gym.experiments.common.evaluate_methods`), so that the numbers compare. Estimates
are averaged over the rotated views of a location, as in the paper.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

from sfa_gym._checks import check_int, check_positive_int
from sfa_gym.experiments.common import evaluate_methods, methods_with_sfa
from sfa_gym.experiments.report import (
    check_out_folder,
    mae_dict,
    results_header,
    write_results,
)
from sfa_gym.localization import random_split_mae
from sfa_gym.plugins import FeatureMethod
from sfa_gym.protocols.settings import EnvId, SFASettings, check_choice, check_env_id
from sfa_gym.rotation import Rotation
from sfa_gym.sfa.io import save_model

__all__ = ["GridExperiment", "PAPER_SIM_RESULTS", "run_grid_experiment", "select_positions"]

PAPER_SIM_RESULTS = {"mae_percent": [1.83, 1.68], "eta_phi_max": 0.17}
"""The paper's simulator figures: MAE (x, z) in % of the range over 100 random 50/50 splits."""

GridOrder = Literal["hilbert", "serpentine", "raster"]


@dataclass(frozen=True)
class GridExperiment:
    """Settings of the grid protocol (defaults: the paper's simulator experiment)."""

    env_id: EnvId = "sfa_gym/OmniRover-v0"
    """registered env to render the panoramas with"""
    world_seed: int = 0
    """seed of the world's procedural variation"""
    grid: int = 30
    """positions per side of the square grid over the arena"""
    n_train: int = 624
    """training positions (visited in ``order``)"""
    n_test: int = 196
    """test positions, disjoint from the training positions"""
    order: GridOrder = "hilbert"
    """order of the training positions: "hilbert", "serpentine" or "raster" """
    step: int = 5
    """simulated rotation step, columns (must divide the panorama width)"""
    sfa: SFASettings = SFASettings()
    """the hierarchical SFA network"""
    n_splits: int = 100
    """random 50/50 splits of the test positions (the paper: 100)"""
    seed: int = 0
    """seed of the headings, the train/test selection and the splits"""

    @property
    def rotation(self) -> Rotation:
        """The simulated rotation every method is trained and evaluated on."""
        return Rotation(step=self.step)

    def validate(self) -> None:
        """Raise ValueError (or TypeError) naming the first bad setting."""
        check_env_id("env_id", self.env_id)
        for name in ("world_seed", "seed"):
            check_int(name, getattr(self, name))
        for name in ("grid", "n_train", "n_test", "step", "n_splits"):
            check_positive_int(name, getattr(self, name))
        check_choice("order", self.order, GridOrder)
        self.sfa.validate()
        if self.n_train + self.n_test > self.grid**2:
            raise ValueError(
                f"n_train + n_test = {self.n_train + self.n_test} positions do not fit on a "
                f"{self.grid} x {self.grid} grid ({self.grid**2} positions)"
            )
        if self.n_train < 2 or self.n_test < 4:
            raise ValueError(
                f"need n_train >= 2 and n_test >= 4, got {self.n_train} and {self.n_test}"
            )


def select_positions(config: GridExperiment, n_positions: int) -> tuple[NDArray, NDArray]:
    """Indices (into the visiting order) of the training and test positions.

    Training positions keep the visiting order, so their sequence follows the curve.
    """
    rng = np.random.default_rng(config.seed)
    chosen = rng.permutation(n_positions)
    train = np.sort(chosen[: config.n_train])
    test = np.sort(chosen[config.n_train : config.n_train + config.n_test])
    return train, test


def render_grid(config: GridExperiment, out_dir: Path, progress: bool = True) -> Any:
    """Record (or resume) the run of all grid positions into ``out_dir / "grid.run"``.

    Returns the :class:`~sfa_gym.recording.runfile.Run`.
    """
    from sfa_gym.recording.drivers import GridPositions
    from sfa_gym.recording.recorder import record

    driver = GridPositions(n=config.grid, seed=config.seed, order=config.order)
    return record(
        config.env_id,
        driver,
        out_dir / "grid.run",
        seed=config.seed,
        env_kwargs={"world_seed": config.world_seed},
        progress=progress,
    )


def run_grid_experiment(
    config: GridExperiment,
    out_dir: str | os.PathLike[str],
    methods: Sequence[tuple[FeatureMethod, Sequence[str]]] = (),
    progress: bool = True,
    figures: bool = True,
) -> dict[str, Any]:
    """Run the grid protocol; write ``results.json``, ``sfa_model.npz`` and figures.

    Args:
        config: the protocol's settings.
        out_dir: output folder (created); the rendered grid is kept there as ``grid.run`` and
            reused (or resumed) by the next call with the same settings.
        methods: extra feature methods with the regressions to evaluate them with (names of
            :func:`~sfa_gym.localization.regression.make_regressor`). Hierarchical SFA comes
            first, with the linear regression (the paper), a quadratic one and the map decoder.
        progress: progress bars.
        figures: write the PNG figures (firing maps, estimates, error map).

    Returns:
        The results, as written to ``results.json``.
    """
    config.validate()
    out = Path(out_dir)
    check_out_folder(out)
    out.mkdir(parents=True, exist_ok=True)
    run = render_grid(config, out, progress)
    poses = run.poses
    train, test = select_positions(config, len(poses))
    panoramas = np.asarray(run.panoramas)
    test_xy = poses[test, :2]
    rotation = config.rotation

    def score(regressor: str, f_test: NDArray, estimates: NDArray) -> dict[str, Any]:
        splits = random_split_mae(
            f_test, test_xy, regressor, n_splits=config.n_splits, seed=config.seed
        )
        return {"paper_splits": mae_dict(splits)}

    found = evaluate_methods(
        methods_with_sfa(config.sfa, rotation, methods, progress),
        train=(panoramas[train], poses[train, :2]),
        test=(panoramas[test], test_xy),
        rotation=rotation,
        score=score,
        progress=progress,
    )
    results: dict[str, Any] = {
        **results_header("grid", config, panoramas.shape[2], config.step),
        "paper": PAPER_SIM_RESULTS,
        "methods": found.methods,
    }
    save_model(found.model, out / "sfa_model.npz")
    results = write_results(out / "results.json", results)
    if figures:
        from sfa_gym.experiments.figures import grid_figures

        grid_figures(out, found.model, rotation, panoramas, poses, test_xy, found.estimates)
    return results
