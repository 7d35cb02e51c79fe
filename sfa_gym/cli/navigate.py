"""``sfa-gym navigate``: the navigation protocol (:mod:`sfa_gym.experiments.navigation`): train
SFA on the world without labels, build feature fields, run the controllers on fixed episode
seeds; results as JSON, a table and figures."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import tyro

from sfa_gym.experiments.navigation import NavigationExperiment

__all__ = ["Navigate"]


@dataclass(frozen=True)
class Navigate:
    """Image-goal navigation: the slow-feature-gradient controller on SFA and on the feature
    methods of a folder of plug-in files, beside the oracle (upper bound) and a random policy."""

    out: Path
    """output folder (created); the renders, the SFA model and the feature fields are kept there
    and reused while the settings that made them stay the same (else computed again)"""
    settings: tyro.conf.OmitArgPrefixes[NavigationExperiment] = NavigationExperiment()
    """settings of the navigation protocol"""
    baselines: Path | None = None
    """folder of feature-method plug-in files (default: none; e.g. baselines/); each runs in a
    worker process of its own"""
    quiet: bool = False
    """no progress bars"""

    def run(self) -> int:
        from sfa_gym.cli.baselines import baseline_workers
        from sfa_gym.experiments.navigation import (
            format_navigation_table,
            run_navigation_experiment,
        )

        self.settings.validate()
        with baseline_workers(self.out, self.baselines, use_default=False) as methods:
            results = run_navigation_experiment(
                self.settings, self.out, methods, progress=not self.quiet
            )
        table = format_navigation_table(results)
        Path(self.out, "results.txt").write_text(table + "\n")
        print(table)
        print(f"results in {Path(self.out) / 'results.json'}; figures in {self.out}")
        return 0
