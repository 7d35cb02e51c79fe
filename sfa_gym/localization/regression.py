"""Regression from features ``(N, k)`` to metric positions ``(N, 2)`` (or any ``(N, m)`` target).

Four scikit-learn regressors (``clone``, ``Pipeline`` and ``GridSearchCV`` work with them; a
1-D target gives 1-D predictions, as in scikit-learn):

- :class:`LinearRegressor`: least squares with an intercept, as in the paper (optional ridge).
- :class:`QuadraticRidge`: all products of pairs of standardized features, then ridge regression.
- :class:`KNNRegressor`: mean position of the ``k`` nearest training features (an exact search
  that skips most distances by lower bounds, :mod:`sfa_gym.localization.nearest`).
- :class:`MapDecoder`: learns each feature as a smooth map over the plane (or a line) and returns
  the position whose mapped features best match.

The first three build on scikit-learn's own pieces (``StandardScaler``,
``PolynomialFeatures``, ``LinearRegression``, ``Ridge``, ``KNeighborsRegressor``) that keep this
project's defaults and error messages. :func:`make_regressor` builds one by name (``"linear"``,
``"quadratic"``, ``"knn"``, ``"map"``). An unfitted ``predict`` raises scikit-learn's
:class:`~sklearn.exceptions.NotFittedError`.
"""

from __future__ import annotations

import numbers
from typing import Any, Literal, Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray
from sklearn.linear_model import LinearRegression, Ridge
from sklearn.neighbors import KNeighborsRegressor
from sklearn.pipeline import Pipeline, make_pipeline
from sklearn.preprocessing import PolynomialFeatures, StandardScaler

from sfa_gym.localization._estimator import _Base
from sfa_gym.localization.map_decoder import MapDecoder
from sfa_gym.localization.nearest import BoundedNeighbors

__all__ = [
    "KNNRegressor",
    "LinearRegressor",
    "MapDecoder",
    "QuadraticRidge",
    "REGRESSORS",
    "Regressor",
    "make_regressor",
]

# A quadratic expansion of k inputs has k (k + 3) / 2 columns; beyond this the design matrix of a
# few thousand samples no longer fits comfortably in memory (k = 198 gives 19_899 columns).
MAX_QUADRATIC_FEATURES = 20_000

# Above this many features a k-d tree visits nearly every node; the bounded search is faster.
BRUTE_FORCE_DIMENSION = 16


class Regressor(Protocol):
    """What the metrics need from a regression: ``fit(X, Y) -> self`` and ``predict(X) -> Y``."""

    def fit(self, X: ArrayLike, y: ArrayLike) -> Regressor: ...

    def predict(self, X: ArrayLike) -> NDArray[np.float64]: ...


def _check_alpha(alpha: float) -> float:
    if isinstance(alpha, bool) or not isinstance(alpha, numbers.Real) or not np.isfinite(alpha):
        raise TypeError(f"alpha must be a finite number >= 0, got {alpha!r}")
    if alpha < 0:
        raise ValueError(f"alpha must be >= 0, got {alpha}")
    return float(alpha)


def _least_squares(alpha: float) -> LinearRegression | Ridge:
    """Least squares with an unpenalized intercept: ordinary (minimum-norm where the design is
    rank-deficient) for ``alpha = 0``, ridge otherwise."""
    return LinearRegression() if alpha == 0 else Ridge(alpha=alpha)


class LinearRegressor(_Base):
    """Least squares with an intercept: ``Y ~ X @ coef_ + intercept_`` (the paper's regression).

    Args:
        alpha: Ridge penalty on the coefficients of the standardized features (0 = ordinary least
            squares; rank-deficient designs get the minimum-norm solution in standardized units).

    Attributes:
        coef_: (k, m) float64, or (k,) for 1-D targets. Coefficients in the units of the raw
            features.
        intercept_: (m,) float64, or a float for 1-D targets.
        n_features_in_: int.
    """

    def __init__(self, alpha: float = 0.0) -> None:
        self.alpha = alpha

    def fit(self, X: ArrayLike, y: ArrayLike) -> LinearRegressor:
        """Fit on features ``X (N, k)`` and targets ``y (N, m)`` (positions, metres) or ``(N,)``."""
        alpha = _check_alpha(self.alpha)
        x, y = self._validate_fit(X, y)
        # The ridge penalty acts on standardized features so that alpha does not depend on units;
        # the regression centres the data itself.
        scale = StandardScaler(with_mean=False).fit(x).scale_
        model = _least_squares(alpha).fit(x / scale, y)
        coef = np.reshape(model.coef_, (-1, x.shape[1])) / scale  # (m, k)
        if self._targets_1d:
            self.coef_, self.intercept_ = coef[0], float(model.intercept_)
        else:
            self.coef_, self.intercept_ = coef.T, np.reshape(model.intercept_, -1)
        return self

    def predict(self, X: ArrayLike) -> NDArray[np.float64]:
        """Predicted targets ``(N, m)`` (or ``(N,)``) for features ``X (N, k)``."""
        x = self._validate_predict(X)
        return self._as_targets(x @ self.coef_ + self.intercept_)


class QuadraticRidge(_Base):
    """Ridge regression on the quadratic expansion of standardized features.

    The features are z-scored with the training mean and std, expanded to all linear and
    pairwise-product terms ``x_i x_j``, ``i <= j`` (``PolynomialFeatures(2)``), z-scored again,
    and fitted with ridge (intercept not penalized).

    Args:
        alpha: Ridge penalty on the standardized expanded features (``>= 0``; 0 = ordinary least
            squares). With ``N`` samples each column has squared norm ``N``, so ``alpha`` much
            smaller than ``N`` is a mild penalty.

    Attributes:
        pipeline_: the fitted ``StandardScaler -> PolynomialFeatures -> StandardScaler ->
            Ridge`` (``LinearRegression`` for ``alpha = 0``); ``p = k (k + 3) / 2`` expanded
            features.
        n_features_in_: int.
    """

    def __init__(self, alpha: float = 1.0) -> None:
        self.alpha = alpha

    def fit(self, X: ArrayLike, y: ArrayLike) -> QuadraticRidge:
        """Fit on features ``X (N, k)`` and targets ``y (N, m)`` or ``(N,)``."""
        alpha = _check_alpha(self.alpha)
        x, y = self._validate_fit(X, y)
        k = x.shape[1]
        n_expanded = k * (k + 3) // 2
        if n_expanded > MAX_QUADRATIC_FEATURES:
            raise ValueError(
                f"QuadraticRidge on {k} features makes {n_expanded} expanded features (limit "
                f"{MAX_QUADRATIC_FEATURES}); reduce the features first (e.g. PCA) or use "
                "LinearRegressor or KNNRegressor"
            )
        self.pipeline_: Pipeline = make_pipeline(
            StandardScaler(),
            PolynomialFeatures(degree=2, include_bias=False),
            StandardScaler(),
            _least_squares(alpha),
        ).fit(x, y)
        return self

    def predict(self, X: ArrayLike) -> NDArray[np.float64]:
        """Predicted targets ``(N, m)`` (or ``(N,)``) for features ``X (N, k)``."""
        x = self._validate_predict(X)
        return self._as_targets(self.pipeline_.predict(x))


class KNNRegressor(_Base):
    """Mean target of the ``n_neighbors`` nearest training samples (Euclidean).

    Args:
        n_neighbors: Number of neighbours averaged (``>= 1``; at most the number of training
            samples).
        weights: ``"uniform"``: plain mean; ``"distance"``: weighted by inverse distance (an exact
            match returns the matched target).
        algorithm: how the neighbours are found, all exact: ``"kd_tree"`` (scikit-learn's),
            ``"bounded"`` (:class:`~sfa_gym.localization.nearest.BoundedNeighbors`: distances
            summed directly, most of them skipped by lower bounds), ``"brute"`` (scikit-learn's
            search through every distance, computed from dot products, which can swap two
            neighbours whose distances agree to ~1e-7 relative) or ``"auto"``: the tree up to
            ``BRUTE_FORCE_DIMENSION`` features, where it is fastest, the bounded search above.

    Attributes:
        algorithm_: ``"kd_tree"``, ``"bounded"`` or ``"brute"``, the search used.
        neighbors_: the fitted search: a ``sklearn.neighbors.KNeighborsRegressor`` or a
            :class:`~sfa_gym.localization.nearest.BoundedNeighbors`.
        n_features_in_: int.
    """

    def __init__(
        self,
        n_neighbors: int = 3,
        weights: Literal["uniform", "distance"] = "uniform",
        algorithm: Literal["auto", "kd_tree", "bounded", "brute"] = "auto",
    ) -> None:
        self.n_neighbors = n_neighbors
        self.weights = weights
        self.algorithm = algorithm

    def fit(self, X: ArrayLike, y: ArrayLike) -> KNNRegressor:
        """Store features ``X (N, k)`` and targets ``y (N, m)`` or ``(N,)``; needs
        ``N >= n_neighbors``."""
        if isinstance(self.n_neighbors, bool) or not isinstance(self.n_neighbors, int | np.integer):
            raise TypeError(f"n_neighbors must be an int >= 1, got {self.n_neighbors!r}")
        if self.n_neighbors < 1:
            raise ValueError(f"n_neighbors must be >= 1, got {self.n_neighbors}")
        if self.weights not in ("uniform", "distance"):
            raise ValueError(f"weights must be 'uniform' or 'distance', got {self.weights!r}")
        if self.algorithm not in ("auto", "kd_tree", "bounded", "brute"):
            raise ValueError(
                f"algorithm must be 'auto', 'kd_tree', 'bounded' or 'brute', got {self.algorithm!r}"
            )
        x, y = self._validate_fit(X, y)
        if x.shape[0] < self.n_neighbors:
            raise ValueError(
                f"KNNRegressor with n_neighbors={self.n_neighbors} needs at least that many "
                f"training samples, got n_samples={x.shape[0]}"
            )
        if self.algorithm == "auto":
            self.algorithm_ = "kd_tree" if x.shape[1] <= BRUTE_FORCE_DIMENSION else "bounded"
        else:
            self.algorithm_ = self.algorithm
        if self.algorithm_ == "bounded":
            self.neighbors_ = BoundedNeighbors(x, int(self.n_neighbors))
            self.targets_ = np.asarray(y, dtype=np.float64)
        else:
            self.neighbors_ = KNeighborsRegressor(
                n_neighbors=int(self.n_neighbors), weights=self.weights, algorithm=self.algorithm_
            ).fit(x, y)
        return self

    def predict(self, X: ArrayLike) -> NDArray[np.float64]:
        """Predicted targets ``(N, m)`` (or ``(N,)``) for features ``X (N, k)``."""
        x = self._validate_predict(X)
        if self.algorithm_ != "bounded":
            return self._as_targets(self.neighbors_.predict(x))
        distances, indices = self.neighbors_.kneighbors(x)
        near = self.targets_[indices]  # (N, n_neighbors, ...) as scikit-learn averages them
        if self.weights == "uniform":
            return self._as_targets(np.mean(near, axis=1))
        with np.errstate(divide="ignore"):
            weights = 1.0 / distances
        exact = np.isinf(weights).any(axis=1)
        weights[exact] = np.isinf(weights[exact]).astype(np.float64)  # only the exact matches
        weights = weights.reshape(weights.shape + (1,) * (near.ndim - 2))
        return self._as_targets(np.sum(near * weights, axis=1) / np.sum(weights, axis=1))


REGRESSORS: dict[str, type[_Base]] = {
    "linear": LinearRegressor,
    "quadratic": QuadraticRidge,
    "knn": KNNRegressor,
    "map": MapDecoder,
}
"""Regressors by name, for command lines and leaderboard configs."""


def make_regressor(name: str, **params: Any) -> Regressor:
    """A fresh regressor by name (``"linear"``, ``"quadratic"``, ``"knn"``,
    ``"map"``) with ``params``."""
    if name not in REGRESSORS:
        raise ValueError(f"unknown regressor {name!r}; expected one of {sorted(REGRESSORS)}")
    return REGRESSORS[name](**params)
