"""Temporal-contrastive features: a small CNN trained with InfoNCE, neighbours in time as
positives and the batch's other views as negatives (as in CPC, Oord et al. 2018, and the
time-contrastive networks of Sermanet et al. 2018), the representation learning that replaced
SFA in much of the field.

The network (:class:`sfa_gym.deep_methods.CircularEncoder`) maps each view to ``output_dim``
outputs. Each training step takes a batch of pairs of neighbours in time (rows ``t`` and ``t + 1``
of one sequence), projects the outputs on the unit sphere and scores every ``t`` against every
``t + 1`` of the batch by cosine similarity over ``TEMPERATURE``; the loss is the cross-entropy
of picking each view's own neighbour, both ways.

Rotation: a simulated rotation of the panorama (a circular shift of its columns) is the
augmentation that would keep heading out of the features; the network is invariant to every such
shift by construction (circular convolutions pooled by |DFT| along the width: see
:mod:`sfa_gym.deep_methods`), which is that augmentation applied exhaustively, so no shifted
copies are fed and the features of a place are the same at every heading.

The features are the outputs standardised over the training views (zero mean, unit variance),
so that distances weigh the outputs alike as for SFA's unit-variance outputs.

On the leaderboard::

    sfa-gym leaderboard run --method contrastive --track train_test --quick

Needs torch (``pip install 'sfa-gym[deep]'``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from sfa_gym.deep_methods import NetworkArgs, TemporalNetworkMethod, torch

TEMPERATURE = 0.1
"""Divides the cosine similarities before the softmax (SimCLR's usual value)."""


@dataclass(frozen=True)
class Args(NetworkArgs):
    """:class:`~sfa_gym.deep_methods.NetworkArgs`: the network and its training."""


def info_nce(before: torch.Tensor, after: torch.Tensor) -> torch.Tensor:
    """InfoNCE of ``(B, k)`` outputs whose rows ``i`` are positives and the other rows
    negatives, symmetric in the two."""
    a = torch.nn.functional.normalize(before, dim=1)
    b = torch.nn.functional.normalize(after, dim=1)
    logits = a @ b.T / TEMPERATURE
    target = torch.arange(len(a))
    cross_entropy = torch.nn.functional.cross_entropy
    return (cross_entropy(logits, target) + cross_entropy(logits.T, target)) / 2


class TemporalContrastive(TemporalNetworkMethod):
    """Feature method: outputs of a CNN trained by temporal InfoNCE; the parameters are the
    fields of :class:`Args`.

    Attributes (after ``fit``, besides those of
    :class:`~sfa_gym.deep_methods.TemporalNetworkMethod`):
        mean_, scale_: ``(output_dim,)`` the outputs' mean and standard deviation over the
            training views.
    """

    name = "contrastive"

    def objective(self, before: torch.Tensor, after: torch.Tensor) -> torch.Tensor:
        return info_nce(before, after)

    def fit_readout(self, outputs: NDArray[np.float64], sequence_ids: Any) -> None:
        self.mean_ = outputs.mean(axis=0)
        scale = outputs.std(axis=0)
        self.scale_ = np.where(scale > 0, scale, 1.0)  # a constant output stays 0

    def readout(self, outputs: NDArray[np.float64]) -> NDArray[np.float64]:
        return (outputs - self.mean_) / self.scale_


METHOD = TemporalContrastive
