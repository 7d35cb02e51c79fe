"""Localization: regression from features to metres, metrics and plots (feature methods are
plug-ins: :mod:`sfa_gym.plugins`)."""

from __future__ import annotations

from sfa_gym.localization.metrics import (
    MAE,
    SplitMAE,
    eta,
    eta_phi,
    eta_r,
    fit_predict,
    mae,
    predict_locations,
    random_split_mae,
    train_test_mae,
)
from sfa_gym.localization.regression import (
    KNNRegressor,
    LinearRegressor,
    MapDecoder,
    QuadraticRidge,
    make_regressor,
)

# plots is not imported here: it pulls in matplotlib, which metrics users need not pay for.

__all__ = [
    "MAE",
    "KNNRegressor",
    "LinearRegressor",
    "MapDecoder",
    "QuadraticRidge",
    "SplitMAE",
    "eta",
    "eta_phi",
    "eta_r",
    "fit_predict",
    "mae",
    "make_regressor",
    "predict_locations",
    "random_split_mae",
    "train_test_mae",
]
