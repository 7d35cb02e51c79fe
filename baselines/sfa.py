"""Hierarchical SFA, the paper's method, as a built-in feature method.

Its arguments are :class:`~sfa_gym.protocols.settings.SFASettings`, the settings every protocol
trains the network with (``--sfa.*`` on the command line): a preset of ``sfa_gym.sfa.presets``
(converging layers of linear SFA, quadratic expansion, SFA), fitted without labels on every
simulated rotation of the training panoramas in visiting order (``fit_rotations``: with weights
shared along rows, the lower layers are computed once per panorama); its ``n_outputs`` slowest
outputs are the features, regressed linearly to position as in the paper.

``sfa-gym localize`` leaves this file out of the folder's methods: the protocols train SFA
themselves with their ``--sfa.*`` settings. On the leaderboard::

    sfa-gym leaderboard run --method sfa --track train_test --quick
"""

from __future__ import annotations

from dataclasses import dataclass

from sfa_gym.protocols.settings import NetworkName, SFASettings
from sfa_gym.protocols.slow_features import SlowFeatureMethod


@dataclass(frozen=True)
class Args(SFASettings):
    """:class:`~sfa_gym.protocols.settings.SFASettings`, the network made for the track's
    panoramas by default (tracks differ in camera: 40 x 350 and 60 x 600)."""

    network: NetworkName = "auto"
    """architecture: a preset of sfa_gym.sfa.presets (paper_sim: 40 x 350 panoramas, 4 layers;
    paper_outdoor: 60 x 600; tiny: any small panorama, 3 layers; auto: the one made for the
    panoramas' size)"""


def make_method(**kwargs: object) -> SlowFeatureMethod:
    """An unfitted hierarchical SFA method with ``Args(**kwargs)`` (checked here, before
    anything is rendered)."""
    settings = Args(**kwargs)  # type: ignore[arg-type]
    settings.validate()
    return SlowFeatureMethod(settings, progress=False)
