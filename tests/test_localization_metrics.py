"""Localization metrics on synthetic data with known answers."""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.neighbors import KNeighborsRegressor
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import StandardScaler

from sfa_gym.localization.metrics import (
    eta,
    eta_phi,
    eta_r,
    fit_predict,
    mae,
    predict_locations,
    random_split_mae,
    train_test_mae,
)
from sfa_gym.localization.regression import KNNRegressor, LinearRegressor


def _grid(n: int = 10, size: tuple[float, float] = (5.0, 2.0)) -> np.ndarray:
    xs, ys = np.meshgrid(np.linspace(0, size[0], n), np.linspace(0, size[1], n))
    return np.column_stack([xs.ravel(), ys.ravel()])


def test_mae_known_answer_in_metres_and_percent_of_range():
    true = _grid()  # x range 5 m, y range 2 m
    result = mae(true + np.array([0.1, -0.2]), true)
    np.testing.assert_allclose(result.mae_m, [0.1, 0.2])
    np.testing.assert_allclose(result.mae_percent, [2.0, 10.0])
    np.testing.assert_allclose(result.std_m, [0.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(result.range_m, [5.0, 2.0])


def test_mae_std_of_absolute_errors_and_explicit_range():
    true = np.zeros((4, 2))
    pred = np.array([[1.0, 0.0], [-1.0, 0.0], [3.0, 0.0], [-3.0, 0.0]])
    result = mae(pred, true, coordinate_range=[10.0, 4.0])
    np.testing.assert_allclose(result.mae_m, [2.0, 0.0])
    np.testing.assert_allclose(result.std_m, [1.0, 0.0])  # |errors| = 1, 1, 3, 3
    np.testing.assert_allclose(result.mae_percent, [20.0, 0.0])


def test_mae_perfect_is_zero_and_zero_range_gives_nan():
    true = np.column_stack([np.arange(5.0), np.zeros(5)])
    result = mae(true, true)
    np.testing.assert_array_equal(result.mae_m, [0.0, 0.0])
    assert result.mae_percent[0] == 0.0 and np.isnan(result.mae_percent[1])


def test_mae_refuses_mismatched_shapes():
    with pytest.raises(ValueError, match="same shape"):
        mae(np.zeros((3, 2)), np.zeros((4, 2)))
    with pytest.raises(ValueError, match=r"\(N, m\)"):
        mae(np.zeros(3), np.zeros(3))
    with pytest.raises(ValueError, match="coordinate_range"):
        mae(np.zeros((3, 2)), np.zeros((3, 2)), coordinate_range=[1.0])


def test_random_split_mae_perfect_feature_gives_zero():
    positions = _grid()
    features = positions @ np.array([[2.0, 1.0], [-1.0, 3.0]]) + 4.0
    result = random_split_mae(features, positions, LinearRegressor, n_splits=10, seed=0)
    np.testing.assert_allclose(result.mae_m, [0.0, 0.0], atol=1e-10)
    assert result.per_split_m.shape == (10, 2)
    np.testing.assert_allclose(result.range_m, [5.0, 2.0])


def test_random_split_mae_is_deterministic_given_the_seed():
    positions = _grid()
    rng = np.random.default_rng(0)
    features = positions + 0.3 * rng.normal(size=positions.shape)
    a = random_split_mae(features, positions, "linear", n_splits=20, seed=7)
    b = random_split_mae(features, positions, "linear", n_splits=20, seed=7)
    c = random_split_mae(features, positions, "linear", n_splits=20, seed=8)
    np.testing.assert_array_equal(a.per_split_m, b.per_split_m)
    assert not np.array_equal(a.per_split_m, c.per_split_m)
    np.testing.assert_allclose(a.mae_m, a.per_split_m.mean(axis=0))
    np.testing.assert_allclose(a.mae_percent, 100 * a.mae_m / a.range_m)


def test_random_split_mae_fits_on_half_and_evaluates_on_the_other():
    # With one neighbour, a location in the fitted half would be predicted exactly; the error is
    # non-zero only because every evaluated location is absent from the fitted half.
    positions = _grid()
    result = random_split_mae(positions, positions, lambda: KNNRegressor(1), n_splits=5)
    assert np.all(result.per_split_m.sum(axis=1) > 0)


def test_estimates_are_averaged_over_the_views_of_a_location():
    positions = _grid(6)
    regressor = LinearRegressor().fit(positions, positions)
    phis = 2 * np.pi * np.arange(8) / 8
    wobble = 0.5 * np.stack([np.cos(phis), np.sin(phis)], axis=1)  # sums to zero over views
    features = positions[:, None, :] + wobble[None, :, :]  # (N, K, 2)
    np.testing.assert_allclose(predict_locations(regressor, features), positions, atol=1e-12)
    per_view = regressor.predict(features.reshape(-1, 2))
    assert np.abs(per_view - np.repeat(positions, 8, axis=0)).max() > 0.4


def test_views_are_training_samples_labelled_with_their_location():
    positions = _grid(6)
    views = np.repeat(positions[:, None, :], 4, axis=1)  # (N, 4, 2)
    estimates = fit_predict(LinearRegressor(), views, positions, views[:5])
    np.testing.assert_allclose(estimates, positions[:5], atol=1e-10)
    result = random_split_mae(views, positions, "linear", n_splits=3)
    np.testing.assert_allclose(result.mae_m, 0.0, atol=1e-10)


def test_train_test_mae_fits_on_train_and_reports_test_range():
    train = _grid(8, (6.0, 6.0))
    test = _grid(5, (3.0, 4.0))
    result = train_test_mae(train, train, test + 0.1, test, regressor="linear")
    np.testing.assert_allclose(result.mae_m, [0.1, 0.1], atol=1e-10)
    np.testing.assert_allclose(result.range_m, [3.0, 4.0])


def test_random_split_mae_refuses_bad_input():
    positions = _grid(4)
    with pytest.raises(ValueError, match="16 locations but positions has 15"):
        random_split_mae(positions, positions[:15], "linear")
    with pytest.raises(ValueError, match="train_fraction"):
        random_split_mae(positions, positions, "linear", train_fraction=1.0)
    with pytest.raises(ValueError, match="n_splits"):
        random_split_mae(positions, positions, "linear", n_splits=0)
    with pytest.raises(ValueError, match="unknown regressor"):
        random_split_mae(positions, positions, "forest")
    with pytest.raises(TypeError, match="zero-argument callable"):
        random_split_mae(positions, positions, 42)
    with pytest.raises(ValueError, match="both need at least one"):
        random_split_mae(positions[:2], positions[:2], "linear", train_fraction=0.2)


def test_a_scikit_learn_regressor_is_cloned_for_every_fit():
    positions = _grid()
    rng = np.random.default_rng(3)
    features = np.tanh(positions) + 0.1 * rng.normal(size=positions.shape)
    by_name = random_split_mae(features, positions, "knn", n_splits=4)
    template = KNNRegressor()
    by_instance = random_split_mae(features, positions, template, n_splits=4)
    np.testing.assert_array_equal(by_instance.per_split_m, by_name.per_split_m)
    assert not hasattr(template, "n_features_in_")  # the caller's object stays unfitted
    pipeline = make_pipeline(StandardScaler(), KNeighborsRegressor(3))
    scaled = random_split_mae(features, positions, pipeline, n_splits=4)
    expected = random_split_mae(
        features, positions, lambda: make_pipeline(StandardScaler(), KNNRegressor()), n_splits=4
    )
    np.testing.assert_allclose(scaled.per_split_m, expected.per_split_m)
    train_test = train_test_mae(features, positions, features, positions, regressor=template)
    np.testing.assert_allclose(
        train_test.mae_m, train_test_mae(features, positions, features, positions, "knn").mae_m
    )


def _position_and_orientation_codes(n_pos: int = 30, n_orient: int = 12):
    rng = np.random.default_rng(1)
    g = rng.normal(size=n_pos)
    g = (g - g.mean()) / g.std()  # zero mean, unit variance over positions
    phis = 2 * np.pi * np.arange(n_orient) / n_orient
    h = np.sqrt(2) * np.cos(phis)  # zero mean, unit variance over orientations
    return g, h


def test_eta_perfect_position_and_pure_orientation_features():
    g, h = _position_and_orientation_codes()
    position_only = np.broadcast_to(g[:, None], (30, 12))
    orientation_only = np.broadcast_to(h[None, :], (30, 12))
    outputs = np.stack([position_only, orientation_only, 5 * position_only + 3], axis=2)
    r, phi = eta(outputs)
    np.testing.assert_allclose(r, [1.0, 0.0, 1.0], atol=1e-12)
    np.testing.assert_allclose(phi, [0.0, 1.0, 0.0], atol=1e-12)


def test_eta_of_a_mixture_known_answer():
    g, h = _position_and_orientation_codes()
    a, b = 0.8, 0.6
    outputs = (a * g[:, None] + b * h[None, :])[:, :, None]  # unit total variance
    np.testing.assert_allclose(eta_r(outputs), [a**2], atol=1e-12)
    np.testing.assert_allclose(eta_phi(outputs), [b**2], atol=1e-12)
    # Outputs with unit total variance: the paper's raw definition gives the same numbers.
    np.testing.assert_allclose(eta_r(outputs, normalize=False), [a**2], atol=1e-12)
    np.testing.assert_allclose(eta_phi(3 * outputs, normalize=False), [9 * b**2], atol=1e-12)


def test_eta_constant_output_is_nan_and_bad_shape_is_refused():
    outputs = np.zeros((5, 4, 1))
    assert np.isnan(eta_r(outputs)[0]) and np.isnan(eta_phi(outputs)[0])
    with pytest.raises(ValueError, match="n_positions, n_orientations, n_outputs"):
        eta_r(np.zeros((5, 4)))
