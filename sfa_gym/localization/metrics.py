"""Localization metrics: mean absolute error in metres and in % of the coordinate range, the
paper's protocol of random 50/50 splits, and the position/orientation variances eta_r, eta_phi.

Features come either per location, ``(N, k)``, or per location and rotated view, ``(N, K, k)``.
In the second case a regression is fitted on every view (each labelled with its location's
position) and the estimates of the ``K`` views of a location are averaged, as in the paper
("estimations are averaged over the windows of the simulated rotation for one location").
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from sklearn.base import clone
from tqdm.auto import tqdm

from sfa_gym._checks import check_int_in
from sfa_gym.localization.regression import Regressor, make_regressor

__all__ = [
    "MAE",
    "SplitMAE",
    "eta",
    "eta_phi",
    "eta_r",
    "fit_predict",
    "mae",
    "mae_dict",
    "predict_locations",
    "random_split_mae",
    "train_test_mae",
]

RegressorFactory = Callable[[], Regressor]


def mae_dict(result: MAE | SplitMAE) -> dict[str, list[float]]:
    """MAE (m and % of the range), standard deviation and range per coordinate, rounded, as
    the protocols' results hold them (JSON types)."""
    return {
        "mae_m": np.round(result.mae_m, 5).tolist(),
        "mae_percent": np.round(result.mae_percent, 4).tolist(),
        "std_m": np.round(result.std_m, 5).tolist(),
        "range_m": np.round(result.range_m, 5).tolist(),
    }


@dataclass(frozen=True)
class MAE:
    """Mean absolute error per axis.

    Attributes:
        mae_m: (m,) float64. Mean absolute error per axis, metres.
        mae_percent: (m,) float64. ``100 * mae_m / range_m`` (NaN on an axis whose range is 0).
        std_m: (m,) float64. Standard deviation of the absolute errors per axis, metres.
        range_m: (m,) float64. Coordinate range (max - min) the percentages refer to, metres.
    """

    mae_m: NDArray[np.float64]
    mae_percent: NDArray[np.float64]
    std_m: NDArray[np.float64]
    range_m: NDArray[np.float64]


@dataclass(frozen=True)
class SplitMAE:
    """Result of :func:`random_split_mae`: means over the splits, plus the per-split values.

    Attributes:
        mae_m, mae_percent, std_m: (m,) float64. Means over the splits of the per-split :class:`MAE`
            fields.
        range_m: (m,) float64. Coordinate range of all the given positions (the test run), which the
            percentages use.
        per_split_m: (n_splits, m) float64. MAE in metres of each split.
    """

    mae_m: NDArray[np.float64]
    mae_percent: NDArray[np.float64]
    std_m: NDArray[np.float64]
    range_m: NDArray[np.float64]
    per_split_m: NDArray[np.float64]


def _as_positions(positions: ArrayLike, name: str) -> NDArray[np.float64]:
    array = np.asarray(positions, dtype=np.float64)
    if array.ndim != 2 or array.shape[0] == 0:
        raise ValueError(f"{name} must have shape (N, m), e.g. (N, 2) metres, got {array.shape}")
    if not np.all(np.isfinite(array)):
        raise ValueError(f"{name} contains NaN or infinite values")
    return array


def mae(pred: ArrayLike, true: ArrayLike, coordinate_range: ArrayLike | None = None) -> MAE:
    """Mean absolute error of ``pred (N, m)`` against ``true (N, m)`` per axis.

    The percentage is relative to ``coordinate_range`` (``(m,)`` metres) if given, else to the
    range of ``true`` (max - min per axis), as the paper reports it for the test set.
    """
    p = _as_positions(pred, "pred")
    t = _as_positions(true, "true")
    if p.shape != t.shape:
        raise ValueError(f"pred and true must have the same shape, got {p.shape} and {t.shape}")
    if coordinate_range is None:
        span = t.max(axis=0) - t.min(axis=0)
    else:
        span = np.asarray(coordinate_range, dtype=np.float64).reshape(-1)
        if span.shape != (t.shape[1],) or np.any(span < 0):
            raise ValueError(
                f"coordinate_range must be {t.shape[1]} non-negative numbers, got {span}"
            )
    errors = np.abs(p - t)
    mean_error = errors.mean(axis=0)
    percent = np.full_like(mean_error, np.nan)
    np.divide(100.0 * mean_error, span, out=percent, where=span > 0)
    return MAE(mae_m=mean_error, mae_percent=percent, std_m=errors.std(axis=0), range_m=span)


def _as_features(features: ArrayLike, n: int | None = None) -> NDArray[np.float64]:
    array = np.asarray(features, dtype=np.float64)
    if array.ndim not in (2, 3) or 0 in array.shape:
        raise ValueError(
            "features must have shape (N, k) (one vector per location) or (N, K, k) "
            f"(K rotated views per location), got {array.shape}"
        )
    if n is not None and array.shape[0] != n:
        raise ValueError(
            f"features has {array.shape[0]} locations but positions has {n} (first axes differ)"
        )
    return array


def predict_locations(regressor: Regressor, features: ArrayLike) -> NDArray[np.float64]:
    """Position estimates ``(N, m)`` for ``features (N, k)``, or the mean estimate over the views
    of each location for ``features (N, K, k)``."""
    f = _as_features(features)
    if f.ndim == 2:
        return np.asarray(regressor.predict(f), dtype=np.float64)
    n, k_views, k = f.shape
    estimates = np.asarray(regressor.predict(f.reshape(n * k_views, k)), dtype=np.float64)
    return estimates.reshape(n, k_views, -1).mean(axis=1)


def fit_predict(
    regressor: Regressor,
    train_features: ArrayLike,
    train_positions: ArrayLike,
    test_features: ArrayLike,
) -> NDArray[np.float64]:
    """Fit ``regressor`` on the training locations, return estimates ``(N_test, m)``.

    ``train_features`` ``(N, k)`` or ``(N, K, k)``: with views, every view is a training sample
    labelled with its location's position. Test estimates are averaged over views likewise.
    """
    positions = _as_positions(train_positions, "train_positions")
    f = _as_features(train_features, n=len(positions))
    if f.ndim == 3:
        n, k_views, k = f.shape
        f = f.reshape(n * k_views, k)
        positions = np.repeat(positions, k_views, axis=0)
    regressor.fit(f, positions)
    return predict_locations(regressor, test_features)


def _factory(regressor: RegressorFactory | Regressor | str) -> RegressorFactory:
    if isinstance(regressor, str):
        name = regressor
        make_regressor(name)  # fail now, with the list of names, rather than inside the loop
        return lambda: make_regressor(name)
    if not isinstance(regressor, type) and hasattr(regressor, "get_params"):
        # A scikit-learn estimator (or Pipeline) instance: every fit gets an unfitted copy, so
        # the caller's object is never fitted and no split sees another's fit.
        template = regressor
        return lambda: clone(template)
    if not callable(regressor):
        raise TypeError(
            "regressor must be a regressor name, a scikit-learn regressor (cloned for every fit) "
            f"or a zero-argument callable returning a fresh regressor, got {regressor!r}"
        )
    return regressor


def train_test_mae(
    train_features: ArrayLike,
    train_positions: ArrayLike,
    test_features: ArrayLike,
    test_positions: ArrayLike,
    regressor: RegressorFactory | Regressor | str = "linear",
) -> MAE:
    """Fit on a training run, evaluate on a test run (the paper's outdoor protocol).

    ``regressor``: a name for :func:`~sfa_gym.localization.regression.make_regressor`, an
    unfitted scikit-learn regressor (cloned, so it stays unfitted), or a zero-argument callable
    returning a fresh regressor. Percentages are relative to the test run's coordinate range.
    """
    estimates = fit_predict(_factory(regressor)(), train_features, train_positions, test_features)
    return mae(estimates, _as_positions(test_positions, "test_positions"))


def random_split_mae(
    features: ArrayLike,
    positions: ArrayLike,
    regressor_factory: RegressorFactory | Regressor | str = "linear",
    n_splits: int = 100,
    seed: int = 0,
    train_fraction: float = 0.5,
    progress: bool = False,
) -> SplitMAE:
    """The paper's simulator protocol: random splits of one (test) set of locations.

    For each of ``n_splits`` random permutations of the ``N`` locations, a fresh regressor is
    fitted on ``round(train_fraction * N)`` of them and evaluated on the rest; the per-split MAEs
    are averaged. Percentages are relative to the coordinate range of all ``positions`` (the test
    run's range, as in the paper).

    Args:
        features: ``(N, k)`` or ``(N, K, k)`` (estimates averaged over the ``K`` views of a
            location).
        positions: ``(N, m)`` ground-truth positions, metres.
        regressor_factory: Zero-argument callable returning a fresh regressor, a name for
            :func:`~sfa_gym.localization.regression.make_regressor`, or an unfitted
            scikit-learn regressor (e.g. a ``Pipeline``), cloned for every split.
        n_splits: Number of random splits (the paper: 100).
        seed: Seed of the splits; same seed, same splits, same numbers.
        train_fraction: Fraction of locations used to fit (the paper: 0.5).
        progress: Show a progress bar over the splits.
    """
    pos = _as_positions(positions, "positions")
    f = _as_features(features, n=len(pos))
    make = _factory(regressor_factory)
    check_int_in("n_splits", n_splits, 1)
    if not 0.0 < train_fraction < 1.0:
        raise ValueError(f"train_fraction must lie strictly between 0 and 1, got {train_fraction}")
    n = len(pos)
    n_train = int(round(train_fraction * n))
    if not 1 <= n_train <= n - 1:
        raise ValueError(
            f"train_fraction={train_fraction} of {n} locations leaves {n_train} to fit and "
            f"{n - n_train} to evaluate; both need at least one"
        )
    span = pos.max(axis=0) - pos.min(axis=0)
    rng = np.random.default_rng(seed)
    results = []
    for _ in tqdm(range(n_splits), desc="random splits", disable=not progress):
        order = rng.permutation(n)
        train, test = order[:n_train], order[n_train:]
        estimates = fit_predict(make(), f[train], pos[train], f[test])
        results.append(mae(estimates, pos[test], coordinate_range=span))
    per_split = np.stack([r.mae_m for r in results])
    return SplitMAE(
        mae_m=per_split.mean(axis=0),
        mae_percent=np.stack([r.mae_percent for r in results]).mean(axis=0),
        std_m=np.stack([r.std_m for r in results]).mean(axis=0),
        range_m=span,
        per_split_m=per_split,
    )


def _as_outputs(outputs: ArrayLike) -> NDArray[np.float64]:
    f = np.asarray(outputs, dtype=np.float64)
    if f.ndim != 3 or 0 in f.shape:
        raise ValueError(
            "outputs must have shape (n_positions, n_orientations, n_outputs), e.g. the features "
            f"of every rotated view at every grid position, got {f.shape}"
        )
    if not np.all(np.isfinite(f)):
        raise ValueError("outputs contains NaN or infinite values")
    return f


def _normalized(variance: NDArray[np.float64], f: NDArray[np.float64], normalize: bool):
    if not normalize:
        return variance
    total = f.reshape(-1, f.shape[-1]).var(axis=0)
    out = np.full_like(variance, np.nan)
    np.divide(variance, total, out=out, where=total > 0)
    return out


def eta_r(outputs: ArrayLike, normalize: bool = True) -> NDArray[np.float64]:
    """Mean positional variance per output: ``eta_r = < var_r f(r, phi) >_phi``.

    ``outputs`` ``(P, K, n)``: output ``j`` at position ``r`` (axis 0) and relative orientation
    ``phi`` (axis 1). Variances are population variances (``ddof=0``).

    The paper's outputs have unit variance over the training data, so its eta_r is this raw
    mean variance. With ``normalize=True`` (default) it is divided by each output's total variance
    over all ``(r, phi)`` of ``outputs``, which makes the numbers comparable for any scaling:
    a feature that depends only on position gives exactly 1 (and :func:`eta_phi` 0), one that
    depends only on orientation gives 0 (and eta_phi 1). A constant output gives NaN. Use
    ``normalize=False`` for the paper's raw definition on unit-variance outputs.
    """
    f = _as_outputs(outputs)
    return _normalized(f.var(axis=0).mean(axis=0), f, normalize)


def eta_phi(outputs: ArrayLike, normalize: bool = True) -> NDArray[np.float64]:
    """Mean orientation variance per output: ``eta_phi = < var_phi f(r, phi) >_r``.

    Same shapes and normalization as :func:`eta_r` (ideal position code: 0).
    """
    f = _as_outputs(outputs)
    return _normalized(f.var(axis=1).mean(axis=0), f, normalize)


def eta(
    outputs: ArrayLike, normalize: bool = True
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``(eta_r, eta_phi)``, each ``(n_outputs,)``; see :func:`eta_r`."""
    return eta_r(outputs, normalize), eta_phi(outputs, normalize)
