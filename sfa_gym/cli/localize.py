"""``sfa-gym localize``, ``localize-run`` and ``localize-outdoor``: the localization protocols,
hierarchical SFA beside the feature methods of a folder of plug-in files; results as JSON, a
table and figures.

Every field of the protocols' settings (:class:`~sfa_gym.experiments.GridExperiment`,
:class:`~sfa_gym.experiments.TrajectoryExperiment`, the nested
:class:`~sfa_gym.experiments.SFASettings`) is an option of the same name, without prefix
(``--n-train``, ``--node-dim``); their docstrings are the help text and their ``validate()``
checks the values.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import tyro

from sfa_gym.cli.baselines import baseline_workers
from sfa_gym.experiments import GridExperiment, OutdoorExperiment, TrajectoryExperiment

__all__ = ["Localize", "LocalizeOutdoor", "LocalizeRun"]


@dataclass(frozen=True)
class _Protocol:
    out: Path
    """output folder (created); the rendered runs are kept there and reused"""
    baselines: Path | None = None
    """folder of feature-method plug-in files (default: the checkout's baselines/, or those
    shipped with sfa-gym)"""
    no_baselines: bool = False
    """hierarchical SFA only"""
    quiet: bool = False
    """no progress bars"""

    def _evaluate(self, experiment: Callable[..., dict[str, Any]], settings: Any) -> int:
        """Run ``experiment`` with ``settings`` (checked first) and the baselines, each in a
        worker process of its own; write and print the table."""
        from sfa_gym.experiments import format_table

        settings.validate()
        folder = None if self.no_baselines else self.baselines
        with baseline_workers(self.out, folder, use_default=not self.no_baselines) as found:
            results = experiment(settings, self.out, found, progress=not self.quiet)
        table = format_table(results)
        Path(self.out, "results.txt").write_text(table + "\n")
        print(table)
        print(f"results in {Path(self.out) / 'results.json'}; figures in {self.out}")
        return 0


@dataclass(frozen=True)
class Localize(_Protocol):
    """The paper's simulator localization experiment (grid protocol)."""

    settings: tyro.conf.OmitArgPrefixes[GridExperiment] = GridExperiment()
    """settings of the grid protocol"""

    def run(self) -> int:
        from sfa_gym.experiments import run_grid_experiment

        return self._evaluate(run_grid_experiment, self.settings)


@dataclass(frozen=True)
class LocalizeRun(_Protocol):
    """The paper's outdoor protocol: fit on a training run, test on a separate run through a
    region never visited in training."""

    settings: tyro.conf.OmitArgPrefixes[TrajectoryExperiment] = TrajectoryExperiment()
    """settings of the trajectory protocol"""
    no_exclude: bool = False
    """the training run visits everything (same as --exclude None)"""

    def run(self) -> int:
        from sfa_gym.experiments import run_trajectory_experiment

        settings = self.settings
        if self.no_exclude:
            settings = dataclasses.replace(settings, exclude=None)
        return self._evaluate(run_trajectory_experiment, settings)


@dataclass(frozen=True)
class LocalizeOutdoor(_Protocol):
    """The paper's outdoor experiment in the outdoor world (sfa_gym/OmniRoverOutdoor-v0): 5900
    training frames, 2800 test frames right after through a region never visited in training,
    and the appearance tracks (--conditions after later overcast no_movers other_day fog
    rearranged other_season); the sun of a date and place (--day-of-year 15 --latitude-deg 50,
    --seasons for the foliage), several later offsets (--later-hours 2 6), other days
    (--other-days 1 2) and seasons (--season-days 92 183) in one run."""

    settings: tyro.conf.OmitArgPrefixes[OutdoorExperiment] = OutdoorExperiment()
    """settings of the outdoor protocol"""

    def run(self) -> int:
        from sfa_gym.experiments import run_outdoor_experiment

        return self._evaluate(run_outdoor_experiment, self.settings)
