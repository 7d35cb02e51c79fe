"""``sfa-gym localize-run``: the trajectory protocol (:mod:`sfa_gym.protocols.trajectory`, the
paper's outdoor protocol on driven runs) with hierarchical SFA beside the plug-ins, written to an
output folder.

:func:`run_trajectory_experiment` records the training run and the test run into the output
folder (``train.run``, ``test.run``, reused or resumed by the next call with the same settings),
scores hierarchical SFA with the linear regression (the paper), a quadratic one and the map
decoder, and every plug-in with its regressions, each through
:func:`sfa_gym.protocols.trajectory.score` (the same code the leaderboard scores with), and
writes ``results.json`` (per method and regression ``train_test``, ``excluded``, ``visited``;
``eta_r``, ``eta_phi``), ``sfa_model.npz`` and figures.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from sfa_gym._checks import check_world_seed
from sfa_gym.experiments.common import (
    FIGURE_REGRESSOR,
    SlowFeatureMethod,
    protocol_part,
    score_methods,
)
from sfa_gym.experiments.report import check_out_folder, results_header, write_results
from sfa_gym.plugins import FeatureMethod
from sfa_gym.protocols import trajectory
from sfa_gym.protocols.settings import SFASettings
from sfa_gym.recording.cache import RunFolder
from sfa_gym.sfa.io import save_model

__all__ = ["PAPER_OUTDOOR_RESULTS", "TrajectoryExperiment", "run_trajectory_experiment"]

PAPER_OUTDOOR_RESULTS = {
    "mae_m": [0.23, 0.175],
    "mae_percent": [5.3, 3.7],
    "std_m": [0.20, 0.13],
    "eta_phi_min": 0.0,
    "eta_phi_max": 0.05,
}
"""The paper's outdoor figures: regression fitted on the training run, MAE (x, z) on the test
run in metres and in % of its range, standard deviations (m), range of eta_phi over outputs."""


@dataclass(frozen=True)
class TrajectoryExperiment(trajectory.Config):
    """Settings of ``sfa-gym localize-run``: the trajectory protocol's (:class:`trajectory.Config
    <sfa_gym.protocols.trajectory.Config>`), the world seed and the SFA network (defaults: the
    paper's outdoor experiment, scaled to the 6 x 6 m ``paper_sim`` arena)."""

    world_seed: int = 0
    """seed of the world's procedural variation (>= 0)"""
    sfa: SFASettings = SFASettings()
    """the hierarchical SFA network"""

    def validate(self) -> None:
        """Raise ValueError (or TypeError) naming the first bad setting."""
        super().validate()
        check_world_seed("world_seed", self.world_seed)
        self.sfa.validate()

    def protocol(self) -> trajectory.Config:
        """The trajectory protocol's own settings."""
        return protocol_part(self, trajectory.Config)


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
        config: the settings (checked before anything is written).
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
    protocol = config.protocol()
    runs = RunFolder(out, trajectory.requests(protocol, config.world_seed), progress=progress)
    sfa = SlowFeatureMethod(config.sfa, protocol.rotation, progress=progress)
    found = score_methods(trajectory, protocol, config.world_seed, runs, sfa, methods, progress)
    data = found[0].data
    results: dict[str, Any] = {
        **results_header("trajectory", config, data.train_pan.shape[2], config.step),
        "eval_windows": data.windows.tolist(),
        "runs": {
            "train": _run_summary(data.train_run, data.train_idx, data.train_inside),
            "test": _run_summary(data.test_run, data.test_idx, data.test_inside),
        },
        "paper": PAPER_OUTDOOR_RESULTS,
        "methods": {scores.method.name: scores.entry() for scores in found},
    }
    model = found[0].method.model_
    save_model(model, out / "sfa_model.npz")
    results = write_results(out / "results.json", results)
    if figures:
        from sfa_gym.experiments.figures import trajectory_figures

        trajectory_figures(
            out,
            exclude=config.exclude,
            model=model,
            rotation=protocol.rotation,
            train_run=data.train_run,
            test_run=data.test_run,
            train_pan=data.train_pan,
            train_xy=data.train_xy,
            test_xy=data.test_xy,
            test_time=data.test_run.time[data.test_idx],
            estimates=found[0].regressions[FIGURE_REGRESSOR].estimates,
        )
    return results
