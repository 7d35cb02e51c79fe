"""Linear Slow Feature Analysis.

Given a time series ``x(t)`` (``F`` dimensions), SFA finds the linear functions
``y_j = w_j . (x - mean)`` that minimise ``delta_j = <(y_j[t+1] - y_j[t])^2>`` under zero mean,
unit variance and decorrelation, ordered slowest first (Wiskott & Sejnowski 2002).

Method: accumulate the covariance ``C`` of ``x`` and the second moment ``Cd`` of its time
differences (float64, chunk by chunk, see :mod:`._moments`); then whiten with the eigenvectors
of ``C`` and diagonalise the whitened ``Cd`` (``scipy.linalg.eigh`` twice). The eigenvalues of
the whitened ``Cd`` are the delta values, in units of 1/sample^2 (time step = one sample).

Rank deficiency: directions of ``C`` whose variance is below ``rank_tol`` times the largest
(constant or linearly dependent inputs) are dropped before whitening, with a
:class:`RankDeficiencyWarning` saying how many; whitening them would amplify round-off into
spurious "slow" outputs.

Sign convention: each output's sign is chosen so that its covariance with the time index of the
training samples (0, 1, 2, ... over all training samples in order, across sequences) is
positive: outputs rise over the training run on average. Where that correlation is negligible
(``|corr| < 1e-6``, e.g. a feature that oscillates symmetrically), the largest-magnitude entry
of the output's weight vector is made positive instead. Both rules depend on the training data
only, never on chunking or on the eigensolver's arbitrary signs. (Outputs whose delta values
coincide, such as a sine/cosine pair, are defined only up to a rotation within their subspace;
no sign rule can pin those down.)
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.linalg
from numpy.typing import NDArray
from sklearn.base import BaseEstimator, TransformerMixin
from sklearn.exceptions import NotFittedError
from sklearn.utils.validation import validate_data

from sfa_gym._checks import check_positive_int
from sfa_gym.sfa._moments import Moments, MomentStats
from sfa_gym.sfa._parallel import single_threaded_blas

__all__ = ["SFA", "RankDeficiencyWarning", "SFASolution", "solve_sfa", "sequence_starts"]

SIGN_CORR_THRESHOLD = 1e-6
"""Below this absolute correlation with time, the sign falls back to the largest weight."""


class RankDeficiencyWarning(UserWarning):
    """Input directions without variance were dropped before SFA."""


@dataclass(frozen=True)
class SFASolution:
    """A solved SFA problem: ``y = (x - mean) @ projection``.

    Attributes:
        mean: ``(F,)`` input mean.
        projection: ``(F, k)`` weights, columns ordered slowest first.
        delta: ``(k,)`` delta values (mean squared difference per sample), ascending.
        n_dropped: input directions dropped for lack of variance.
    """

    mean: NDArray[np.float64]
    projection: NDArray[np.float64]
    delta: NDArray[np.float64]
    n_dropped: int


def solve_sfa(
    stats: MomentStats,
    n_components: int | None,
    rank_tol: float,
    context: str = "SFA",
) -> SFASolution:
    """Solve SFA from accumulated statistics (see the module docstring for the method).

    Args:
        stats: finished moments.
        n_components: outputs wanted (``None``: all available). If fewer are available after
            dropping degenerate directions, fewer are returned (the warning says so).
        rank_tol: relative eigenvalue threshold for dropping covariance directions.
        context: names the node in messages, e.g. ``"layer 2 expanded SFA"``.

    Raises:
        ValueError: too few samples, no time differences, or no input variance at all.
    """
    if stats.n_samples < 2:
        raise ValueError(f"{context}: need at least 2 training samples, got {stats.n_samples:g}")
    if stats.n_differences <= 0:
        raise ValueError(
            f"{context}: no time differences: every training sequence has a single sample; "
            "SFA needs consecutive samples of the same sequence"
        )
    f = stats.cov.shape[0]
    with single_threaded_blas():  # small dense problems: threads only cost (see _parallel)
        return _solve(stats, n_components, rank_tol, context, f)


def _solve(
    stats: MomentStats, n_components: int | None, rank_tol: float, context: str, f: int
) -> SFASolution:
    evals, evecs = scipy.linalg.eigh(stats.cov)
    top = float(evals[-1])
    scale = float(np.max(np.abs(stats.mean))) if f else 0.0
    if not np.isfinite(top) or top <= 0.0 or top <= (1e-10 * scale) ** 2:
        raise ValueError(
            f"{context}: the input has no variance: all {f} input dimensions are constant over "
            f"the {stats.n_samples:g} training samples. Train on data that changes (check for "
            "blank or frozen frames, or a constant image region covering every node's field)"
        )
    keep = evals > rank_tol * top
    rank = int(keep.sum())
    n_dropped = f - rank
    want = rank if n_components is None else int(n_components)
    if n_dropped:
        extra = ""
        if want > rank:
            extra = f"; only {rank} output components are available (asked for {want})"
        warnings.warn(
            f"{context}: dropped {n_dropped} of {f} input directions whose variance is below "
            f"{rank_tol:g} x the largest (constant or linearly dependent inputs, or fewer "
            f"samples than dimensions){extra}",
            RankDeficiencyWarning,
            stacklevel=4,
        )
    k = min(want, rank)
    whiten = evecs[:, keep] / np.sqrt(evals[keep])
    dw = whiten.T @ stats.dcov @ whiten
    dvals, dvecs = scipy.linalg.eigh(0.5 * (dw + dw.T), subset_by_index=[0, k - 1])
    projection = whiten @ dvecs
    projection *= _signs(projection, stats)[None, :]
    return SFASolution(
        mean=stats.mean.copy(),
        projection=projection,
        delta=np.maximum(dvals, 0.0),
        n_dropped=n_dropped,
    )


def _signs(projection: NDArray[np.float64], stats: MomentStats) -> NDArray[np.float64]:
    """+1/-1 per output: positive covariance with time, else positive largest weight."""
    signs = np.ones(projection.shape[1])
    cov_yt = projection.T @ stats.cov_xt
    corr = cov_yt / np.sqrt(stats.var_t) if stats.var_t > 0 else np.zeros_like(cov_yt)
    for j in range(projection.shape[1]):
        if abs(corr[j]) >= SIGN_CORR_THRESHOLD:
            signs[j] = np.sign(corr[j])
        else:
            col = projection[:, j]
            signs[j] = 1.0 if col[np.argmax(np.abs(col))] >= 0 else -1.0
    return signs


def sequence_starts(sequence_ids: Any, n: int) -> NDArray[np.bool_]:
    """``(n,)`` bool: True where a new sequence starts (the id differs from the previous row)."""
    ids = np.asarray(sequence_ids)
    if ids.shape != (n,):
        raise ValueError(f"sequence_ids must have shape ({n},) (one per sample), got {ids.shape}")
    starts = np.ones(n, dtype=bool)
    starts[1:] = ids[1:] != ids[:-1]
    return starts


class SFA(TransformerMixin, BaseEstimator):
    """Linear Slow Feature Analysis, fitted in one go or chunk by chunk; a scikit-learn
    transformer (``clone``, ``Pipeline`` and ``GridSearchCV`` work).

    Args:
        n_components: number of slowest outputs to keep (``None``: as many as the input has
            non-degenerate directions).
        rank_tol: covariance eigenvalues below ``rank_tol`` times the largest are treated as
            zero and their directions dropped (with a :class:`RankDeficiencyWarning`).

    Attributes (after fitting; the eigenproblem is solved from the statistics on first use
    after each ``partial_fit``, so a chunked fit solves it once):
        mean_: ``(F,)`` training mean.
        components_: ``(k, F)`` weight vectors; ``transform(X) = (X - mean_) @ components_.T``.
        delta_values_: ``(k,)`` ascending mean squared differences of the outputs (per sample).
        n_components_: ``k``, which may be below ``n_components`` for degenerate input.
        n_dropped_: number of degenerate input directions dropped.
        n_features_in_: ``F``. n_samples_seen_: number of training samples.

    Sequences: ``fit(X, sequence_ids=ids)`` forms no difference between rows whose ids differ.
    ``partial_fit(chunk)`` treats the chunk as continuing the current sequence (the last row
    of the previous chunk is kept to form the difference across the boundary) unless
    ``new_sequence=True``, or ``sequence_ids`` says otherwise (a chunk continues the previous
    one if its first id equals the previous chunk's last id). ``y`` is ignored (SFA learns
    without labels); it is accepted so that SFA can stand in a ``Pipeline`` before a regressor.

    Example:
        >>> import numpy as np
        >>> t = np.linspace(0, 2 * np.pi, 500)
        >>> x = np.c_[np.sin(t) + 0.1 * np.sin(40 * t), np.sin(40 * t)]
        >>> y = SFA(n_components=1).fit(x).transform(x)
        >>> bool(abs(np.corrcoef(y[:, 0], np.sin(t))[0, 1]) > 0.99)
        True
    """

    def __init__(self, n_components: int | None = None, *, rank_tol: float = 1e-8) -> None:
        self.n_components = n_components
        self.rank_tol = rank_tol

    # -- training ---------------------------------------------------------------------------
    def _reset(self) -> None:
        for name in (
            "_moments",
            "_last",
            "_last_id",
            "_solution",
            "n_samples_seen_",
            "n_features_in_",
            "feature_names_in_",
        ):
            self.__dict__.pop(name, None)

    def _check_params(self) -> None:
        check_positive_int("n_components", self.n_components, none=True)
        if not (isinstance(self.rank_tol, float | int) and 0 <= self.rank_tol < 1):
            raise ValueError(f"rank_tol must be a float in [0, 1), got {self.rank_tol!r}")

    def fit(self, X: Any, y: Any = None, sequence_ids: Any = None) -> SFA:
        """Fit on ``X`` ``(n, F)`` (rows in time order); ``sequence_ids`` ``(n,)`` optional;
        ``y`` is ignored."""
        del y
        self._check_params()
        self._reset()
        x = validate_data(self, X, dtype=np.float64, ensure_min_samples=2)
        self._add(x, new_sequence=True, sequence_ids=sequence_ids)
        self._solve()
        return self

    def partial_fit(
        self, X: Any, y: Any = None, *, new_sequence: bool = False, sequence_ids: Any = None
    ) -> SFA:
        """Add a chunk ``X`` ``(n, F)`` of training data (see the class docstring on sequences);
        ``y`` is ignored."""
        del y
        self._check_params()
        first = getattr(self, "_moments", None) is None
        x = validate_data(self, X, reset=first, dtype=np.float64, ensure_min_samples=0)
        self._add(x, new_sequence, sequence_ids)
        return self

    def _add(self, x: NDArray[np.float64], new_sequence: bool, sequence_ids: Any) -> None:
        """Add validated samples ``x`` ``(n, F)`` to the statistics."""
        n, f = x.shape
        if self.n_components is not None and self.n_components > f:
            raise ValueError(f"n_components={self.n_components} exceeds the input dimension {f}")
        moments: Moments | None = getattr(self, "_moments", None)
        if moments is None:
            moments = self._moments = Moments(f)
            self.n_samples_seen_ = 0
            self._last = None
            self._last_id = None
        starts = sequence_starts(sequence_ids, n) if sequence_ids is not None else np.zeros(n, bool)
        if n == 0:
            return
        continues = not new_sequence and self._last is not None
        if sequence_ids is not None:
            first_id = np.asarray(sequence_ids)[0]
            continues = continues and self._last_id is not None and first_id == self._last_id
        starts[0] = not continues
        t = np.arange(self.n_samples_seen_, self.n_samples_seen_ + n, dtype=np.float64)
        moments.add_samples(x.T[None], t)
        # differences inside the chunk, except into rows that start a sequence
        inner = ~starts[1:]
        moments.add_differences((x[1:] - x[:-1])[inner].T[None])
        if continues:
            moments.add_differences((x[:1] - self._last).T[None])
        self._last = x[-1:].copy()
        self._last_id = None if sequence_ids is None else np.asarray(sequence_ids)[-1]
        self.n_samples_seen_ += n
        self._solution = None

    def _solve(self) -> SFASolution:
        moments: Moments | None = getattr(self, "_moments", None)
        if moments is None:
            raise NotFittedError("this SFA is not fitted yet: call fit or partial_fit first")
        if getattr(self, "_solution", None) is None:
            self._solution = solve_sfa(moments.finish(), self.n_components, self.rank_tol)
        return self._solution

    def __sklearn_is_fitted__(self) -> bool:
        return getattr(self, "_moments", None) is not None

    # -- learned attributes -----------------------------------------------------------------
    @property
    def mean_(self) -> NDArray[np.float64]:
        return self._solve().mean

    @property
    def components_(self) -> NDArray[np.float64]:
        return self._solve().projection.T

    @property
    def delta_values_(self) -> NDArray[np.float64]:
        return self._solve().delta

    @property
    def n_components_(self) -> int:
        return int(self._solve().projection.shape[1])

    @property
    def n_dropped_(self) -> int:
        return self._solve().n_dropped

    # -- inference --------------------------------------------------------------------------
    def transform(self, X: Any) -> NDArray[np.float64]:
        """Slow features of ``X`` ``(n, F)``: ``(n, k)`` float64, slowest first."""
        sol = self._solve()
        x = validate_data(self, X, reset=False, dtype=np.float64)
        return (x - sol.mean) @ sol.projection
