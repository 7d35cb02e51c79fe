"""Slow Feature Analysis: linear SFA, quadratic expansion, hierarchical networks.

Pure numpy/scipy; imports neither gymnasium nor mujoco.

>>> from sfa_gym.sfa import SFA, QuadraticExpansion, LayerSpec, HierarchicalSFA, presets
"""

from __future__ import annotations

from sfa_gym.sfa import presets
from sfa_gym.sfa.expansion import QuadraticExpansion, n_quadratic_features, quadratic_expand
from sfa_gym.sfa.linear import SFA, NotFittedError, RankDeficiencyWarning
from sfa_gym.sfa.network import HierarchicalSFA, shortcut_applies
from sfa_gym.sfa.spec import LayerSpec, describe, layer_grids

__all__ = [
    "SFA",
    "QuadraticExpansion",
    "LayerSpec",
    "HierarchicalSFA",
    "presets",
    "NotFittedError",
    "RankDeficiencyWarning",
    "describe",
    "layer_grids",
    "n_quadratic_features",
    "quadratic_expand",
    "shortcut_applies",
]
