"""Hierarchical SFA as a feature method, scored first, beside the plug-ins, by the command
line's localization runs.

Every method is scored through its protocol's ``score`` (:mod:`sfa_gym.protocols`): fitted on
the rotated views of the same training panoramas, in their visiting order, with the same
regressions and metrics as on the leaderboard; SFA with :data:`SFA_REGRESSORS`, each plug-in
with the regressions it names.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from sfa_gym.localization.methods import FeatureMethod
from sfa_gym.protocols import RunSource
from sfa_gym.protocols.settings import SFASettings
from sfa_gym.rotation import Rotation

__all__ = [
    "FIGURE_REGRESSOR",
    "SFA_REGRESSORS",
    "SlowFeatureMethod",
    "methods_with_sfa",
    "score_methods",
]

FIGURE_REGRESSOR = "map"
"""The regression whose SFA estimates the estimate and error-map figures show."""

SFA_REGRESSORS = ("linear", "quadratic", "map")
"""Regressions hierarchical SFA is evaluated with: the paper's linear one, a quadratic one and
the map decoder."""


class SlowFeatureMethod:
    """Hierarchical SFA as a feature method: fitted on all simulated rotations of a sequence of
    panoramas (:meth:`HierarchicalSFA.fit_rotations`), regressed linearly as in the paper.

    Args:
        settings: the network (default: :class:`SFASettings` defaults).
        rotation: the simulated rotation it is trained on (default: 5 columns, full views).
        progress: progress bars while fitting.
    """

    name = "hierarchical_sfa"
    regressor = "linear"

    def __init__(
        self,
        settings: SFASettings | None = None,
        rotation: Rotation | None = None,
        progress: bool = True,
    ) -> None:
        self.settings = SFASettings() if settings is None else settings
        self.rotation = Rotation() if rotation is None else rotation
        self.progress = progress

    def fit_rotations(self, panoramas: NDArray[np.uint8]) -> SlowFeatureMethod:
        """Fit on ``panoramas (L, H, W, 3)`` in visiting order, with all their rotations."""
        _, h, w, _ = panoramas.shape
        model = self.settings.make_model(h, w, self.progress)
        self.model_ = model.fit_rotations(
            panoramas, step=self.rotation.step, window=self.rotation.window
        )
        self.input_shape_ = self.model_.input_shape_
        return self

    def fit(self, views: NDArray[np.uint8], sequence_ids: Any = None) -> SlowFeatureMethod:
        """Fit on ``views (N, H, W, 3)`` in time order."""
        _, h, w, _ = views.shape
        self.model_ = self.settings.make_model(h, w, self.progress).fit(
            views, sequence_ids=sequence_ids
        )
        self.input_shape_ = self.model_.input_shape_
        return self

    def transform(self, views: NDArray[np.uint8]) -> NDArray[np.float64]:
        """``(N, H, W, 3)`` uint8 -> ``(N, n_outputs)`` slow features."""
        return self.model_.transform(views)

    def transform_rotations(self, panoramas: NDArray[np.uint8], step: int) -> NDArray[np.float64]:
        """Features of every rotation of every panorama, ``(L, K, n_outputs)``, computed with
        the rotation shortcut (the lower layers run once per panorama); ``step`` must be the
        rotation's."""
        if step != self.rotation.step:
            raise ValueError(
                f"{self.name} was set up for rotation steps of {self.rotation.step} columns, "
                f"got step={step!r}"
            )
        return self.model_.transform_rotations(panoramas, step=step)


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
