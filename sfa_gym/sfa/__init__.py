"""Slow Feature Analysis: linear SFA, quadratic expansion, hierarchical networks.

Pure numpy/scipy and scikit-learn estimators; imports neither gymnasium nor mujoco. A fitted
:class:`HierarchicalSFA` is written and read by :func:`save_model` and :func:`load_model`
(:mod:`sfa_gym.sfa.io`). An estimator used before it is fitted raises
:class:`sklearn.exceptions.NotFittedError`.

>>> from sfa_gym.sfa import SFA, QuadraticExpansion, LayerSpec, HierarchicalSFA, presets
"""

from __future__ import annotations

from sfa_gym.sfa import presets
from sfa_gym.sfa.expansion import QuadraticExpansion, n_quadratic_features, quadratic_expand
from sfa_gym.sfa.io import load_model, save_model
from sfa_gym.sfa.linear import SFA, RankDeficiencyWarning
from sfa_gym.sfa.network import WEIGHT_SHARING, HierarchicalSFA, WeightSharing, shortcut_applies
from sfa_gym.sfa.spec import LayerSpec, describe, layer_grids

__all__ = [
    "SFA",
    "QuadraticExpansion",
    "LayerSpec",
    "HierarchicalSFA",
    "WEIGHT_SHARING",
    "WeightSharing",
    "presets",
    "RankDeficiencyWarning",
    "describe",
    "layer_grids",
    "load_model",
    "n_quadratic_features",
    "quadratic_expand",
    "save_model",
    "shortcut_applies",
]
