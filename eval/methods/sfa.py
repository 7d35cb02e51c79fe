"""Hierarchical SFA, the paper's method, as a leaderboard plug-in.

The network of :class:`~sfa_gym.protocols.settings.SFASettings` (a preset of
``sfa_gym.sfa.presets``: converging layers of linear SFA, quadratic expansion, SFA) is fitted
without labels on every simulated rotation of the training panoramas in visiting order
(``fit_rotations``: with weights shared along rows, the lower layers are computed once per
panorama); its ``n_outputs`` slowest outputs are the features, regressed linearly to position as
in the paper.

Run alone: ``python sfa.py`` prints the arguments; on the leaderboard::

    sfa-gym leaderboard run --method eval/methods/sfa.py --track train_test --quick
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from sfa_gym.experiments.common import SlowFeatureMethod
from sfa_gym.protocols.settings import SFASettings


@dataclass(frozen=True)
class Args:
    network: str = "paper_sim"
    """architecture, a preset of sfa_gym.sfa.presets (paper_sim: 40 x 350 panoramas; tiny:
    any small panorama)"""
    node_dim: int = 32
    """linear SFA dimension and output dimension of every node"""
    n_outputs: int = 8
    """slow features used (the paper: 8)"""
    weight_sharing: str = "rows"
    """nodes that share weights: "rows", "layer" (the paper) or "none" (slow)"""
    regressor: str = "linear"
    """regression the features are paired with (the paper: linear)"""


class LeaderboardSFA(SlowFeatureMethod):
    """:class:`SlowFeatureMethod` whose rotated features may use any step: a feature field
    averages over every column (step 1) of a network trained with 5-column rotations."""

    def transform_rotations(self, panoramas: NDArray[np.uint8], step: int) -> NDArray[np.float64]:
        """Features of every ``step``-column rotation of each panorama, ``(L, W // step, k)``."""
        return self.model_.transform_rotations(panoramas, step=step)


def make_method(**kwargs: object) -> SlowFeatureMethod:
    """An unfitted hierarchical SFA method with ``Args(**kwargs)``."""
    args = Args(**kwargs)  # type: ignore[arg-type]
    settings = SFASettings(
        network=args.network,  # type: ignore[arg-type]
        node_dim=args.node_dim,
        n_outputs=args.n_outputs,
        weight_sharing=args.weight_sharing,  # type: ignore[arg-type]
    )
    settings.validate()
    method = LeaderboardSFA(settings, progress=False)
    method.regressor = args.regressor  # the instance's choice over the class default
    method.args = args  # type: ignore[attr-defined]
    return method


if __name__ == "__main__":
    print(Args())
