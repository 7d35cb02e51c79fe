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

import dataclasses
import json
import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray
from tqdm.auto import tqdm

import sfa_gym
from sfa_gym.localization import eta_phi, eta_r, fit_predict, mae, make_regressor, random_split_mae
from sfa_gym.localization.methods import FeatureMethod
from sfa_gym.rotation import n_rotations, rotated_views
from sfa_gym.sfa import HierarchicalSFA, presets

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
        if self.network not in NETWORKS:
            raise ValueError(f"network must be one of {sorted(NETWORKS)}, got {self.network!r}")


NETWORKS = {
    "paper_sim": lambda h, w, d: presets.paper_sim(dim=d, out_dim=d),
    "paper_outdoor": lambda h, w, d: presets.paper_outdoor(dim=d, out_dim=d),
    "tiny": lambda h, w, d: presets.tiny(height=h, width=w, dim=d, out_dim=d),
}


class SlowFeatureMethod:
    """Hierarchical SFA as a feature method: fitted on all simulated rotations of a sequence of
    panoramas (:meth:`HierarchicalSFA.fit_rotations`), regressed linearly as in the paper."""

    name = "hierarchical_sfa"
    regressor = "linear"

    def __init__(
        self,
        network: str = "paper_sim",
        node_dim: int = 32,
        n_outputs: int = 8,
        step: int = 5,
        progress: bool = True,
    ) -> None:
        self.network = network
        self.node_dim = node_dim
        self.n_outputs = n_outputs
        self.step = step
        self.progress = progress

    def fit_rotations(self, panoramas: NDArray[np.uint8]) -> SlowFeatureMethod:
        """Fit on ``panoramas (L, H, W, 3)`` in visiting order, with all their rotations."""
        _, h, w, _ = panoramas.shape
        layers = NETWORKS[self.network](h, w, self.node_dim)
        self.model_ = HierarchicalSFA(layers, n_outputs=self.n_outputs, progress=self.progress)
        self.model_.fit_rotations(panoramas, step=self.step)
        self.input_shape_ = self.model_.input_shape_
        return self

    def fit(self, views: NDArray[np.uint8], sequence_ids: Any = None) -> SlowFeatureMethod:
        _, h, w, _ = views.shape
        layers = NETWORKS[self.network](h, w, self.node_dim)
        self.model_ = HierarchicalSFA(layers, n_outputs=self.n_outputs, progress=self.progress)
        self.model_.fit(views, sequence_ids)
        self.input_shape_ = self.model_.input_shape_
        return self

    def transform(self, views: NDArray[np.uint8]) -> NDArray[np.float64]:
        return self.model_.transform(views)


def _rotation_features(
    method: FeatureMethod, panoramas: NDArray[np.uint8], step: int, desc: str, progress: bool
) -> NDArray[np.float64]:
    """Features of every rotated view, ``(L, K, k)``, a few locations at a time."""
    n_rot = n_rotations(panoramas.shape[2], step)
    per_chunk = max(1, 4096 // n_rot)
    out = []
    for i in tqdm(range(0, len(panoramas), per_chunk), desc=desc, disable=not progress):
        block = panoramas[i : i + per_chunk]
        views = np.concatenate([rotated_views(p, step)[0] for p in block])
        out.append(
            np.asarray(method.transform(views), dtype=np.float64).reshape(len(block), n_rot, -1)
        )
    return np.concatenate(out)


def _fit_method(method: FeatureMethod, panoramas: NDArray[np.uint8], step: int) -> FeatureMethod:
    if hasattr(method, "fit_rotations"):
        return method.fit_rotations(panoramas)
    views = np.concatenate([rotated_views(p, step)[0] for p in panoramas])
    return method.fit(views)


def _mae_dict(result: Any) -> dict[str, list[float]]:
    return {
        "mae_m": np.round(result.mae_m, 5).tolist(),
        "mae_percent": np.round(result.mae_percent, 4).tolist(),
        "std_m": np.round(result.std_m, 5).tolist(),
        "range_m": np.round(result.range_m, 5).tolist(),
    }


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
    """Record (or resume) the run of all grid positions; returns the :class:`~sfa_gym.runs.Run`."""
    from sfa_gym.drivers import GridPositions
    from sfa_gym.runs import record

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
            first, with the linear regression (the paper) and a quadratic one.
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

    sfa = SlowFeatureMethod(
        config.network, config.node_dim, config.n_outputs, config.step, progress=progress
    )
    entries: list[tuple[FeatureMethod, Sequence[str]]] = [(sfa, ("linear", "quadratic"))]
    entries += list(methods)
    results: dict[str, Any] = {
        "format": "sfa-gym-localization",
        "version": 1,
        "sfa_gym_version": sfa_gym.__version__,
        "protocol": "grid",
        "config": dataclasses.asdict(config),
        "n_rotations": n_rotations(panoramas.shape[2], config.step),
        "paper": PAPER_SIM_RESULTS,
        "methods": {},
    }
    sfa_outputs: dict[str, NDArray] = {}
    for method, regressors in entries:
        fitted = _fit_method(method, train_pan, config.step)
        f_train = _rotation_features(
            fitted, train_pan, config.step, f"{method.name} train", progress
        )
        f_test = _rotation_features(fitted, test_pan, config.step, f"{method.name} test", progress)
        entry: dict[str, Any] = {
            "eta_r": np.round(eta_r(f_train), 4).tolist(),
            "eta_phi": np.round(eta_phi(f_train), 4).tolist(),
            "n_features": int(f_train.shape[2]),
        }
        for name in dict.fromkeys(regressors):
            splits = random_split_mae(
                f_test, test_xy, name, n_splits=config.n_splits, seed=config.seed
            )
            estimates = fit_predict(make_regressor(name), f_train, train_xy, f_test)
            entry[name] = {
                "paper_splits": _mae_dict(splits),
                "train_test": _mae_dict(mae(estimates, test_xy)),
            }
            if method is sfa and name == "linear":
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
    fig, _ = plots.firing_maps(outputs, poses[:, :2], phis=np.degrees(phis), n_outputs=4)
    fig.savefig(out / "firing_maps.png", dpi=110, bbox_inches="tight")
    plt.close(fig)
    fig, _ = plots.estimate_vs_truth(estimates, test_xy)
    fig.savefig(out / "estimates.png", dpi=110, bbox_inches="tight")
    plt.close(fig)
    fig, _ = plots.error_map(estimates, test_xy)
    fig.savefig(out / "error_map.png", dpi=110, bbox_inches="tight")
    plt.close(fig)


def format_table(results: dict[str, Any]) -> str:
    """A plain-text table of the MAE (% of the range) per method and regression."""
    lines = [
        f"{'method':<20} {'regression':<10} {'splits x %':>10} {'splits y %':>10} "
        f"{'test x %':>9} {'test y %':>9} {'max eta_phi':>11}"
    ]
    for name, entry in results["methods"].items():
        for reg, value in entry.items():
            if not isinstance(value, dict):
                continue
            s = value["paper_splits"]["mae_percent"]
            t = value["train_test"]["mae_percent"]
            lines.append(
                f"{name:<20} {reg:<10} {s[0]:>10.2f} {s[1]:>10.2f} {t[0]:>9.2f} {t[1]:>9.2f} "
                f"{max(entry['eta_phi']):>11.3f}"
            )
    paper = results["paper"]
    lines.append(
        f"{'paper (2013)':<20} {'linear':<10} {paper['mae_percent'][0]:>10.2f} "
        f"{paper['mae_percent'][1]:>10.2f} {'-':>9} {'-':>9} {paper['eta_phi_max']:>11.3f}"
    )
    return "\n".join(lines)
