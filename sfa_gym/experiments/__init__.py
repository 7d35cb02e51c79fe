"""The command line's localization runs: output folder, ``results.json``, figures, report.

The protocols themselves are :mod:`sfa_gym.protocols` (each a ``Config`` and ``score``, which the
leaderboard calls too); these modules score hierarchical SFA beside the plug-ins through them:

- :mod:`sfa_gym.experiments.grid`: ``sfa-gym localize``, the paper's simulator protocol (a grid
  of positions).
- :mod:`sfa_gym.experiments.trajectory`: ``sfa-gym localize-run``, the paper's outdoor protocol
  (a training run and a test run through a region never visited in training).
- :mod:`sfa_gym.experiments.outdoor`: the paper's outdoor experiment in the outdoor world
  (dynamics, mirror camera, vibration) and its appearance tracks.
- :mod:`sfa_gym.experiments.common`: hierarchical SFA as a feature method, scored first.
- :mod:`sfa_gym.experiments.report`, :mod:`sfa_gym.experiments.figures`: what they write.
"""

from __future__ import annotations

from sfa_gym.experiments.common import SlowFeatureMethod, score_methods
from sfa_gym.experiments.grid import PAPER_SIM_RESULTS, GridExperiment, run_grid_experiment
from sfa_gym.experiments.outdoor import OutdoorExperiment, run_outdoor_experiment
from sfa_gym.experiments.report import format_table
from sfa_gym.experiments.trajectory import (
    PAPER_OUTDOOR_RESULTS,
    TrajectoryExperiment,
    run_trajectory_experiment,
)
from sfa_gym.protocols.settings import SFASettings

__all__ = [
    "PAPER_OUTDOOR_RESULTS",
    "PAPER_SIM_RESULTS",
    "GridExperiment",
    "OutdoorExperiment",
    "SFASettings",
    "SlowFeatureMethod",
    "TrajectoryExperiment",
    "score_methods",
    "format_table",
    "run_grid_experiment",
    "run_outdoor_experiment",
    "run_trajectory_experiment",
]
