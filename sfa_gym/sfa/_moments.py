"""Streaming first and second moments of samples and of their time differences.

SFA needs, over the training data, the mean and covariance of the input ``x`` and the second
moment matrix of its time derivative ``dx`` (``x[t+1] - x[t]`` within a sequence), plus -- for
the sign convention -- the covariance of ``x`` with the time index. :class:`Moments` accumulates
all of these chunk by chunk so that the data never has to be held at once.

Samples may carry integer-valued *weights*: a row with weight ``w`` stands for ``w`` identical
samples. The rotation shortcut of the hierarchical network uses this: one evaluation of a node
at a position of the dense periodic grid stands for every rotated view that sees that position.

Precision: products of a chunk are computed in the chunk's dtype (float32 chunks use sgemm /
ssyrk, twice as fast) and summed across chunks in float64. Data is shifted by the mean of the
first chunk before any product, so a large common offset (pixel values around 128) does not
cancel catastrophically when the covariance is formed at the end.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray


@dataclass(frozen=True)
class MomentStats:
    """Finished statistics of one group (node), all float64.

    Attributes:
        mean: ``(F,)`` weighted mean of the samples.
        cov: ``(F, F)`` covariance (normalised by the total weight, not weight - 1).
        dcov: ``(F, F)`` second moment of the time differences, not centred (SFA's objective
            is the mean *squared* derivative).
        cov_xt: ``(F,)`` covariance of each input with the time index.
        var_t: variance of the time index over the samples.
        n_samples: total sample weight.
        n_differences: total difference weight.
    """

    mean: NDArray[np.float64]
    cov: NDArray[np.float64]
    dcov: NDArray[np.float64]
    cov_xt: NDArray[np.float64]
    var_t: float
    n_samples: float
    n_differences: float


def _gram(x: NDArray[np.floating]) -> NDArray[np.float64]:
    """Sum of outer products over the sample axis: ``(G, F, n) -> (G, F, F)`` float64."""
    if x.shape[0] == 1:
        # a @ a.T on one buffer lets numpy call syrk (half the flops of gemm)
        a = x[0]
        return (a @ a.T)[None].astype(np.float64, copy=False)
    return np.matmul(x, x.transpose(0, 2, 1)).astype(np.float64, copy=False)


def _weighted_gram(x: NDArray[np.floating], w: NDArray[np.float64] | None) -> NDArray[np.float64]:
    """``sum_n w[n] x[..., n] x[..., n]^T`` without an extra pass over ``x`` where possible.

    Weights are sample counts and usually take one value for all but a few samples (the rotation
    shortcut: every dense column stands for the same number of views, a few for one less). Then
    ``w_max * Gram(x) - Gram(deficient samples)`` is cheaper than scaling every sample.
    """
    if w is None:
        return _gram(x)
    w_max = float(w.max())
    deficit = w_max - w
    short = np.flatnonzero(deficit)
    if len(short) == 0:
        return w_max * _gram(x)
    if len(short) <= w.size // 4:
        sub = x[:, :, short] * np.sqrt(deficit[short]).astype(x.dtype)
        return w_max * _gram(x) - _gram(sub)
    return _gram(x * np.sqrt(w).astype(x.dtype))


def _weighted_sum(x: NDArray[np.floating], w: NDArray[np.float64]) -> NDArray[np.float64]:
    """``sum_n x[g, :, n] w[n, ...]``: ``(G, F, n), (n, k) -> (G, F, k)`` in float64.

    Float32 data is summed in blocks of 4096 samples (BLAS, float32) whose results are added in
    float64, so the round-off stays at the level of one block (~1e-6 relative) however many
    samples are seen, without an upcast copy of the data.
    """
    if x.dtype == np.float64:
        return np.matmul(x, w)
    out = np.zeros((*x.shape[:2], w.shape[1]))
    w32 = w.astype(x.dtype)
    block = 4096
    for i in range(0, x.shape[2], block):
        out += np.matmul(x[:, :, i : i + block], w32[i : i + block])
    return out


class Moments:
    """Accumulates SFA statistics for ``n_groups`` independent nodes of ``n_features`` inputs.

    Data is passed feature-major, ``(G, F, n)``: G groups, F features, n samples (for a row-major
    ``(n, F)`` array pass ``x.T[None]``, a view). All groups receive the same number of samples,
    weights and times per call (the nodes of one layer see the same frames).

    ``center=True`` subtracts the mean of the first chunk before any product (needed for data
    far from zero mean, such as pixel values); data that is already about centred and scaled
    (whitened SFA outputs and their expansion) can skip that pass with ``center=False``.
    """

    def __init__(self, n_features: int, n_groups: int = 1, center: bool = True) -> None:
        self.n_features = int(n_features)
        self.n_groups = int(n_groups)
        self.center = bool(center)
        g, f = self.n_groups, self.n_features
        self.shift: NDArray[np.float64] | None = None
        self.t_shift: float | None = None
        self.count = 0.0
        self.sum = np.zeros((g, f))
        self.outer = np.zeros((g, f, f))
        self.t_sum = 0.0
        self.t2_sum = 0.0
        self.xt_sum = np.zeros((g, f))
        self.diff_count = 0.0
        self.diff_outer = np.zeros((g, f, f))

    def _check(self, x: NDArray[np.floating], weights: NDArray[np.floating] | None) -> None:
        if x.ndim != 3 or x.shape[0] != self.n_groups or x.shape[1] != self.n_features:
            raise ValueError(
                f"expected samples of shape ({self.n_groups}, {self.n_features}, n), got {x.shape}"
            )
        if weights is not None and weights.shape != (x.shape[2],):
            raise ValueError(f"weights must have shape ({x.shape[2]},), got {weights.shape}")

    def add_samples(
        self,
        x: NDArray[np.floating],
        times: NDArray[np.floating],
        weights: NDArray[np.floating] | None = None,
        times_sq: NDArray[np.floating] | None = None,
    ) -> None:
        """Add samples.

        Args:
            x: ``(G, F, n)`` samples of each group.
            times: ``(n,)`` time index of each row; for a weighted row, the *sum* of the times
                of the samples it stands for.
            weights: ``(n,)`` non-negative sample counts per row (default 1).
            times_sq: ``(n,)`` sum of squared times per row (default ``times**2``, right for
                unweighted rows).
        """
        self._check(x, weights)
        n = x.shape[2]
        if n == 0:
            return
        times = np.asarray(times, dtype=np.float64)
        w64 = np.ones(n) if weights is None else np.asarray(weights, dtype=np.float64)
        if times_sq is None:
            times_sq = times**2
        if self.shift is None:
            total = w64.sum()
            if self.center:
                self.shift = _weighted_sum(x, w64[:, None])[..., 0] / total
            else:
                self.shift = np.zeros((self.n_groups, self.n_features))
            self.t_shift = float(times.sum() / total)
        t0 = self.t_shift
        t_rel = times - w64 * t0  # per row: sum over its samples of (t - t0)
        xs = x - self.shift[:, :, None].astype(x.dtype) if self.center else x
        sums = _weighted_sum(xs, np.stack([w64, t_rel], axis=1))
        self.sum += sums[..., 0]
        self.xt_sum += sums[..., 1]
        self.outer += _weighted_gram(xs, None if weights is None else w64)
        self.t_sum += float(t_rel.sum())
        self.t2_sum += float((times_sq - 2.0 * t0 * times + w64 * t0 * t0).sum())
        self.count += float(w64.sum())

    def add_differences(
        self, d: NDArray[np.floating], weights: NDArray[np.floating] | None = None
    ) -> None:
        """Add time differences ``x[t+1] - x[t]``: ``d`` is ``(G, F, n)``, weights ``(n,)``."""
        self._check(d, weights)
        if d.shape[2] == 0:
            return
        if weights is not None:
            weights = np.asarray(weights, dtype=np.float64)
            self.diff_count += float(weights.sum())
        else:
            self.diff_count += float(d.shape[2])
        self.diff_outer += _weighted_gram(d, weights)

    def finish(self, group: int = 0) -> MomentStats:
        """The statistics of one group. Raises ValueError if no samples or no differences."""
        if self.count <= 0 or self.shift is None:
            raise ValueError("no training samples were seen")
        n = self.count
        m_rel = self.sum[group] / n
        cov = self.outer[group] / n - np.outer(m_rel, m_rel)
        cov = 0.5 * (cov + cov.T)
        if self.diff_count > 0:
            dcov = self.diff_outer[group] / self.diff_count
            dcov = 0.5 * (dcov + dcov.T)
        else:
            dcov = np.zeros_like(cov)
        t_mean = self.t_sum / n
        var_t = max(self.t2_sum / n - t_mean**2, 0.0)
        cov_xt = self.xt_sum[group] / n - m_rel * t_mean
        return MomentStats(
            mean=self.shift[group] + m_rel,
            cov=cov,
            dcov=dcov,
            cov_xt=cov_xt,
            var_t=float(var_t),
            n_samples=n,
            n_differences=self.diff_count,
        )
