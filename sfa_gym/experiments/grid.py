"""``sfa-gym localize``: the grid protocol (:mod:`sfa_gym.protocols.grid`, the paper's simulator
protocol) with hierarchical SFA beside the plug-ins, written to an output folder.

:func:`run_grid_experiment` renders the grid once into the output folder (``grid.run``, reused or
resumed by the next call with the same settings), scores hierarchical SFA with the linear
regression (the paper), a quadratic one and the map decoder, and every plug-in with its
regressions, each through :func:`sfa_gym.protocols.grid.score` (the same code the leaderboard
scores with), and writes ``results.json``, ``sfa_model.npz`` and figures. Two evaluations are
reported per regression by default:

- ``paper_splits``: the paper's protocol, regression fitted and evaluated on 100 random 50/50
  splits of the test positions (MAE in % of the test set's coordinate range);
- ``train_test``: regression fitted on the training positions and applied to the test positions.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from sfa_gym._checks import check_world_seed
from sfa_gym.experiments.common import (
    FIGURE_REGRESSOR,
    SlowFeatureMethod,
    protocol_part,
    score_methods,
)
from sfa_gym.experiments.report import check_out_folder, results_header, write_results
from sfa_gym.plugins import FeatureMethod
from sfa_gym.protocols import grid
from sfa_gym.protocols.settings import SFASettings
from sfa_gym.recording.cache import RunFolder
from sfa_gym.sfa.io import save_model

__all__ = ["GridExperiment", "PAPER_SIM_RESULTS", "run_grid_experiment"]

PAPER_SIM_RESULTS = {"mae_percent": [1.83, 1.68], "eta_phi_max": 0.17}
"""The paper's simulator figures: MAE (x, z) in % of the range over 100 random 50/50 splits."""


@dataclass(frozen=True)
class GridExperiment(grid.Config):
    """Settings of ``sfa-gym localize``: the grid protocol's (:class:`grid.Config
    <sfa_gym.protocols.grid.Config>`), the world seed and the SFA network (defaults: the
    paper's simulator experiment)."""

    world_seed: int = 0
    """seed of the world's procedural variation (>= 0)"""
    sfa: SFASettings = SFASettings()
    """the hierarchical SFA network"""

    def validate(self) -> None:
        """Raise ValueError (or TypeError) naming the first bad setting."""
        super().validate()
        check_world_seed("world_seed", self.world_seed)
        self.sfa.validate()

    def protocol(self) -> grid.Config:
        """The grid protocol's own settings."""
        return protocol_part(self, grid.Config)


def run_grid_experiment(
    config: GridExperiment,
    out_dir: str | os.PathLike[str],
    methods: Sequence[tuple[FeatureMethod, Sequence[str]]] = (),
    progress: bool = True,
    figures: bool = True,
) -> dict[str, Any]:
    """Run the grid protocol; write ``results.json``, ``sfa_model.npz`` and figures.

    Args:
        config: the settings (checked before anything is written).
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
    protocol = config.protocol()
    runs = RunFolder(out, grid.requests(protocol, config.world_seed), progress=progress)
    sfa = SlowFeatureMethod(config.sfa, protocol.rotation, progress=progress)
    found = score_methods(grid, protocol, config.world_seed, runs, sfa, methods, progress)
    data = found[0].data
    results: dict[str, Any] = {
        **results_header("grid", config, data.panoramas.shape[2], config.step),
        "paper": PAPER_SIM_RESULTS,
        "methods": {scores.method.name: scores.entry() for scores in found},
    }
    model = found[0].method.model_
    save_model(model, out / "sfa_model.npz")
    results = write_results(out / "results.json", results)
    if figures:
        from sfa_gym.experiments.figures import grid_figures

        estimates = found[0].regressions[FIGURE_REGRESSOR].estimates
        test_xy = data.positions[data.test]
        grid_figures(
            out, model, protocol.rotation, data.panoramas, data.positions, test_xy, estimates
        )
    return results
