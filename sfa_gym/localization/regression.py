"""Regression from features ``(N, k)`` to metric positions ``(N, 2)`` (or any ``(N, m)`` target).

Three estimators with the scikit-learn conventions (``__init__`` stores parameters, ``fit`` returns
``self``, learned state ends in ``_``), written in numpy/scipy only:

- :class:`LinearRegressor`: least squares with an intercept, as in the paper (optional ridge).
- :class:`QuadraticRidge`: all products of pairs of standardized features, then ridge regression.
- :class:`KNNRegressor`: mean position of the ``k`` nearest training features (``cKDTree``).
- :class:`MapDecoder`: learns each feature as a smooth map over the plane and returns the
  position whose mapped features best match (for 2-D positions).

:func:`make_regressor` builds one by name (``"linear"``, ``"quadratic"``, ``"knn"``, ``"map"``).
"""

from __future__ import annotations

from typing import Any, Literal, Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial import cKDTree

__all__ = [
    "KNNRegressor",
    "LinearRegressor",
    "MapDecoder",
    "NotFittedError",
    "QuadraticRidge",
    "REGRESSORS",
    "Regressor",
    "make_regressor",
    "quadratic_expansion",
]

# A quadratic expansion of k inputs has k (k + 3) / 2 columns; beyond this the design matrix of a
# few thousand samples no longer fits comfortably in memory (k = 198 gives 19_899 columns).
MAX_QUADRATIC_FEATURES = 20_000

# Above this many features a k-d tree visits nearly every node; brute force by BLAS is faster.
BRUTE_FORCE_DIMENSION = 16


class NotFittedError(ValueError, AttributeError):
    """Raised when ``predict`` is called before ``fit``."""


class Regressor(Protocol):
    """What the metrics need from a regression: ``fit(X, Y) -> self`` and ``predict(X) -> Y``."""

    def fit(self, features: ArrayLike, targets: ArrayLike) -> Regressor: ...

    def predict(self, features: ArrayLike) -> NDArray[np.float64]: ...


def _check_features(features: ArrayLike, name: str = "features") -> NDArray[np.float64]:
    array = np.asarray(features)
    if array.dtype == object or not (np.issubdtype(array.dtype, np.number) or array.dtype == bool):
        raise TypeError(f"{name} must be a numeric array, got dtype {array.dtype}")
    if array.ndim != 2:
        raise ValueError(f"{name} must have shape (N, k), got shape {array.shape}")
    if array.shape[0] == 0 or array.shape[1] == 0:
        raise ValueError(f"{name} must have at least one row and one column, got {array.shape}")
    array = array.astype(np.float64, copy=False)
    if not np.all(np.isfinite(array)):
        raise ValueError(f"{name} contains NaN or infinite values")
    return array


def _check_fit_input(
    features: ArrayLike, targets: ArrayLike
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    x = _check_features(features)
    y = np.asarray(targets)
    if y.ndim == 1:
        raise ValueError(
            f"targets must have shape (N, m), e.g. positions (N, 2), got shape {y.shape}; "
            "use targets[:, None] for a single output"
        )
    y = _check_features(y, name="targets")
    if y.shape[0] != x.shape[0]:
        raise ValueError(
            f"features and targets must have the same number of rows, got {x.shape[0]} and "
            f"{y.shape[0]}"
        )
    return x, y


class _FittedMixin:
    n_features_in_: int

    def _check_predict_input(self, features: ArrayLike) -> NDArray[np.float64]:
        if not hasattr(self, "n_features_in_"):
            raise NotFittedError(
                f"this {type(self).__name__} is not fitted yet; call fit(features, targets) first"
            )
        x = _check_features(features)
        if x.shape[1] != self.n_features_in_:
            raise ValueError(
                f"{type(self).__name__} was fitted on {self.n_features_in_} features, "
                f"got {x.shape[1]}"
            )
        return x


def _ridge(
    x: NDArray[np.float64], y: NDArray[np.float64], alpha: float
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Ridge with an unpenalized intercept: returns ``(coef (p, m), intercept (m,))``.

    Solved through the eigen-decomposition of the centred design's Gram matrix (``N >= p``,
    several times faster than an SVD of the tall design) or its SVD (``p > N``). Directions with
    negligible variance (constant or duplicated features) carry no information and are dropped,
    as ``lstsq``'s ``rcond`` does, which keeps ``alpha = 0`` stable for rank-deficient designs.
    """
    x_mean = x.mean(axis=0)
    y_mean = y.mean(axis=0)
    xc = x - x_mean
    yc = y - y_mean
    eps = np.finfo(np.float64).eps
    if xc.shape[0] >= xc.shape[1]:
        variances, v = np.linalg.eigh(xc.T @ xc)  # squared singular values, ascending
        # The Gram matrix squares the condition number: eigenvalues below ~1e-10 of the largest
        # are round-off (for standardized features: near-collinear directions).
        keep = variances > variances.max(initial=0.0) * max(1e-10, xc.shape[0] * eps)
        v = v[:, keep]
        coef = v @ ((v.T @ (xc.T @ yc)) / (variances[keep] + alpha)[:, None])
    else:
        u, s, vt = np.linalg.svd(xc, full_matrices=False)
        keep = s > s.max(initial=0.0) * max(xc.shape) * eps
        shrink = s[keep] / (s[keep] ** 2 + alpha)
        coef = vt[keep].T @ (shrink[:, None] * (u[:, keep].T @ yc))
    intercept = y_mean - x_mean @ coef
    return coef, intercept


def _check_alpha(alpha: float) -> float:
    if isinstance(alpha, bool) or not isinstance(alpha, int | float) or not np.isfinite(alpha):
        raise TypeError(f"alpha must be a finite number >= 0, got {alpha!r}")
    if alpha < 0:
        raise ValueError(f"alpha must be >= 0, got {alpha}")
    return float(alpha)


class LinearRegressor(_FittedMixin):
    """Least squares with an intercept: ``Y ~ X @ coef_ + intercept_`` (the paper's regression).

    Args:
        alpha: Ridge penalty on the coefficients of the standardized features (0 = ordinary least
            squares; rank-deficient designs get the minimum-norm solution).

    Attributes:
        coef_: (k, m) float64. Coefficients in the units of the raw features.
        intercept_: (m,) float64.
        n_features_in_: int.
    """

    def __init__(self, alpha: float = 0.0) -> None:
        self.alpha = alpha

    def fit(self, features: ArrayLike, targets: ArrayLike) -> LinearRegressor:
        """Fit on ``features (N, k)`` and ``targets (N, m)`` (positions in metres)."""
        alpha = _check_alpha(self.alpha)
        x, y = _check_fit_input(features, targets)
        # The ridge penalty acts on standardized features so that alpha does not depend on units.
        scale = x.std(axis=0)
        scale[scale == 0] = 1.0
        coef, intercept = _ridge(x / scale, y, alpha)
        self.coef_ = coef / scale[:, None]
        self.intercept_ = intercept
        self.n_features_in_ = x.shape[1]
        return self

    def predict(self, features: ArrayLike) -> NDArray[np.float64]:
        """Predicted targets ``(N, m)`` for ``features (N, k)``."""
        x = self._check_predict_input(features)
        return x @ self.coef_ + self.intercept_


def quadratic_expansion(features: NDArray[np.float64]) -> NDArray[np.float64]:
    """``(N, k)`` -> ``(N, k + k (k + 1) / 2)``: the inputs, then ``x_i x_j`` for ``i <= j``."""
    n, k = features.shape
    rows, cols = np.triu_indices(k)
    return np.concatenate([features, features[:, rows] * features[:, cols]], axis=1)


class QuadraticRidge(_FittedMixin):
    """Ridge regression on the quadratic expansion of standardized features.

    The features are z-scored with the training mean and std, expanded to all linear and
    pairwise-product terms (:func:`quadratic_expansion`), z-scored again, and fitted with ridge
    (intercept not penalized).

    Args:
        alpha: Ridge penalty on the standardized expanded features (``>= 0``). With ``N`` samples
            each column has squared norm ``N``, so ``alpha`` much smaller than ``N`` is a mild
            penalty.

    Attributes:
        n_features_in_: int.
        mean_, scale_: (k,) float64. Standardization of the raw features.
        expanded_mean_, expanded_scale_: (p,) float64. Standardization of the expanded
            features, ``p = k (k + 3) / 2``.
        coef_: (p, m) float64.
        intercept_: (m,) float64.
    """

    def __init__(self, alpha: float = 1.0) -> None:
        self.alpha = alpha

    def _expand(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        return quadratic_expansion((x - self.mean_) / self.scale_)

    def fit(self, features: ArrayLike, targets: ArrayLike) -> QuadraticRidge:
        """Fit on ``features (N, k)`` and ``targets (N, m)``."""
        alpha = _check_alpha(self.alpha)
        x, y = _check_fit_input(features, targets)
        k = x.shape[1]
        n_expanded = k * (k + 3) // 2
        if n_expanded > MAX_QUADRATIC_FEATURES:
            raise ValueError(
                f"QuadraticRidge on {k} features makes {n_expanded} expanded features (limit "
                f"{MAX_QUADRATIC_FEATURES}); reduce the features first (e.g. PCA) or use "
                "LinearRegressor or KNNRegressor"
            )
        self.mean_ = x.mean(axis=0)
        scale = x.std(axis=0)
        scale[scale == 0] = 1.0
        self.scale_ = scale
        expanded = self._expand(x)
        self.expanded_mean_ = expanded.mean(axis=0)
        expanded_scale = expanded.std(axis=0)
        expanded_scale[expanded_scale == 0] = 1.0
        self.expanded_scale_ = expanded_scale
        self.coef_, self.intercept_ = _ridge(
            (expanded - self.expanded_mean_) / expanded_scale, y, alpha
        )
        self.n_features_in_ = k
        return self

    def predict(self, features: ArrayLike) -> NDArray[np.float64]:
        """Predicted targets ``(N, m)`` for ``features (N, k)``."""
        x = self._check_predict_input(features)
        expanded = (self._expand(x) - self.expanded_mean_) / self.expanded_scale_
        return expanded @ self.coef_ + self.intercept_


class KNNRegressor(_FittedMixin):
    """Mean target of the ``n_neighbors`` nearest training samples (Euclidean, ``cKDTree``).

    Args:
        n_neighbors: Number of neighbours averaged (``>= 1``; at most the number of training
            samples).
        weights: ``"uniform"``: plain mean; ``"distance"``: weighted by inverse distance (an exact
            match returns the matched target).
        algorithm: ``"kd_tree"`` (``scipy.spatial.cKDTree``), ``"brute"`` (all distances, by matrix
            products in chunks) or ``"auto"``: the tree up to ``BRUTE_FORCE_DIMENSION`` features,
            brute force above, where a k-d tree degenerates into a slower exhaustive search.

    Attributes:
        tree_: scipy.spatial.cKDTree over the training features, or None (brute force).
        features_: (N, k) float64, the training features.
        targets_: (N, m) float64.
        n_features_in_: int.
    """

    def __init__(
        self,
        n_neighbors: int = 3,
        weights: Literal["uniform", "distance"] = "uniform",
        algorithm: Literal["auto", "kd_tree", "brute"] = "auto",
    ) -> None:
        self.n_neighbors = n_neighbors
        self.weights = weights
        self.algorithm = algorithm

    def fit(self, features: ArrayLike, targets: ArrayLike) -> KNNRegressor:
        """Store ``features (N, k)`` and ``targets (N, m)``; needs ``N >= n_neighbors``."""
        if isinstance(self.n_neighbors, bool) or not isinstance(self.n_neighbors, int | np.integer):
            raise TypeError(f"n_neighbors must be an int >= 1, got {self.n_neighbors!r}")
        if self.n_neighbors < 1:
            raise ValueError(f"n_neighbors must be >= 1, got {self.n_neighbors}")
        if self.weights not in ("uniform", "distance"):
            raise ValueError(f"weights must be 'uniform' or 'distance', got {self.weights!r}")
        if self.algorithm not in ("auto", "kd_tree", "brute"):
            raise ValueError(
                f"algorithm must be 'auto', 'kd_tree' or 'brute', got {self.algorithm!r}"
            )
        x, y = _check_fit_input(features, targets)
        if x.shape[0] < self.n_neighbors:
            raise ValueError(
                f"KNNRegressor with n_neighbors={self.n_neighbors} needs at least that many "
                f"training samples, got {x.shape[0]}"
            )
        use_tree = self.algorithm == "kd_tree" or (
            self.algorithm == "auto" and x.shape[1] <= BRUTE_FORCE_DIMENSION
        )
        self.tree_ = cKDTree(x) if use_tree else None
        self.features_ = x
        self.targets_ = y
        self.n_features_in_ = x.shape[1]
        return self

    def predict(self, features: ArrayLike) -> NDArray[np.float64]:
        """Predicted targets ``(N, m)`` for ``features (N, k)``."""
        x = self._check_predict_input(features)
        k = int(self.n_neighbors)
        if self.tree_ is not None:
            distances, index = self.tree_.query(x, k=k)
            distances = distances.reshape(len(x), k)
            index = index.reshape(len(x), k)
        else:
            distances, index = self._brute_neighbours(x, k)
        neighbours = self.targets_[index]  # (N, k, m)
        if self.weights == "uniform":
            return neighbours.mean(axis=1)
        exact = distances == 0
        with np.errstate(divide="ignore"):
            w = 1.0 / distances
        # Where a query coincides with training samples, only those samples count.
        has_exact = exact.any(axis=1)
        w[has_exact] = exact[has_exact].astype(np.float64)
        w /= w.sum(axis=1, keepdims=True)
        return np.einsum("nk,nkm->nm", w, neighbours)

    def _brute_neighbours(
        self, x: NDArray[np.float64], k: int
    ) -> tuple[NDArray[np.float64], NDArray[np.intp]]:
        """Distances and indices ``(n, k)`` of the ``k`` nearest training samples, any order."""
        train = self.features_
        train_sq = np.einsum("ij,ij->i", train, train)
        index = np.empty((len(x), k), dtype=np.intp)
        distances = np.empty((len(x), k))
        # Chunks of queries keep the (chunk, N) distance matrix near 64 MB.
        chunk = max(1, (8 << 20) // len(train))
        for start in range(0, len(x), chunk):
            part = slice(start, start + chunk)
            q = x[part]
            d2 = train_sq[None, :] - 2.0 * (q @ train.T)
            if k < len(train):
                index[part] = np.argpartition(d2, k - 1, axis=1)[:, :k]
            else:
                index[part] = np.arange(len(train))
            # Exact distances of the chosen neighbours (the expansion loses exact zeros).
            distances[part] = np.linalg.norm(q[:, None, :] - train[index[part]], axis=2)
        return distances, index


def _cosine_basis(positions: NDArray[np.float64], low, high, degree: int) -> NDArray[np.float64]:
    """``cos(i pi u) cos(j pi v)`` for ``i + j <= degree``, ``(u, v)`` = positions scaled to
    ``[0, 1]`` over the box ``low..high``: the smooth functions of a rectangle (the slowest
    features of a uniform random walk in a box are the first of them)."""
    u = (positions - low) / (high - low)
    cu = np.cos(np.pi * np.arange(degree + 1)[None, :] * u[:, :1])
    cv = np.cos(np.pi * np.arange(degree + 1)[None, :] * u[:, 1:2])
    return np.stack(
        [cu[:, i] * cv[:, j] for i in range(degree + 1) for j in range(degree + 1 - i)], axis=1
    )


class MapDecoder(_FittedMixin):
    """Position by inverting a smooth map of each feature over the plane.

    Instead of regressing position on the features, ``fit`` learns the forward map: each
    feature as a smooth function of position (a least-squares fit of the cosine basis
    ``cos(i pi u) cos(j pi v)``, ``i + j <= degree``, over the bounding box of the training
    positions), and the variance of each feature around its map. ``predict`` returns the
    position whose mapped features are nearest to the observed ones (squared distance weighted
    by the inverse variances: the maximum-likelihood position under independent Gaussian
    noise), searched on a coarse grid over the box and refined on a fine grid around the best
    cell. Slow features of a box-shaped arena look like the basis functions themselves
    (cosines along the axes and their products), whose inverse no low-order regression of
    position on features represents well near the walls; the forward map has few parameters
    per feature, so it needs few labelled positions.

    Estimates lie inside the box of the training positions. Targets must be 2-D positions.

    Args:
        degree: highest total degree ``i + j`` of the cosine basis (``(degree+1)(degree+2)/2``
            coefficients per feature).
        grid: coarse search grid points per axis; the fine search divides one coarse cell into
            4 steps each way around the best point.
    """

    def __init__(self, degree: int = 6, grid: int = 61) -> None:
        self.degree = degree
        self.grid = grid

    def fit(self, features: ArrayLike, targets: ArrayLike) -> MapDecoder:
        x, y = _check_fit_input(features, targets)
        for name, low in (("degree", 1), ("grid", 5)):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < low:
                raise ValueError(f"{name} must be an int >= {low}, got {value!r}")
        if y.shape[1] != 2:
            raise ValueError(f"MapDecoder decodes 2-D positions, got targets of shape {y.shape}")
        low, high = y.min(axis=0), y.max(axis=0)
        if np.any(high <= low):
            raise ValueError(
                f"the training positions span no area (range {high - low} m); MapDecoder needs "
                "positions spread over both axes"
            )
        basis = _cosine_basis(y, low, high, self.degree)
        coef, intercept = _ridge(basis[:, 1:], x, 1e-8 * len(x))
        residual = x - (basis[:, 1:] @ coef + intercept)
        # Features that the map explains worse count less; the floor keeps a perfectly explained
        # feature from dominating through round-off.
        variance = residual.var(axis=0)
        self.weights_ = 1.0 / np.maximum(variance, 1e-6 * x.var(axis=0).max() + 1e-300)
        self.coef_, self.intercept_ = coef, intercept
        self.low_, self.high_ = low, high
        self.n_features_in_ = x.shape[1]
        return self

    def _mapped(self, positions: NDArray[np.float64]) -> NDArray[np.float64]:
        return _cosine_basis(positions, self.low_, self.high_, self.degree)[:, 1:] @ self.coef_ + (
            self.intercept_
        )

    def predict(self, features: ArrayLike) -> NDArray[np.float64]:
        x = self._check_predict_input(features)
        w = np.sqrt(self.weights_)
        axes = [
            np.linspace(lo, hi, self.grid) for lo, hi in zip(self.low_, self.high_, strict=True)
        ]
        coarse = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 2)
        # The coarse grid's features, mapped once: every row is scored against all of them
        # with one matrix product (the squared norm of a row does not change its argmin).
        coarse_mapped = self._mapped(coarse) * w
        coarse_norms = (coarse_mapped**2).sum(axis=1)
        cell = (self.high_ - self.low_) / (self.grid - 1)
        offsets = np.linspace(-1.0, 1.0, 2 * 4 + 1)
        fine = np.stack(np.meshgrid(offsets, offsets, indexing="ij"), axis=-1).reshape(-1, 2)
        out = np.empty((len(x), 2))
        for i0 in range(0, len(x), 1024):  # bounds the (rows x candidates) score matrix
            part = x[i0 : i0 + 1024]
            score = coarse_norms[None, :] - 2.0 * (part * w) @ coarse_mapped.T
            best = coarse[score.argmin(axis=1)]
            local = np.clip(best[:, None, :] + fine[None] * cell, self.low_, self.high_)
            n, c, _ = local.shape
            mapped = self._mapped(local.reshape(n * c, 2)).reshape(n, c, -1)
            nearest = (((mapped - part[:, None, :]) * w) ** 2).sum(axis=2).argmin(axis=1)
            out[i0 : i0 + 1024] = local[np.arange(n), nearest]
        return out


REGRESSORS: dict[str, type] = {
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
