"""What a robot can know of the slow-feature gradient without a map: the cost's feature weights
from the features' slowness, the local linear model of the features fitted to its own recent
moves, and the Gauss-Newton step to the goal features under that model.

Shared by the gradient controller (:mod:`sfa_gym.navigation.controllers`) and learning agents
that see the same estimate. Numpy only, in :mod:`~sfa_gym.navigation.portable` arithmetic where
it runs at every step (the same bits on every CPU).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sfa_gym.navigation import portable

__all__ = ["LocalLinearFit", "gauss_newton_step", "slowness_weights"]


def slowness_weights(sequence: ArrayLike, power: float = 2.0) -> NDArray[np.float64]:
    """Feature weights ``delta_i ** -power`` from features ``(T, k)`` along a trajectory in time
    order (a training run; no positions needed).

    ``delta_i = mean((f_i[t+1] - f_i[t])^2) / var(f_i)`` is the slowness SFA minimises. The cost
    ``sum_i w_i (f_i - g_i)^2`` weighs the standardised features by their slowness, so that slow
    features, which vary smoothly over the whole arena, dominate and fast ones, whose many
    extrema would create false minima, count less. SFA's outputs approximate the slowest
    eigenfunctions of the Laplacian of the space the training run explored, with ``delta_i`` their
    eigenvalues; ``power=1`` then gives the commute-time (diffusion) distance and ``power=2``
    (default) the biharmonic distance (Lipman et al. 2010), which is smooth at the goal and keeps
    its slope far from it (the README's navigation section compares the powers).
    """
    f = np.asarray(sequence, dtype=np.float64)
    if f.ndim != 2 or len(f) < 3:
        raise ValueError(f"sequence must be (T, k) features with T >= 3, got shape {f.shape}")
    if not (isinstance(power, int | float) and power > 0):
        raise ValueError(f"power must be a positive number, got {power!r}")
    variance = np.var(f, axis=0)
    delta = np.mean(np.diff(f, axis=0) ** 2, axis=0) / np.where(variance > 0, variance, 1.0)
    if np.any(~(delta > 0)) or np.any(~(variance > 0)):
        raise ValueError("a feature does not change along the sequence: its slowness is undefined")
    return (1.0 / delta) ** power / variance


class LocalLinearFit:
    """The local linear model of the features around the rover, ``f(p) = a + J (p - p_now)``,
    fitted by weighted least squares to the features and odometry positions of its recent moves:
    what the gradient controller (and a learning agent) can know about the feature gradient
    without a map.

    One sample per centimetre of travel is kept, over ``window`` metres; a sample fades with the
    distance travelled since it (``memory``); a prior keeps the Jacobian's unexplored directions
    at their last estimate (``prior``), since the rover mostly moves along one direction.

    Args:
        weights: ``(k,)`` feature weights of the cost (for the fit's noise floor).
        memory: as in :class:`~sfa_gym.navigation.controllers.GradientSettings`.
        window: as there.
        prior: as there.
    """

    def __init__(self, weights: NDArray, memory: float, window: float, prior: float) -> None:
        self.weights = weights
        self.memory, self.window, self.prior = memory, window, prior
        self._positions: list[NDArray] = []
        self._features: list[NDArray] = []
        self._odometer: list[float] = []  # distance travelled when each sample was taken
        self._last_position: NDArray | None = None
        self._jacobian: NDArray | None = None
        self.travelled = 0.0
        """metres travelled since the start (odometry)"""
        self.spread = 0.0
        """spread (m) of the last fit's moves across their main direction: the standard deviation
        along the smaller axis of their weighted covariance, how well they determine the
        Jacobian's second column"""

    def remember(self, position: NDArray, features: NDArray) -> None:
        """Add the features ``(k,)`` seen at the odometry position ``(2,)``."""
        if self._last_position is not None:
            self.travelled += portable.norm2(position - self._last_position)
        self._last_position = position
        if self._positions and portable.norm2(position - self._positions[-1]) < 0.01:
            # turning on the spot adds no information: keep only the latest features there
            self._positions[-1], self._features[-1] = position, features
            self._odometer[-1] = self.travelled
        else:
            self._positions.append(position)
            self._features.append(features)
            self._odometer.append(self.travelled)
        while self.travelled - self._odometer[0] > self.window:
            del self._positions[0], self._features[0], self._odometer[0]

    def fit(self) -> tuple[NDArray, NDArray, float] | None:
        """``(a, J, noise floor of the cost)`` of the model around the last position, or None
        while the first moves do not span the plane."""
        if len(self._positions) < 4:
            return None
        p = np.array(self._positions) - self._last_position
        f = np.array(self._features)
        sw = portable.exp(-(self.travelled - np.array(self._odometer)) / self.memory)
        design = np.column_stack([np.ones(len(p)), p])
        normal = portable.gram(design, design, sw)
        rhs = portable.gram(design, f, sw)
        self.spread = math.sqrt(max(portable.smallest_eigenvalue(_weighted_covariance(p, sw)), 0.0))
        if self._jacobian is None and self.spread < 0.02:
            return None  # the moves span less than a couple of cm across
        if self._jacobian is not None:
            strength = self.prior * sw.sum()
            normal[1:, 1:] += strength * np.eye(2)
            rhs[1:] += strength * self._jacobian.T
        coef = portable.solve(normal, rhs)
        a, self._jacobian = coef[0], coef[1:].T
        residual = f - np.einsum("ni,ik->nk", design, coef)
        noise = float(np.sum(sw[:, None] * self.weights * residual**2) / max(sw.sum() - 3, 1))
        return a, self._jacobian, noise


def gauss_newton_step(
    a: NDArray, jacobian: NDArray, goal: NDArray, weights: NDArray, damping: float
) -> NDArray:
    """The damped Gauss-Newton step ``-(J^T W J + mu I)^-1 J^T W (a - g)`` (m, in the odometry
    frame) towards the goal features ``g`` under the local linear model, ``mu`` = ``damping``
    times the trace of ``J^T W J``."""
    metric = portable.gram(jacobian, jacobian, weights)
    gradient = np.einsum("ki,k->i", jacobian, weights * (a - goal))
    mu = damping * float(metric[0, 0] + metric[1, 1]) + 1e-12
    return -portable.solve(metric + mu * np.eye(2), gradient)


def _weighted_covariance(p: NDArray, weights: NDArray) -> NDArray:
    """``np.cov(p.T, aweights=weights)`` of positions ``(n, 2)`` (unbiased for reliability
    weights), in :mod:`~sfa_gym.navigation.portable` arithmetic."""
    total = weights.sum()
    centred = p - np.einsum("n,ni->i", weights, p) / total
    return portable.gram(centred, centred, weights) / (total - (weights**2).sum() / total)
