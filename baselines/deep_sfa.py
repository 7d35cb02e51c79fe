"""Deep slow features: a small CNN trained with the slowness objective through differentiable
whitening (PowerSFA-style; Schüler, Hlynsson & Wiskott 2019).

The network (:class:`sfa_gym.deep_methods.CircularEncoder`: circular convolutions, pooled over
the width by |DFT|, so a simulated rotation of a panorama leaves its features unchanged; why
there and not by averaging rotated copies: :mod:`sfa_gym.deep_methods`) maps each view to
``output_dim`` outputs. Each training step takes a batch of pairs of neighbours in time (rows
``t`` and ``t + 1`` of one sequence), whitens the outputs of all the batch's views with their
own covariance (the whitening layer, differentiable, so the gradient sees that the outputs must
stay decorrelated and of unit variance) and minimises the mean squared time difference of the
whitened outputs. Whitening here is by the Cholesky factor of the covariance rather than
PowerSFA's power iteration: any whitening gives the same loss, ``trace(C^-1 C_dot) / k``
(``C_dot`` the covariance of the differences), since they differ by a rotation; a ridge of
``RIDGE`` times the mean variance keeps it finite without a scale the network could shrink under.

After training, linear SFA (:class:`sfa_gym.sfa.linear.SFA`) on the outputs of all training
views, with their sequences, orders them slowest first with unit variance, as SFA's outputs are:
these are the features, regressed linearly to position like SFA's.

On the leaderboard::

    sfa-gym leaderboard run --method deep_sfa --track train_test --quick

Needs torch (``pip install 'sfa-gym[deep]'``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from sfa_gym.deep_methods import NetworkArgs, TemporalNetworkMethod, torch
from sfa_gym.sfa.linear import SFA

RIDGE = 1e-4
"""Added to the batch covariance before whitening, times its mean variance."""


@dataclass(frozen=True)
class Args(NetworkArgs):
    """:class:`~sfa_gym.deep_methods.NetworkArgs`: the network and its training."""


def whiten(outputs: torch.Tensor) -> torch.Tensor:
    """``(n, k)`` outputs centred and whitened with their own covariance (differentiable)."""
    centred = outputs - outputs.mean(dim=0)
    covariance = centred.T @ centred / (len(outputs) - 1)
    k = covariance.shape[0]
    covariance = covariance + RIDGE * torch.trace(covariance) / k * torch.eye(k)
    factor = torch.linalg.cholesky(covariance)  # covariance = L L^T; L^-1 x is white
    return torch.linalg.solve_triangular(factor, centred.T, upper=False).T


class DeepSFA(TemporalNetworkMethod):
    """Feature method: slow features of a CNN trained through whitening; the parameters are the
    fields of :class:`Args`.

    Attributes (after ``fit``, besides those of
    :class:`~sfa_gym.deep_methods.TemporalNetworkMethod`):
        sfa_: the linear SFA that orders the network's outputs by slowness.
    """

    name = "deep_sfa"

    def objective(self, before: torch.Tensor, after: torch.Tensor) -> torch.Tensor:
        white = whiten(torch.cat([before, after]))
        n = len(before)
        return ((white[n:] - white[:n]) ** 2).mean()

    def fit_readout(self, outputs: NDArray[np.float64], sequence_ids: Any) -> None:
        self.sfa_ = SFA(n_components=self.output_dim).fit(outputs, sequence_ids=sequence_ids)

    def readout(self, outputs: NDArray[np.float64]) -> NDArray[np.float64]:
        return self.sfa_.transform(outputs)


METHOD = DeepSFA
