"""Hierarchical SFA as a feature method, scored first, beside the plug-ins, by the command
line's localization runs.

Every method is scored through its protocol's ``score`` (:mod:`sfa_gym.protocols`): fitted on
the rotated views of the same training panoramas, in their visiting order, with the same
regressions and metrics as on the leaderboard; SFA with :data:`SFA_REGRESSORS`, each plug-in
with the regressions it names.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import Any, TypeVar

from sfa_gym.plugins import FeatureMethod
from sfa_gym.protocols import RunSource
from sfa_gym.protocols.settings import SFASettings
from sfa_gym.protocols.slow_features import SlowFeatureMethod
from sfa_gym.rotation import Rotation

__all__ = [
    "FIGURE_REGRESSOR",
    "SFA_REGRESSORS",
    "SlowFeatureMethod",
    "methods_with_sfa",
    "protocol_part",
    "score_methods",
]

C = TypeVar("C")

FIGURE_REGRESSOR = "map"
"""The regression whose SFA estimates the estimate and error-map figures show."""

SFA_REGRESSORS = ("linear", "quadratic", "map")
"""Regressions hierarchical SFA is evaluated with: the paper's linear one, a quadratic one and
the map decoder."""


def protocol_part(settings: Any, config_type: type[C]) -> C:
    """The protocol's own ``Config`` (``config_type``) of a command's ``settings``, which are
    that ``Config`` with the command's own fields added (world seed, SFA network, ...)."""
    names = [f.name for f in dataclasses.fields(config_type)]  # type: ignore[arg-type]
    return config_type(**{name: getattr(settings, name) for name in names})


def methods_with_sfa(
    settings: SFASettings,
    rotation: Rotation,
    methods: Sequence[tuple[FeatureMethod, Sequence[str]]],
    progress: bool,
) -> list[tuple[FeatureMethod, Sequence[str]]]:
    """Hierarchical SFA with :data:`SFA_REGRESSORS`, followed by the extra ``methods``."""
    sfa = SlowFeatureMethod(settings, rotation, progress=progress)
    return [(sfa, SFA_REGRESSORS), *methods]


def score_methods(
    protocol: Any,
    config: Any,
    world_seed: int,
    runs: RunSource,
    sfa: SlowFeatureMethod,
    methods: Sequence[tuple[FeatureMethod, Sequence[str]]],
    progress: bool = True,
) -> list[Any]:
    """Score hierarchical SFA (with :data:`SFA_REGRESSORS`), then every extra method (with its
    regressions), through ``protocol.score`` (a module of :mod:`sfa_gym.protocols`); returns
    their ``Scores`` in that order."""
    return [
        protocol.score(config, method, world_seed, runs, regressors=regressors, progress=progress)
        for method, regressors in [(sfa, SFA_REGRESSORS), *methods]
    ]
