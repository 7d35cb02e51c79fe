"""The evaluation loop shared by the localization protocols.

Every feature method (hierarchical SFA first, then the plug-ins) is fitted on the rotated views of
the same training panoramas, in their visiting order; its features of rotated views of the
training and the test panoramas feed each of its regressions; the MAE of the estimates (averaged
over the views of a location) and the invariance of the features over the training views are
recorded. The protocols differ only in their data (which panoramas, which views) and in what they
report per regression (a callback of :func:`evaluate_methods`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from sfa_gym.experiments.report import mae_dict
from sfa_gym.localization import fit_predict, mae, make_regressor
from sfa_gym.plugins import FeatureMethod
from sfa_gym.protocols.features import fit_method, invariance_entry, view_features
from sfa_gym.protocols.settings import SFASettings
from sfa_gym.protocols.slow_features import SlowFeatureMethod
from sfa_gym.rotation import Rotation
from sfa_gym.sfa import HierarchicalSFA

__all__ = [
    "FIGURE_REGRESSOR",
    "Evaluation",
    "SlowFeatureMethod",
    "evaluate_methods",
    "methods_with_sfa",
]

FIGURE_REGRESSOR = "map"
"""The regression whose SFA estimates the estimate and error-map figures show."""

SFA_REGRESSORS = ("linear", "quadratic", "map")
"""Regressions hierarchical SFA is evaluated with: the paper's linear one, a quadratic one and
the map decoder."""


def methods_with_sfa(
    settings: SFASettings,
    rotation: Rotation,
    methods: Sequence[tuple[FeatureMethod, Sequence[str]]],
    progress: bool,
) -> list[tuple[FeatureMethod, Sequence[str]]]:
    """Hierarchical SFA with :data:`SFA_REGRESSORS`, followed by the extra ``methods``."""
    sfa = SlowFeatureMethod(settings, rotation, progress=progress)
    return [(sfa, SFA_REGRESSORS), *methods]


@dataclass
class Evaluation:
    """What :func:`evaluate_methods` found.

    Attributes:
        methods: per method name, ``eta_r``, ``eta_phi``, ``n_features`` and one entry per
            regression (``train_test`` MAE and what the protocol's ``score`` added), as
            ``results.json`` holds them.
        model: the fitted hierarchical SFA network.
        estimates: SFA's test estimates with :data:`FIGURE_REGRESSOR`, ``(M, 2)`` metres.
    """

    methods: dict[str, dict[str, Any]]
    model: HierarchicalSFA
    estimates: NDArray[np.float64]


Score = Callable[[str, NDArray[np.float64], NDArray[np.float64]], dict[str, Any]]
"""``score(regressor name, test features (M, K', k), estimates (M, 2)) -> entries`` that a
protocol reports besides ``train_test``."""


def evaluate_methods(
    methods: Sequence[tuple[FeatureMethod, Sequence[str]]],
    *,
    train: tuple[NDArray[np.uint8], NDArray[np.float64]],
    test: tuple[NDArray[np.uint8], NDArray[np.float64]],
    rotation: Rotation,
    score: Score,
    indices: NDArray[np.intp] | None = None,
    progress: bool = True,
) -> Evaluation:
    """Fit and evaluate every method; the first one must be a :class:`SlowFeatureMethod`.

    Args:
        methods: feature methods, each with the names of the regressions to evaluate it with
            (see :func:`~sfa_gym.localization.regression.make_regressor`; repeats count once).
        train: training panoramas ``(L, H, W, 3)`` in visiting order and positions ``(L, 2)``.
        test: test panoramas ``(M, H, W, 3)`` and positions ``(M, 2)``.
        rotation: the simulated rotation; every method is fitted on all views of the training
            panoramas.
        score: what the protocol reports for one regression besides the MAE of the estimates
            fitted on the training data (``train_test``); called once per method and
            regression with the test features and those estimates.
        indices: the views whose features the regressions see (all ``K`` by default).
        progress: progress bars.
    """
    (train_pan, train_xy), (test_pan, test_xy) = train, test
    sfa, sfa_regressors = methods[0]
    if not isinstance(sfa, SlowFeatureMethod) or FIGURE_REGRESSOR not in sfa_regressors:
        raise ValueError(
            f"the first method must be a SlowFeatureMethod evaluated with {FIGURE_REGRESSOR!r} "
            f"(see methods_with_sfa), got {sfa!r} with {list(sfa_regressors)}"
        )
    results: dict[str, dict[str, Any]] = {}
    estimates = np.empty((0, 2))
    for method, regressors in methods:
        fitted = fit_method(method, train_pan, rotation)
        f_train = view_features(
            fitted, train_pan, rotation, indices, f"{method.name} train", progress
        )
        f_test = view_features(fitted, test_pan, rotation, indices, f"{method.name} test", progress)
        entry = invariance_entry(f_train)
        for name in dict.fromkeys(regressors):
            found = fit_predict(make_regressor(name), f_train, train_xy, f_test)
            entry[name] = {
                "train_test": mae_dict(mae(found, test_xy)),
                **score(name, f_test, found),
            }
            if method is sfa and name == FIGURE_REGRESSOR:
                estimates = found
        results[method.name] = entry
    return Evaluation(methods=results, model=sfa.model_, estimates=estimates)
