"""Input validation shared by the project's scikit-learn regressors (:mod:`.regression`,
:mod:`.map_decoder`): this project's error messages before scikit-learn's own checks."""

from __future__ import annotations

from typing import Any

import numpy as np
import scipy.sparse
from numpy.typing import ArrayLike, NDArray
from sklearn.base import BaseEstimator, RegressorMixin
from sklearn.utils.validation import check_is_fitted, validate_data


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
