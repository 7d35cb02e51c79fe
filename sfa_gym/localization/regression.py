"""Regression from features ``(N, k)`` to metric positions ``(N, 2)`` (or any ``(N, m)`` target).

Four scikit-learn regressors (``clone``, ``Pipeline`` and ``GridSearchCV`` work with them; a
1-D target gives 1-D predictions, as in scikit-learn):

- :class:`LinearRegressor`: least squares with an intercept, as in the paper (optional ridge).
- :class:`QuadraticRidge`: all products of pairs of standardized features, then ridge regression.
- :class:`KNNRegressor`: mean position of the ``k`` nearest training features.
- :class:`MapDecoder`: learns each feature as a smooth map over the plane (or a line) and returns
  the position whose mapped features best match.

The first three are thin layers over scikit-learn's own pieces (``StandardScaler``,
``PolynomialFeatures``, ``LinearRegression``, ``Ridge``, ``KNeighborsRegressor``) that keep this
project's defaults and error messages. :func:`make_regressor` builds one by name (``"linear"``,
``"quadratic"``, ``"knn"``, ``"map"``). An unfitted ``predict`` raises scikit-learn's
:class:`~sklearn.exceptions.NotFittedError`.
"""

from __future__ import annotations

import numbers
from dataclasses import dataclass
from typing import Any, Literal, Protocol

import numpy as np
import scipy.sparse
from numpy.typing import ArrayLike, NDArray
from sklearn.base import BaseEstimator, RegressorMixin
from sklearn.linear_model import LinearRegression, Ridge
from sklearn.neighbors import KNeighborsRegressor
from sklearn.pipeline import Pipeline, make_pipeline
from sklearn.preprocessing import PolynomialFeatures, StandardScaler
from sklearn.utils.validation import check_is_fitted, validate_data

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

# Above this many features a k-d tree visits nearly every node; brute force by BLAS is faster.
BRUTE_FORCE_DIMENSION = 16


class Regressor(Protocol):
    """What the metrics need from a regression: ``fit(X, Y) -> self`` and ``predict(X) -> Y``."""

    def fit(self, X: ArrayLike, y: ArrayLike) -> Regressor: ...

    def predict(self, X: ArrayLike) -> NDArray[np.float64]: ...


def _precheck(data: Any, name: str, ndims: tuple[int, ...], expected: str) -> int | None:
    """Refuse text and wrongly shaped input with this project's messages, before scikit-learn's
    validation (which then handles NaN, emptiness, object arrays, data frames). Returns the
    number of rows, or None where scikit-learn's validation alone decides (sparse input)."""
    if scipy.sparse.issparse(data):
        return None  # refused by validate_data, whose message says that dense data is required
    array = np.asarray(data)
    if array.dtype.kind in "USV":
        raise TypeError(f"{name} must be a numeric array, got dtype {array.dtype}")
    if array.ndim not in ndims:
        # "Reshape your data" is the phrase scikit-learn's estimator checks look for.
        raise ValueError(
            f"{name} must have shape {expected}, got shape {array.shape}. Reshape your data: "
            "array.reshape(-1, 1) for a single feature, array.reshape(1, -1) for a single sample"
        )
    return array.shape[0]


class _Base(RegressorMixin, BaseEstimator):
    """Input validation shared by the regressors; targets may have one or several columns."""

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.target_tags.multi_output = True
        return tags

    def _validate_fit(
        self, features: ArrayLike, targets: ArrayLike
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """``features (N, k)`` and ``targets (N,)`` or ``(N, m)`` as float64; sets
        ``n_features_in_``."""
        n_x = _precheck(features, "features", (2,), "(N, k)")
        if targets is not None:  # None: validate_data says that targets are required
            n_y = _precheck(targets, "targets", (1, 2), "(N,) or (N, m), e.g. positions (N, 2)")
            if n_x is not None and n_y is not None and n_x != n_y:
                raise ValueError(
                    f"features and targets must have the same number of rows, got {n_x} and {n_y}"
                )
        x, y = validate_data(
            self, features, targets, dtype=np.float64, multi_output=True, y_numeric=True
        )
        self._targets_1d = y.ndim == 1
        return x, np.asarray(y, dtype=np.float64)

    def _as_targets(self, predictions: ArrayLike) -> NDArray[np.float64]:
        """Predictions shaped as the training targets were: ``(N,)`` or ``(N, m)`` (scikit-learn's
        ridge returns ``(N,)`` for targets ``(N, 1)``)."""
        predictions = np.asarray(predictions, dtype=np.float64)
        return (
            predictions.reshape(-1)
            if self._targets_1d
            else predictions.reshape(len(predictions), -1)
        )

    def _validate_predict(self, features: ArrayLike) -> NDArray[np.float64]:
        check_is_fitted(self)
        _precheck(features, "features", (2,), "(N, k)")
        return validate_data(self, features, dtype=np.float64, reset=False)


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
    """Mean target of the ``n_neighbors`` nearest training samples (Euclidean;
    ``KNeighborsRegressor``).

    Args:
        n_neighbors: Number of neighbours averaged (``>= 1``; at most the number of training
            samples).
        weights: ``"uniform"``: plain mean; ``"distance"``: weighted by inverse distance (an exact
            match returns the matched target; to ~1e-7 relative with brute force, which computes
            distances from dot products).
        algorithm: ``"kd_tree"``, ``"brute"`` (all distances, by matrix products) or ``"auto"``:
            the tree up to ``BRUTE_FORCE_DIMENSION`` features, brute force above, where a k-d tree
            degenerates into a slower exhaustive search.

    Attributes:
        algorithm_: ``"kd_tree"`` or ``"brute"``, the search used.
        neighbors_: the fitted ``sklearn.neighbors.KNeighborsRegressor``.
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

    def fit(self, X: ArrayLike, y: ArrayLike) -> KNNRegressor:
        """Store features ``X (N, k)`` and targets ``y (N, m)`` or ``(N,)``; needs
        ``N >= n_neighbors``."""
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
        x, y = self._validate_fit(X, y)
        if x.shape[0] < self.n_neighbors:
            raise ValueError(
                f"KNNRegressor with n_neighbors={self.n_neighbors} needs at least that many "
                f"training samples, got n_samples={x.shape[0]}"
            )
        if self.algorithm == "auto":
            self.algorithm_ = "kd_tree" if x.shape[1] <= BRUTE_FORCE_DIMENSION else "brute"
        else:
            self.algorithm_ = self.algorithm
        self.neighbors_ = KNeighborsRegressor(
            n_neighbors=int(self.n_neighbors), weights=self.weights, algorithm=self.algorithm_
        ).fit(x, y)
        return self

    def predict(self, X: ArrayLike) -> NDArray[np.float64]:
        """Predicted targets ``(N, m)`` (or ``(N,)``) for features ``X (N, k)``."""
        x = self._validate_predict(X)
        return self._as_targets(self.neighbors_.predict(x))


def _cosine_basis(
    positions: NDArray[np.float64],
    low: NDArray[np.float64],
    high: NDArray[np.float64],
    degree: int,
) -> NDArray[np.float64]:
    """``cos(i pi u) cos(j pi v)`` for ``i + j <= degree`` (``cos(i pi u)``, ``i <= degree``, on
    a line), ``(u, v)`` = ``positions (N, m)`` scaled to ``[0, 1]`` over the box ``low..high``:
    the smooth functions of a rectangle (the slowest features of a uniform random walk in a box
    are the first of them). Column 0 is the constant."""
    u = (positions - low) / (high - low)
    cu = np.cos(np.pi * np.arange(degree + 1)[None, :] * u[:, :1])
    if positions.shape[1] == 1:
        return cu
    cv = np.cos(np.pi * np.arange(degree + 1)[None, :] * u[:, 1:2])
    return np.stack(
        [cu[:, i] * cv[:, j] for i in range(degree + 1) for j in range(degree + 1 - i)], axis=1
    )


def _bending(degree: int, dims: int) -> NDArray[np.float64]:
    """``(i^2 + j^2)^2`` for each function of :func:`_cosine_basis` (``i^4`` on a line): its
    squared Laplacian integrated over the box, up to a factor common to all of them."""
    i = np.arange(degree + 1, dtype=np.float64)
    if dims == 1:
        return i**4
    return np.array([(a * a + b * b) ** 2 for a in i for b in i[: degree + 1 - int(a)]])


def _penalised_map(
    gram: NDArray[np.float64],
    cross: NDArray[np.float64],
    bending: NDArray[np.float64],
    smoothness: float,
) -> NDArray[np.float64]:
    """Coefficients ``(n_basis, k)`` minimising the mean squared residual plus the bending
    penalty, from the mean products ``gram = B'B / n`` and ``cross = B'X / n``."""
    # A tiny ridge keeps the fit defined where the positions do not pin down every basis
    # function (few positions, or positions along a few lines); the constant stays free.
    penalty = smoothness * bending + 1e-8 * (bending > 0)
    return np.linalg.solve(gram + np.diag(penalty), cross)


def _blocks(
    y: NDArray[np.float64], low: NDArray[np.float64], high: NDArray[np.float64], blocks: int
) -> NDArray[np.intp]:
    """The cross-validation block of each position: the box cut into ``blocks`` per axis."""
    cell = np.minimum(((y - low) / (high - low) * blocks).astype(np.intp), blocks - 1)
    return np.ravel_multi_index(tuple(cell.T), (blocks,) * y.shape[1])


@dataclass(frozen=True)
class _Sums:
    """The sums of products of some samples' basis ``B`` and features ``X``: a least-squares
    map and its residuals come from them alone, and the sums of all blocks but one are the
    total minus that block's."""

    n: int
    gram: NDArray[np.float64]  # B'B
    cross: NDArray[np.float64]  # B'X
    squares: NDArray[np.float64]  # X'X per feature

    @classmethod
    def of(cls, basis: NDArray[np.float64], x: NDArray[np.float64]) -> _Sums:
        return cls(len(x), basis.T @ basis, basis.T @ x, (x * x).sum(axis=0))

    def __sub__(self, other: _Sums) -> _Sums:
        return _Sums(
            self.n - other.n,
            self.gram - other.gram,
            self.cross - other.cross,
            self.squares - other.squares,
        )

    def fit(self, bending: NDArray[np.float64], smoothness: float) -> tuple[NDArray, NDArray]:
        """The penalised map's coefficients ``(n_basis, k)`` and its residual variances."""
        coef = _penalised_map(self.gram / self.n, self.cross / self.n, bending, smoothness)
        residual = self.squares - 2 * (coef * self.cross).sum(axis=0)
        residual += (coef * (self.gram @ coef)).sum(axis=0)
        return coef, np.maximum(residual, 0.0) / self.n


def _grid(axes: list[NDArray[np.float64]]) -> NDArray[np.float64]:
    """All points ``(prod of lengths, m)`` of the grid spanned by ``m`` axes."""
    return np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, len(axes))


class MapDecoder(_Base):
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

    *Smoothness*: the fit penalises ``smoothness * sum (i^2 + j^2)^2 c_ij^2`` (per unit of mean
    squared residual), which is, up to a constant factor, the integral of the squared Laplacian
    of the map over the box: a bending energy. Where training positions pin the map down it
    changes little; where none lie (a region the training run never visited, the gaps between
    the lanes of a path) the map becomes the least bent surface that joins its surroundings,
    instead of whatever the highest cosines happen to do there. ``"auto"`` chooses the penalty
    by spatial block cross-validation: the box is cut into ``cv_blocks`` x ``cv_blocks`` blocks,
    each block is held out in turn, and the penalty of :attr:`SMOOTHNESS_GRID` whose maps,
    fitted on the other blocks, decode the held-out positions best (mean absolute error on the
    coarse search grid, over at most :attr:`CV_SAMPLES` held-out samples) wins. Holding out
    whole blocks, not scattered samples, asks how well the map reaches into places it has not
    seen; scoring decoded positions, not feature residuals, keeps a block that no map fits well
    (a corner by the walls) from ruling the choice.

    Estimates lie inside the box of the training positions. Targets are 2-D positions
    ``(N, 2)``, or positions on a line (``(N, 1)`` or ``(N,)``, basis ``cos(i pi u)``).

    Args:
        degree: highest total degree ``i + j`` of the cosine basis (``(degree+1)(degree+2)/2``
            coefficients per feature in the plane).
        grid: coarse search grid points per axis; the fine search divides one coarse cell into
            4 steps each way around the best point.
        smoothness: the bending penalty (a number >= 0; 0: plain least squares), or ``"auto"``
            to choose it by spatial block cross-validation.
        cv_blocks: blocks per axis of the cross-validation (``"auto"`` only).

    Attributes:
        coef_: (n_basis - 1, k) float64, intercept_: (k,) float64. The map from the non-constant
            basis functions to the features.
        weights_: (k,) float64. Inverse variance of each feature around its map.
        low_, high_: (m,) float64. The box of the training positions, metres.
        smoothness_: float. The penalty used (the chosen one with ``"auto"``).
        cv_errors_: dict[float, float]. With ``"auto"``: for each penalty tried, the mean
            absolute error, m, of the held-out blocks' positions decoded on the coarse grid.
        n_features_in_: int.
    """

    SMOOTHNESS_GRID = (0.0, 1e-6, 1e-5, 1e-4, 3e-4, 1e-3, 3e-3, 1e-2, 1e-1)
    """The penalties ``"auto"`` chooses from (about half a decade apart around the values that
    won on the project's runs)."""

    CV_SAMPLES = 600
    """held-out samples decoded per penalty, spread evenly over all blocks (enough to rank the
    penalties; it bounds the cost on long runs)"""

    def __init__(
        self,
        degree: int = 6,
        grid: int = 61,
        smoothness: float | Literal["auto"] = "auto",
        cv_blocks: int = 3,
    ) -> None:
        self.degree = degree
        self.grid = grid
        self.smoothness = smoothness
        self.cv_blocks = cv_blocks

    def fit(self, X: ArrayLike, y: ArrayLike) -> MapDecoder:
        """Fit on features ``X (N, k)`` and positions ``y (N, 2)`` (or ``(N, 1)``, ``(N,)``)."""
        for name, low in (("degree", 1), ("grid", 5), ("cv_blocks", 2)):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < low:
                raise ValueError(f"{name} must be an int >= {low}, got {value!r}")
        smoothness = self.smoothness
        if smoothness != "auto" and (
            isinstance(smoothness, bool)
            or not isinstance(smoothness, numbers.Real)
            or not np.isfinite(smoothness)
            or smoothness < 0
        ):
            raise ValueError(f"smoothness must be a number >= 0 or 'auto', got {smoothness!r}")
        x, y = self._validate_fit(X, y)
        y = y.reshape(len(y), -1)
        if y.shape[1] > 2:
            raise ValueError(
                f"MapDecoder decodes 2-D positions (or positions on a line), got targets of shape "
                f"{y.shape}"
            )
        if len(y) < 2:
            raise ValueError(f"MapDecoder needs positions spread over an area, got {len(y)} sample")
        low, high = y.min(axis=0), y.max(axis=0)
        if np.any(high <= low):
            raise ValueError(
                f"the training positions span no area (range {high - low} m); MapDecoder needs "
                "positions spread over every axis"
            )
        self.low_, self.high_ = low, high
        basis = _cosine_basis(y, low, high, self.degree)
        bending = _bending(self.degree, y.shape[1])
        # the floor keeps a perfectly explained feature from dominating through round-off
        floor = 1e-6 * x.var(axis=0).max() + 1e-300
        if smoothness == "auto":
            self.cv_errors_ = self._block_cv(basis, x, y, bending, floor)
            smoothness = min(self.cv_errors_, key=self.cv_errors_.__getitem__)
        self.smoothness_ = float(smoothness)
        self._set_map(*_Sums.of(basis, x).fit(bending, self.smoothness_), floor)
        return self

    def _set_map(self, coef: NDArray, variance: NDArray, floor: float) -> None:
        # Features that the map explains worse count less.
        self.coef_, self.intercept_ = coef[1:], coef[0]
        self.weights_ = 1.0 / np.maximum(variance, floor)

    def _block_cv(
        self,
        basis: NDArray[np.float64],
        x: NDArray[np.float64],
        y: NDArray[np.float64],
        bending: NDArray[np.float64],
        floor: float,
    ) -> dict[float, float]:
        """Mean absolute error, m, of the held-out blocks' positions decoded on the coarse
        grid, for each penalty of :attr:`SMOOTHNESS_GRID`."""
        fold = _blocks(y, self.low_, self.high_, self.cv_blocks)
        every = max(1, -(-len(x) // self.CV_SAMPLES))
        blocks = {f: _Sums.of(basis[fold == f], x[fold == f]) for f in np.unique(fold)}
        total = _Sums.of(basis, x)
        errors = dict.fromkeys(map(float, self.SMOOTHNESS_GRID), 0.0)
        held_out = MapDecoder(self.degree, self.grid)
        held_out.low_, held_out.high_ = self.low_, self.high_
        scored = 0
        for f, block in blocks.items():
            if block.n == total.n:
                continue  # the positions fill one block: nothing to fit the others on
            rows = np.flatnonzero(fold == f)[::every]
            for smoothness in errors:
                held_out._set_map(*(total - block).fit(bending, smoothness), floor)
                decoded = held_out._decode(x[rows], refine=False)
                errors[smoothness] += float(np.abs(decoded - y[rows]).sum())
            scored += rows.size * y.shape[1]
        return {s: e / max(scored, 1) for s, e in errors.items()}

    def _mapped(self, positions: NDArray[np.float64]) -> NDArray[np.float64]:
        return _cosine_basis(positions, self.low_, self.high_, self.degree)[:, 1:] @ self.coef_ + (
            self.intercept_
        )

    def predict(self, X: ArrayLike) -> NDArray[np.float64]:
        """Positions ``(N, m)`` (``(N,)`` if fitted on 1-D targets) for features ``X (N, k)``."""
        return self._as_targets(self._decode(self._validate_predict(X)))

    def _decode(self, x: NDArray[np.float64], refine: bool = True) -> NDArray[np.float64]:
        """The best-matching positions ``(N, m)`` for validated features ``x (N, k)``, on the
        coarse grid only unless ``refine``."""
        w = np.sqrt(self.weights_)
        m = len(self.low_)
        coarse = _grid(
            [np.linspace(lo, hi, self.grid) for lo, hi in zip(self.low_, self.high_, strict=True)]
        )
        # The coarse grid's features, mapped once: every row is scored against all of them
        # with one matrix product (the squared norm of a row does not change its argmin).
        coarse_mapped = self._mapped(coarse) * w
        coarse_norms = (coarse_mapped**2).sum(axis=1)
        cell = (self.high_ - self.low_) / (self.grid - 1)
        fine = _grid([np.linspace(-1.0, 1.0, 2 * 4 + 1)] * m)
        out = np.empty((len(x), m))
        for i0 in range(0, len(x), 1024):  # bounds the (rows x candidates) score matrix
            part = x[i0 : i0 + 1024]
            score = coarse_norms[None, :] - 2.0 * (part * w) @ coarse_mapped.T
            best = coarse[score.argmin(axis=1)]
            if not refine:
                out[i0 : i0 + 1024] = best
                continue
            local = np.clip(best[:, None, :] + fine[None] * cell, self.low_, self.high_)
            n, c, _ = local.shape
            mapped = self._mapped(local.reshape(n * c, m)).reshape(n, c, -1)
            nearest = (((mapped - part[:, None, :]) * w) ** 2).sum(axis=2).argmin(axis=1)
            out[i0 : i0 + 1024] = local[np.arange(n), nearest]
        return out


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
