"""Localization experiments, end to end: render, learn features, regress, measure.

- :mod:`sfa_gym.experiments.grid`: the paper's simulator protocol (a grid of positions).
- :mod:`sfa_gym.experiments.trajectory`: the paper's outdoor protocol (a training run and a
  test run through a region never visited in training).
"""

from __future__ import annotations

from sfa_gym.experiments.common import SlowFeatureMethod, format_table
from sfa_gym.experiments.grid import PAPER_SIM_RESULTS, GridExperiment, run_grid_experiment
from sfa_gym.experiments.trajectory import (
    PAPER_OUTDOOR_RESULTS,
    TrajectoryExperiment,
    run_trajectory_experiment,
)

__all__ = [
    "PAPER_OUTDOOR_RESULTS",
    "PAPER_SIM_RESULTS",
    "GridExperiment",
    "SlowFeatureMethod",
    "TrajectoryExperiment",
    "format_table",
    "run_grid_experiment",
    "run_trajectory_experiment",
]
