"""The paper's localization experiments, end to end: render, learn features, regress, measure.

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
is fitted on the same training sequence and is evaluated by the same regressions, so that the
numbers compare. Estimates are averaged over the rotated views of a location, as in the paper.
"""

from __future__ import annotations

import json
import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from sfa_gym.experiments.common import (
    FIGURE_REGRESSOR,
    SlowFeatureMethod,
    check_sfa_settings,
    fit_method,
    invariance_entry,
    mae_dict,
    methods_with_sfa,
    results_header,
    rotation_features,
)
from sfa_gym.localization import fit_predict, mae, make_regressor, random_split_mae
from sfa_gym.localization.methods import FeatureMethod
from sfa_gym.rotation import n_rotations
from sfa_gym.sfa import HierarchicalSFA

__all__ = [
    "GridExperiment",
    "PAPER_SIM_RESULTS",
    "SlowFeatureMethod",
    "run_grid_experiment",
]

PAPER_SIM_RESULTS = {"mae_percent": [1.83, 1.68], "eta_phi_max": 0.17}
"""The paper's simulator figures: MAE (x, z) in % of the range over 100 random 50/50 splits."""


@dataclass(frozen=True)
class GridExperiment:
    """Settings of the grid protocol (defaults: the paper's simulator experiment)."""

    env_id: str = "sfa_gym/OmniRover-v0"
    """registered env to render the panoramas with"""
    world_seed: int = 0
    """seed of the world's procedural variation"""
    grid: int = 30
    """positions per side of the square grid over the arena"""
    n_train: int = 624
    """training positions (visited in ``order``)"""
    n_test: int = 196
    """test positions, disjoint from the training positions"""
    order: str = "hilbert"
    """order of the training positions: "hilbert", "serpentine" or "raster" """
    step: int = 5
    """simulated rotation step, columns"""
    network: str = "paper_sim"
    """SFA architecture: a preset of :mod:`sfa_gym.sfa.presets` ("paper_sim", "paper_outdoor",
    "tiny")"""
    node_dim: int = 32
    """linear SFA dimension and output dimension of every node"""
    n_outputs: int = 8
    """slow features used (the paper: 8)"""
    weight_sharing: str = "rows"
    """nodes that share weights: "rows" (one node per row of each layer's grid: rows see sky,
    horizon or ground, while along the width every position sees the same patches once all
    rotations are trained on), "layer" (one node per layer, the paper) or "none" (one per
    position; no rotation shortcut, slow)"""
    n_splits: int = 100
    """random 50/50 splits of the test positions (the paper: 100)"""
    seed: int = 0
    """seed of the headings, the train/test selection and the splits"""

    def validate(self) -> None:
        for name in ("grid", "n_train", "n_test", "step", "node_dim", "n_outputs", "n_splits"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                raise ValueError(f"{name} must be a positive int, got {value!r}")
        if self.n_train + self.n_test > self.grid**2:
            raise ValueError(
                f"n_train + n_test = {self.n_train + self.n_test} positions do not fit on a "
                f"{self.grid} x {self.grid} grid ({self.grid**2} positions)"
            )
        if self.n_train < 2 or self.n_test < 4:
            raise ValueError(
                f"need n_train >= 2 and n_test >= 4, got {self.n_train} and {self.n_test}"
            )
        check_sfa_settings(self)


def select_positions(config: GridExperiment, n_positions: int) -> tuple[NDArray, NDArray]:
    """Indices (into the visiting order) of the training and test positions.

    Training positions keep the visiting order, so their sequence follows the curve.
    """
    rng = np.random.default_rng(config.seed)
    chosen = rng.permutation(n_positions)
    train = np.sort(chosen[: config.n_train])
    test = np.sort(chosen[config.n_train : config.n_train + config.n_test])
    return train, test


def render_grid(config: GridExperiment, out_dir: Path, progress: bool = True):
    """Record (or resume) the run of all grid positions.

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
    """Run the grid protocol; write ``results.json`` and figures into ``out_dir``.

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
    out.mkdir(parents=True, exist_ok=True)
    run = render_grid(config, out, progress)
    poses = run.poses
    train, test = select_positions(config, len(poses))
    panoramas = np.asarray(run.panoramas)
    train_pan, test_pan = panoramas[train], panoramas[test]
    train_xy, test_xy = poses[train, :2], poses[test, :2]

    sfa, entries = methods_with_sfa(config, methods, progress)
    results: dict[str, Any] = {
        **results_header("grid", config, panoramas.shape[2]),
        "paper": PAPER_SIM_RESULTS,
        "methods": {},
    }
    sfa_outputs: dict[str, NDArray] = {}
    for method, regressors in entries:
        fitted = fit_method(method, train_pan, config.step)
        f_train = rotation_features(
            fitted, train_pan, config.step, f"{method.name} train", progress
        )
        f_test = rotation_features(fitted, test_pan, config.step, f"{method.name} test", progress)
        entry = invariance_entry(f_train)
        for name in dict.fromkeys(regressors):
            splits = random_split_mae(
                f_test, test_xy, name, n_splits=config.n_splits, seed=config.seed
            )
            estimates = fit_predict(make_regressor(name), f_train, train_xy, f_test)
            entry[name] = {
                "paper_splits": mae_dict(splits),
                "train_test": mae_dict(mae(estimates, test_xy)),
            }
            if method is sfa and name == FIGURE_REGRESSOR:
                sfa_outputs["estimates"] = estimates
        results["methods"][method.name] = entry
        if method is sfa:
            sfa_outputs["model"] = fitted.model_
    fitted_sfa = sfa_outputs["model"]
    fitted_sfa.save(out / "sfa_model.npz")
    (out / "results.json").write_text(json.dumps(results, indent=2) + "\n")
    if figures:
        _grid_figures(out, fitted_sfa, panoramas, poses, test_xy, sfa_outputs["estimates"], config)
    return results


def _grid_figures(
    out: Path,
    model: HierarchicalSFA,
    panoramas: NDArray[np.uint8],
    poses: NDArray[np.float64],
    test_xy: NDArray[np.float64],
    estimates: NDArray[np.float64],
    config: GridExperiment,
) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from sfa_gym.localization import plots

    # Firing maps over every grid position, at the views nearest 0, 90, 180 and 270 degrees.
    width = panoramas.shape[2]
    n_rot = n_rotations(width, config.step)
    ks = sorted({round(q * n_rot / 4) % n_rot for q in range(4)})
    phis = np.array([2 * np.pi * k * config.step / width for k in ks])
    outputs = np.stack(
        [model.transform(np.roll(panoramas, -k * config.step, axis=2)) for k in ks], axis=1
    )
    fig, _ = plots.firing_maps(outputs, poses[:, :2], phis=phis, n_outputs=4)
    fig.savefig(out / "firing_maps.png", dpi=110, bbox_inches="tight")
    plt.close(fig)
    fig, _ = plots.estimate_vs_truth(estimates, test_xy)
    fig.savefig(out / "estimates.png", dpi=110, bbox_inches="tight")
    plt.close(fig)
    fig, _ = plots.error_map(estimates, test_xy)
    fig.savefig(out / "error_map.png", dpi=110, bbox_inches="tight")
    plt.close(fig)
