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

Quadratic expansions (``quadratic=k``): the second moments of expanded data are gathered from
its distinct fourth moments (:mod:`sfa_gym.sfa._fourth`) where that is faster.

Consecutive frames (:meth:`Moments.add_sequence`). Over a block of ``k`` consecutive frames
``X = [x_0 .. x_{k-1}]`` the sample second moments are ``X X^T`` and those of the ``k - 1``
differences are ``X L X^T``, ``L`` the Laplacian of the path ``0 - 1 - .. - (k-1)``. With
``L = U diag(lam) U^T`` (``U`` orthonormal: the DCT-II basis, :func:`difference_basis`) and
``z_i = X u_i``, both are sums of the same ``k`` rank-one terms: ``X X^T = sum_i z_i z_i^T`` and
``X L X^T = sum_i lam_i z_i z_i^T``. One Gram matrix per ``i`` (summed over the blocks and over
the samples of a frame) thus gives both statistics: the products over ``n`` frames drop from
``2n`` (samples and differences apart) to ``n (1 + 1/k)`` (the differences between blocks are
added directly). As ``u_i`` sums to zero for ``i > 0``, only the block means ``z_0`` carry the
data's offset, so centring touches ``1/k`` of the data.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from sfa_gym.sfa._fourth import QuadraticGram, quadratic_gram


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


@functools.cache
def difference_basis(k: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Eigenvectors and eigenvalues of the Laplacian ``L`` of a path of ``k`` frames.

    ``L = D^T D`` with ``D`` the ``(k - 1, k)`` first-difference matrix, so ``x^T L x`` is the sum
    of squared differences of consecutive entries. Its orthonormal eigenvectors are the DCT-II
    basis ``U[j, i] = c_i cos(pi i (j + 1/2) / k)`` with eigenvalues ``4 sin^2(pi i / (2 k))``;
    ``i = 0`` is the constant vector (eigenvalue 0).

    Returns:
        ``U`` ``(k, k)`` (columns are the eigenvectors) and the eigenvalues ``(k,)``.
    """
    j = np.arange(k)[:, None] + 0.5
    basis = np.sqrt(2.0 / k) * np.cos(np.pi * np.arange(k)[None, :] * j / k)
    basis[:, 0] = np.sqrt(1.0 / k)
    return basis, 4.0 * np.sin(np.pi * np.arange(k) / (2 * k)) ** 2


@functools.cache
def _anchored_basis(k: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """:func:`difference_basis` applied to ``[x_0, x_1 - x_0, .., x_{k-1} - x_0]``.

    Returns ``V`` with ``V^T [x_0, x_1 - x_0, ..] = U^T [x_0, x_1, ..]``, and the eigenvalues.
    Since ``u_i`` sums to zero for ``i > 0``, ``z_i = sum_{j > 0} u_i[j] (x_j - x_0)`` there;
    ``z_0 = sqrt(k) x_0 + sum_{j > 0} (x_j - x_0) / sqrt(k)``.
    """
    basis, lam = difference_basis(k)
    anchored = basis.copy()
    anchored[0, 0] = np.sqrt(k)
    anchored[0, 1:] = 0.0
    return anchored, lam


def sequence_block(n_frames: int, per_frame: int) -> int:
    """Frames per block for :meth:`Moments.add_sequence` (1: no blocks, add samples directly).

    Longer blocks leave fewer differences between blocks to add separately, but cost more in
    the basis change (``k`` multiply-adds per value) and give each Gram matrix fewer samples
    (``n_frames / k * per_frame``), which BLAS runs at a lower rate below a few hundred
    (measured here: about 70 % of the large-product rate at 128). So: blocks of at most 16
    frames, at least 256 samples per product, and ``n_frames`` split as evenly as that allows
    (frames left over after the last whole block are added directly).
    """
    n_blocks = max(-(-n_frames // 16), -(-256 // max(per_frame, 1)))
    k = n_frames // n_blocks
    return k if k >= 2 else 1


class Moments:
    """Accumulates SFA statistics for ``n_groups`` independent nodes of ``n_features`` inputs.

    Data is passed feature-major, ``(G, F, n)``: G groups, F features, n samples (for a row-major
    ``(n, F)`` array pass ``x.T[None]``, a view). All groups receive the same number of samples,
    weights and times per call (the nodes of one layer see the same frames).

    ``center=True`` subtracts the mean of the first chunk before any product (needed for data
    far from zero mean, such as pixel values); data that is already about centred and scaled
    (whitened SFA outputs and their expansion) can skip that pass with ``center=False``.

    ``quadratic=k`` declares the samples to be quadratic expansions of ``k``-dimensional data
    (one group, no centring): their second moments are then gathered by :class:`QuadraticGram`.
    """

    def __init__(
        self, n_features: int, n_groups: int = 1, center: bool = True, quadratic: int | None = None
    ) -> None:
        self.n_features = int(n_features)
        self.n_groups = int(n_groups)
        self.center = bool(center)
        self.quadratic = quadratic
        self._quad: QuadraticGram | None = None
        self._quad_sums: list[NDArray[np.float64]] = []
        if quadratic is not None:
            if self.n_groups != 1 or self.center:
                raise ValueError("quadratic moments need one group and no centring")
            self._quad = quadratic_gram(quadratic)
            if self._quad.n_features != self.n_features:
                raise ValueError(
                    f"{self.n_features} features are not the quadratic expansion of {quadratic}"
                )
            self._quad_sums = self._quad.zeros()
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

    def partial(self) -> Moments:
        """An empty accumulator with this one's origin, for one chunk processed elsewhere.

        The origin (shift of the data and of the time index) must be set already, by a first
        :meth:`add_samples`; the chunk's statistics are added back with :meth:`merge`.
        """
        if self.shift is None:
            raise ValueError("the origin is not set yet: add the first chunk's samples first")
        part = Moments(self.n_features, self.n_groups, self.center, self.quadratic)
        part.shift, part.t_shift = self.shift, self.t_shift
        return part

    def merge(self, other: Moments) -> None:
        """Add the statistics of ``other`` (made by :meth:`partial` of this accumulator)."""
        if other.shift is not self.shift or other.t_shift != self.t_shift:
            raise ValueError("can only merge statistics taken about the same origin")
        self.count += other.count
        self.sum += other.sum
        self.outer += other.outer
        for mine, theirs in zip(self._quad_sums, other._quad_sums, strict=True):
            mine += theirs
        self.t_sum += other.t_sum
        self.t2_sum += other.t2_sum
        self.xt_sum += other.xt_sum
        self.diff_count += other.diff_count
        self.diff_outer += other.diff_outer

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
        outer: NDArray[np.float64] | None = None,
    ) -> None:
        """Add samples.

        Args:
            x: ``(G, F, n)`` samples of each group.
            times: ``(n,)`` time index of each row; for a weighted row, the *sum* of the times
                of the samples it stands for.
            weights: ``(n,)`` non-negative sample counts per row (default 1).
            times_sq: ``(n,)`` sum of squared times per row (default ``times**2``, right for
                unweighted rows).
            outer: ``(G, F, F)`` float64 ``sum_n w_n x_n x_n^T`` if the caller has computed it
                more cheaply (only without centring); otherwise it is computed here.
        """
        self._check(x, weights)
        n = x.shape[2]
        if n == 0:
            return
        times = np.asarray(times, dtype=np.float64)
        w64 = np.ones(n) if weights is None else np.asarray(weights, dtype=np.float64)
        if times_sq is None:
            times_sq = times**2
        self._set_origin(x, times, w64)
        t0 = self.t_shift
        t_rel = times - w64 * t0  # per row: sum over its samples of (t - t0)
        xs = x - self.shift[:, :, None].astype(x.dtype) if self.center else x
        sums = _weighted_sum(xs, np.stack([w64, t_rel], axis=1))
        self.sum += sums[..., 0]
        self.xt_sum += sums[..., 1]
        if outer is not None:
            if self.center or outer.shape != self.outer.shape:
                raise ValueError("a precomputed outer product needs uncentred (G, F, F) moments")
            self.outer += outer
        elif self._quad is not None:
            self._add_quadratic(xs[0], None if weights is None else w64)
        else:
            self.outer += _weighted_gram(xs, None if weights is None else w64)
        self.t_sum += float(t_rel.sum())
        self.t2_sum += float((times_sq - 2.0 * t0 * times + w64 * t0 * t0).sum())
        self.count += float(w64.sum())

    def set_origin(self, x: NDArray[np.floating] | None, times: NDArray[np.floating]) -> None:
        """Take the mean of unweighted samples ``x`` ``(G, F, n)`` (only read when centring)
        and of their ``times`` as the origin of the statistics, before any samples are added
        (otherwise the first samples added set it). Lets every chunk be processed apart."""
        if self.shift is not None:
            raise ValueError("the origin is set already")
        times = np.asarray(times, dtype=np.float64)
        self._set_origin(x, times, np.ones(len(times)))

    def _set_origin(
        self,
        x: NDArray[np.floating] | None,
        times: NDArray[np.float64],
        w64: NDArray[np.float64],
    ) -> None:
        """Take the first samples' mean (if centring) and mean time as the origin, once."""
        if self.shift is not None:
            return
        total = w64.sum()
        if self.center:
            self.shift = _weighted_sum(x, w64[:, None])[..., 0] / total
        else:
            self.shift = np.zeros((self.n_groups, self.n_features))
        self.t_shift = float(times.sum() / total)

    def add_sequence(
        self,
        x: NDArray[np.floating],
        first_time: float,
        samples_first: bool,
        overwrite: bool = False,
    ) -> None:
        """Add ``n`` consecutive frames of one sequence: their samples and the ``n - 1`` time
        differences between them (one group, unit weights).

        Every frame holds ``P`` samples (one per node position) taken at the frame's time; a
        difference pairs the same position in consecutive frames. The second moments of both
        come from one Gram matrix per basis vector of :func:`difference_basis` (module
        docstring), in blocks of :func:`sequence_block` frames.

        Args:
            x: ``(n, P, F)`` if ``samples_first`` (a C-contiguous array, or such a slice of
                frames), else ``(F, n, P)`` with ``(n, P)`` contiguous.
            first_time: time index of frame 0; frame ``j`` is at ``first_time + j``.
            samples_first: the layout of ``x``.
            overwrite: ``x`` may be changed in place (saves a copy of the data).
        """
        if self.n_groups != 1 or self._quad is not None:
            raise ValueError("add_sequence needs one group and plain (not quadratic) moments")
        n, p, f = x.shape if samples_first else (x.shape[1], x.shape[2], x.shape[0])
        if f != self.n_features:
            raise ValueError(f"expected {self.n_features} features, got {f}")
        if n == 0:
            return

        def flat(a: NDArray[np.floating]) -> NDArray[np.floating]:  # -> (1, F, samples)
            return a.reshape(-1, f).T[None] if samples_first else a.reshape(f, -1)[None]

        times = np.repeat(first_time + np.arange(n, dtype=np.float64), p)
        self._set_origin(flat(x), times, np.ones(len(times)))
        k = sequence_block(n, p)
        nb = n // k if k > 1 else 0
        m = nb * k
        # differences not inside a block: between blocks, and among the frames after the last
        # whole block (taken first, as are the sums: the blocks may be overwritten below)
        pairs = np.array([j for j in range(n - 1) if j >= m or (j + 1) % k == 0], dtype=np.intp)
        if len(pairs):
            if samples_first:
                self.add_differences(flat(x[pairs + 1] - x[pairs]))
            else:
                self.add_differences(flat(x[:, pairs + 1] - x[:, pairs]))
        if nb:
            self._add_blocks(x, k, nb, p, first_time, samples_first, overwrite)
        if m < n:
            self.add_samples(flat(x[m:] if samples_first else x[:, m:]), times[m * p :])

    def _add_blocks(
        self,
        x: NDArray[np.floating],
        k: int,
        nb: int,
        p: int,
        first_time: float,
        samples_first: bool,
        overwrite: bool,
    ) -> None:
        """Statistics of the first ``nb`` blocks of ``k`` frames of :meth:`add_sequence`'s data
        (samples, first moments, and the differences inside each block)."""
        assert self.shift is not None and self.t_shift is not None
        f = self.n_features
        basis, lam = difference_basis(k)
        anchored, _ = _anchored_basis(k)
        vt = anchored.T.astype(x.dtype)
        # each block as its first frame and the other frames' differences from it: the z_i
        # (i > 0) are then sums of small numbers, not small sums of large ones, and keep the
        # precision of float32 differences of slowly changing features
        m = nb * k
        if samples_first:
            rel = x[:m].reshape(nb, k, p * f)
            rel = rel if overwrite else rel.copy()
            np.subtract(rel[:, 1:], rel[:, :1], out=rel[:, 1:])
            z = np.empty((k, nb, p * f), dtype=x.dtype)
            np.matmul(vt, rel, out=z.transpose(1, 0, 2))
            zs = [z[i].reshape(nb * p, f) for i in range(k)]
        else:
            rel = x[:, :m].reshape(f, nb, k, p)
            rel = rel if overwrite else rel.copy()
            np.subtract(rel[:, :, 1:], rel[:, :, :1], out=rel[:, :, 1:])
            z = np.empty((f, k, nb, p), dtype=x.dtype)
            np.matmul(vt, rel, out=z.transpose(0, 2, 1, 3))
            zs = [z[:, i].reshape(f, nb * p).T for i in range(k)]
        del rel
        if self.center:  # only the block means carry the offset (u_i sums to 0 for i > 0)
            zs[0] -= (np.sqrt(k) * self.shift[0]).astype(x.dtype)
        # first moments: frame j of block b, x_bj = sum_i u_i[j] z_ib, is at time tau_b + j, so
        # sum_j x_bj = sqrt(k) z_0b and sum_j x_bj (tau_b + j) = tau_b sqrt(k) z_0b + sum_i c_i z_ib
        # with c_i = sum_j j u_i[j] (zero for even i > 0)
        c = np.arange(k) @ basis
        tau = np.repeat(first_time + k * np.arange(nb) - self.t_shift, p)
        w0 = np.stack([np.full(nb * p, np.sqrt(k)), np.sqrt(k) * tau + c[0]]).astype(x.dtype)
        sums = (w0 @ zs[0]).astype(np.float64)
        for i in np.flatnonzero(np.abs(c[1:]) > 1e-9 * k) + 1:
            sums[1] += c[i] * zs[i].sum(axis=0)
        self.sum[0] += sums[0]
        self.xt_sum[0] += sums[1]
        t_rel = tau[:, None] + np.arange(k)[None, :]  # (nb * p, k): every sample's time
        self.t_sum += float(t_rel.sum())
        self.t2_sum += float((t_rel**2).sum())
        self.count += float(m * p)
        # second moments: one Gram matrix per basis vector, for both statistics
        outer = zs[0].T @ zs[0]  # a.T @ a on one buffer: numpy calls syrk
        douter = np.zeros_like(outer)
        for i in range(1, k):
            g = zs[i].T @ zs[i]
            outer += g
            g *= np.float32(lam[i]) if x.dtype == np.float32 else lam[i]
            douter += g
        del z, zs
        self.outer[0] += outer
        self.diff_outer[0] += douter
        self.diff_count += float(nb * (k - 1) * p)

    def _add_quadratic(self, q: NDArray[np.floating], w: NDArray[np.float64] | None) -> None:
        assert self._quad is not None
        scale = 1.0
        if w is not None and w.min() == w.max():  # one count for all rows: scale the sums
            scale, w = float(w[0]), None
        parts = self._quad.products(q, None if w is None else w.astype(q.dtype))
        for acc, part in zip(self._quad_sums, parts, strict=True):
            if scale == 1.0:
                acc += part.ravel()
            else:
                acc += scale * part.ravel().astype(np.float64)

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

    def add_difference_moments(self, outer: NDArray[np.float64], count: float) -> None:
        """Add precomputed ``sum_n w_n d_n d_n^T`` ``(G, F, F)`` of ``count`` differences."""
        if outer.shape != self.diff_outer.shape:
            raise ValueError(f"outer must have shape {self.diff_outer.shape}, got {outer.shape}")
        self.diff_outer += outer
        self.diff_count += float(count)

    def finish(self, group: int = 0) -> MomentStats:
        """The statistics of one group. Raises ValueError if no samples or no differences."""
        if self.count <= 0 or self.shift is None:
            raise ValueError("no training samples were seen")
        n = self.count
        m_rel = self.sum[group] / n
        outer = self.outer[group]
        if self._quad is not None:
            outer = outer + self._quad.assemble(self._quad_sums)
        cov = outer / n - np.outer(m_rel, m_rel)
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
