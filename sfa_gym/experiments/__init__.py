"""Localization experiments, end to end: render, learn features, regress, measure.

- :mod:`sfa_gym.experiments.grid`: the paper's simulator protocol (a grid of positions).
"""

from __future__ import annotations

from sfa_gym.experiments.common import SlowFeatureMethod, format_table
from sfa_gym.experiments.grid import PAPER_SIM_RESULTS, GridExperiment, run_grid_experiment

__all__ = [
    "PAPER_SIM_RESULTS",
    "GridExperiment",
    "SlowFeatureMethod",
    "format_table",
    "run_grid_experiment",
]
