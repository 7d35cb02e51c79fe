"""Regressions from features to positions: known-answer recovery and input validation."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from sklearn.base import clone
from sklearn.exceptions import NotFittedError
from sklearn.model_selection import GridSearchCV
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import StandardScaler
from sklearn.utils.estimator_checks import parametrize_with_checks

from sfa_gym.localization.map_decoder import _cosine_basis
from sfa_gym.localization.regression import (
    KNNRegressor,
    LinearRegressor,
    MapDecoder,
    QuadraticRidge,
    make_regressor,
)


def _data(n: int = 200, k: int = 3, seed: int = 0):
    rng = np.random.default_rng(seed)
    return rng.normal(size=(n, k)), rng


def test_linear_recovers_an_affine_map_exactly():
    x, rng = _data()
    a = rng.normal(size=(3, 2))
    b = np.array([1.5, -2.0])
    model = LinearRegressor().fit(x, x @ a + b)
    np.testing.assert_allclose(model.coef_, a, atol=1e-10)
    np.testing.assert_allclose(model.intercept_, b, atol=1e-10)
    x_new, _ = _data(50, seed=1)
    np.testing.assert_allclose(model.predict(x_new), x_new @ a + b, atol=1e-10)


def test_linear_matches_lstsq_with_an_intercept_column_on_noisy_data():
    x, rng = _data()
    y = rng.normal(size=(200, 2))
    design = np.column_stack([x, np.ones(len(x))])
    expected = design @ np.linalg.lstsq(design, y, rcond=None)[0]
    np.testing.assert_allclose(LinearRegressor().fit(x, y).predict(x), expected, atol=1e-10)


def test_linear_with_more_features_than_samples_is_the_minimum_norm_fit():
    x, rng = _data(20, k=50)
    y = rng.normal(size=(20, 2))
    model = LinearRegressor().fit(x, y)
    np.testing.assert_allclose(model.predict(x), y, atol=1e-9)  # interpolates
    # The minimum-norm solution in standardized feature units (the regressor's internal units).
    mean, scale = x.mean(axis=0), x.std(axis=0)
    coef = np.linalg.lstsq((x - mean) / scale, y - y.mean(axis=0), rcond=None)[0]
    x_new, _ = _data(5, k=50, seed=4)
    expected = (x_new - mean) / scale @ coef + y.mean(axis=0)
    np.testing.assert_allclose(model.predict(x_new), expected, atol=1e-9)


def test_linear_handles_a_constant_and_a_duplicated_feature():
    x, rng = _data()
    x = np.column_stack([x, np.full(len(x), 7.0), x[:, 0]])
    y = x[:, :2] @ np.array([[1.0, 2.0], [3.0, 4.0]])
    np.testing.assert_allclose(LinearRegressor().fit(x, y).predict(x), y, atol=1e-9)


def test_ridge_penalty_shrinks_the_coefficients():
    x, rng = _data()
    y = x @ rng.normal(size=(3, 2)) + 0.1 * rng.normal(size=(200, 2))
    norms = [np.linalg.norm(LinearRegressor(alpha=a).fit(x, y).coef_) for a in (0.0, 10.0, 1e4)]
    assert norms[0] > norms[1] > norms[2]


def test_quadratic_expansion_columns():
    model = QuadraticRidge().fit(np.array([[2.0, 3.0], [1.0, 5.0], [0.0, 1.0]]), np.eye(3)[:, :2])
    expansion = model.pipeline_.named_steps["polynomialfeatures"]
    names = expansion.get_feature_names_out(["a", "b"]).tolist()
    assert names == ["a", "b", "a^2", "a b", "b^2"]  # the inputs, then x_i x_j for i <= j


def test_quadratic_ridge_is_ridge_on_the_standardized_expansion_with_a_free_intercept():
    x, rng = _data(120)
    y = np.column_stack([x[:, 0] * x[:, 1], x[:, 2] ** 2]) + 0.3 * rng.normal(size=(120, 2))
    alpha = 5.0

    def standardized_expansion(data, train):
        def z(a, ref):
            return (a - ref.mean(axis=0)) / ref.std(axis=0)

        def expand(a):
            rows, cols = np.triu_indices(a.shape[1])
            return np.concatenate([a, a[:, rows] * a[:, cols]], axis=1)

        return z(expand(z(data, train)), expand(z(train, train)))

    design = standardized_expansion(x, x)
    # The intercept is the targets' mean: the expanded columns are centred and not penalized.
    coef = np.linalg.solve(
        design.T @ design + alpha * np.eye(design.shape[1]), design.T @ (y - y.mean(axis=0))
    )
    x_new, _ = _data(30, seed=5)
    expected = standardized_expansion(x_new, x) @ coef + y.mean(axis=0)
    np.testing.assert_allclose(QuadraticRidge(alpha).fit(x, y).predict(x_new), expected, atol=1e-9)


def test_quadratic_ridge_recovers_a_quadratic_map_where_linear_cannot():
    x, rng = _data(300)
    y = np.column_stack([x[:, 0] ** 2 - x[:, 1] * x[:, 2] + 0.5, 2 * x[:, 1] + x[:, 0] * x[:, 1]])
    x_new, _ = _data(100, seed=2)
    y_new = np.column_stack(
        [
            x_new[:, 0] ** 2 - x_new[:, 1] * x_new[:, 2] + 0.5,
            2 * x_new[:, 1] + x_new[:, 0] * x_new[:, 1],
        ]
    )
    quadratic = QuadraticRidge(alpha=0.0).fit(x, y)
    np.testing.assert_allclose(quadratic.predict(x_new), y_new, atol=1e-8)
    # A mild penalty barely changes the fit.
    assert np.abs(QuadraticRidge(alpha=1e-3).fit(x, y).predict(x_new) - y_new).max() < 1e-2
    linear_error = np.abs(LinearRegressor().fit(x, y).predict(x_new) - y_new).mean()
    assert linear_error > 0.3


@pytest.mark.parametrize("algorithm", ["kd_tree", "bounded", "brute"])
@pytest.mark.parametrize("k", [2, 40])
def test_knn_averages_the_nearest_training_targets(algorithm, k):
    x, rng = _data(60, k=k)
    y = rng.normal(size=(60, 2))
    queries, _ = _data(10, k=k, seed=3)
    distances = np.linalg.norm(queries[:, None] - x[None], axis=2)
    nearest = np.argsort(distances, axis=1)[:, :3]
    expected = y[nearest].mean(axis=1)
    model = KNNRegressor(3, algorithm=algorithm).fit(x, y)
    assert model.algorithm_ == algorithm
    np.testing.assert_allclose(model.predict(queries), expected)
    # One neighbour at a training point returns its target; so does distance weighting.
    np.testing.assert_array_equal(KNNRegressor(1, algorithm=algorithm).fit(x, y).predict(x), y)
    weighted = KNNRegressor(4, weights="distance", algorithm=algorithm).fit(x, y)
    # Brute force gets distances from dot products: an exact match is ~1e-8, not 0, away.
    np.testing.assert_allclose(weighted.predict(x), y, rtol=1e-5 if algorithm == "brute" else 1e-7)
    # As many neighbours as samples: the mean of all targets.
    everything = KNNRegressor(60, algorithm=algorithm).fit(x, y).predict(queries)
    np.testing.assert_allclose(everything, np.broadcast_to(y.mean(axis=0), (10, 2)))


def test_knn_auto_uses_a_tree_only_in_few_dimensions():
    x, rng = _data(30, k=3)
    y = rng.normal(size=(30, 2))
    assert KNNRegressor().fit(x, y).algorithm_ == "kd_tree"
    wide, _ = _data(30, k=40)
    assert KNNRegressor().fit(wide, y).algorithm_ == "bounded"


@pytest.mark.parametrize("algorithm", ["kd_tree", "bounded", "brute"])
def test_knn_distance_weights(algorithm):
    x = np.array([[0.0], [1.0], [3.0]])
    y = np.array([[0.0], [10.0], [30.0]])
    # Query at 0.5: neighbours 0 and 1 at distance 0.5 each -> mean 5; at 0.25: weights 4 and 4/3.
    model = KNNRegressor(2, weights="distance", algorithm=algorithm).fit(x, y)
    np.testing.assert_allclose(model.predict([[0.5], [0.25]]), [[5.0], [10.0 * (4 / 3) / (16 / 3)]])


@settings(max_examples=25, deadline=None)
@given(
    scale=st.lists(st.floats(1e-3, 1e3), min_size=3, max_size=3),
    shift=st.lists(st.floats(-1e3, 1e3), min_size=3, max_size=3),
)
def test_linear_prediction_does_not_depend_on_feature_units(scale, shift):
    x, rng = _data(80)
    y = rng.normal(size=(80, 2))
    reference = LinearRegressor().fit(x, y).predict(x)
    x_scaled = x * np.array(scale) + np.array(shift)
    np.testing.assert_allclose(
        LinearRegressor().fit(x_scaled, y).predict(x_scaled), reference, atol=1e-6
    )


def test_make_regressor_by_name():
    assert isinstance(make_regressor("linear"), LinearRegressor)
    assert make_regressor("quadratic", alpha=2.0).alpha == 2.0
    assert make_regressor("knn", n_neighbors=5).n_neighbors == 5
    with pytest.raises(ValueError, match="unknown regressor 'cubic'.*knn"):
        make_regressor("cubic")


@pytest.mark.parametrize("cls", [LinearRegressor, QuadraticRidge, KNNRegressor, MapDecoder])
def test_bad_input_is_refused_clearly(cls):
    x, rng = _data(20)
    y = rng.normal(size=(20, 2))
    with pytest.raises(NotFittedError, match="not fitted"):
        cls().predict(x)
    with pytest.raises(ValueError, match=r"targets must have shape \(N,\) or \(N, m\)"):
        cls().fit(x, y[:, :, None])
    with pytest.raises(ValueError, match="same number of rows"):
        cls().fit(x, y[:10])
    with pytest.raises(ValueError, match=r"shape \(N, k\)"):
        cls().fit(x[:, 0], y)
    bad = x.copy()
    bad[3, 1] = np.nan
    with pytest.raises(ValueError, match="NaN"):
        cls().fit(bad, y)
    with pytest.raises(TypeError, match="numeric"):
        cls().fit(np.full((20, 3), "a"), y)
    with pytest.raises(TypeError, match="numeric"):
        cls().fit(x, np.full((20, 2), "a"))
    model = cls().fit(x, y)
    with pytest.raises(ValueError, match=f"X has 2 features, but {cls.__name__} is expecting 3"):
        model.predict(x[:, :2])
    with pytest.raises(ValueError, match=r"shape \(N, k\), got shape \(3,\)"):
        model.predict(x[0])


@pytest.mark.parametrize("cls", [LinearRegressor, QuadraticRidge, KNNRegressor, MapDecoder])
def test_one_dimensional_targets_give_one_dimensional_predictions(cls):
    x, rng = _data(40)
    y = rng.uniform(0, 6, size=40)
    single = cls().fit(x, y).predict(x)
    column = cls().fit(x, y[:, None]).predict(x)
    assert single.shape == (40,) and column.shape == (40, 1)
    np.testing.assert_allclose(single, column[:, 0])


def test_bad_parameters_are_refused_clearly():
    x, rng = _data(20)
    y = rng.normal(size=(20, 2))
    with pytest.raises(ValueError, match="alpha must be >= 0"):
        LinearRegressor(alpha=-1.0).fit(x, y)
    with pytest.raises(TypeError, match="alpha"):
        QuadraticRidge(alpha="big").fit(x, y)
    with pytest.raises(ValueError, match="at least that many"):
        KNNRegressor(30).fit(x, y)
    with pytest.raises(ValueError, match="n_neighbors must be >= 1"):
        KNNRegressor(0).fit(x, y)
    with pytest.raises(ValueError, match="weights"):
        KNNRegressor(weights="gaussian").fit(x, y)
    with pytest.raises(ValueError, match="algorithm"):
        KNNRegressor(algorithm="ball_tree").fit(x, y)
    with pytest.raises(ValueError, match="expanded features.*PCA"):
        QuadraticRidge().fit(np.zeros((3, 300)), np.zeros((3, 2)))


# -- map decoder ---------------------------------------------------------------------------------


def _cosine_features(xy: np.ndarray, noise: float = 0.0, seed: int = 0) -> np.ndarray:
    """The slowest features of a random walk in the box [0, 6]^2: cosines along the axes and
    their product, which no low-order regression of position on them inverts near the walls."""
    u = xy / 6.0
    f = np.stack(
        [
            np.cos(np.pi * u[:, 1]),
            np.cos(np.pi * u[:, 0]),
            np.cos(np.pi * u[:, 0]) * np.cos(np.pi * u[:, 1]),
            np.cos(2 * np.pi * u[:, 1]),
        ],
        axis=1,
    )
    return f + noise * np.random.default_rng(seed).standard_normal(f.shape)


def test_map_decoder_inverts_cosine_features_where_linear_regression_cannot():
    rng = np.random.default_rng(0)
    train, test = rng.uniform(0, 6, (300, 2)), rng.uniform(0.1, 5.9, (200, 2))
    train[:4] = [[0, 0], [6, 6], [0, 6], [6, 0]]  # the box's corners bound the estimates
    decoder = make_regressor("map", degree=3).fit(_cosine_features(train), train)
    error = np.abs(decoder.predict(_cosine_features(test)) - test).mean()
    linear = make_regressor("linear").fit(_cosine_features(train), train)
    linear_error = np.abs(linear.predict(_cosine_features(test)) - test).mean()
    assert error < 0.02  # metres: the fine grid's resolution, far below linear's error
    assert linear_error > 10 * error


def test_map_decoder_weights_the_noisier_feature_less():
    rng = np.random.default_rng(1)
    train, test = rng.uniform(0, 6, (400, 2)), rng.uniform(0.5, 5.5, (200, 2))
    f_train, f_test = _cosine_features(train), _cosine_features(test)
    noisy_train = np.c_[f_train, f_train[:, 0] + rng.normal(0, 1.0, len(train))]
    noisy_test = np.c_[f_test, f_test[:, 0] + rng.normal(0, 1.0, len(test))]
    decoder = MapDecoder(degree=3).fit(noisy_train, train)
    assert decoder.weights_[4] < decoder.weights_[0] / 100
    assert np.abs(decoder.predict(noisy_test) - test).mean() < 0.05


def test_map_decoder_rejects_bad_targets_and_settings():
    f = np.random.default_rng(0).normal(size=(20, 3))
    with pytest.raises(ValueError, match="2-D positions"):
        MapDecoder().fit(f, np.zeros((20, 3)))
    with pytest.raises(ValueError, match="span no area"):
        MapDecoder().fit(f, np.c_[np.arange(20.0), np.zeros(20)])
    with pytest.raises(ValueError, match="degree must be an int >= 1"):
        MapDecoder(degree=0).fit(f, np.random.default_rng(1).uniform(size=(20, 2)))
    with pytest.raises(NotFittedError):
        MapDecoder().predict(f)


def _landmark_features(xy: np.ndarray, noise: float, rng: np.random.Generator) -> np.ndarray:
    """Two axis cosines and the nearness of three landmarks: maps that the cosine basis fits
    only with its higher terms, which swing wherever no training position holds them."""
    u = xy / 6.0
    near = [1.0 / (0.3 + np.hypot(*(xy - landmark).T)) for landmark in ((4.5, 4), (5, 1), (1, 5))]
    f = np.stack([np.cos(np.pi * u[:, 0]), np.cos(np.pi * u[:, 1]), *near], axis=1)
    return f + rng.normal(0.0, noise, f.shape)


def test_map_decoder_smoothness_reaches_into_a_region_never_trained_on():
    rng = np.random.default_rng(0)
    train = rng.uniform(0, 6, (3000, 2))
    train = train[~np.all(train < 2.0, axis=1)]  # the 2 x 2 m corner is never visited
    hole, rest = rng.uniform(0.2, 1.8, (300, 2)), rng.uniform(2.2, 5.8, (300, 2))
    f_train = _landmark_features(train, 0.05, rng)
    f_hole, f_rest = (_landmark_features(p, 0.05, rng) for p in (hole, rest))
    plain = MapDecoder(smoothness=0.0).fit(f_train, train)
    smooth = MapDecoder().fit(f_train, train)  # "auto": block cross-validation
    assert smooth.smoothness_ > 0
    assert set(smooth.cv_errors_) == set(MapDecoder.SMOOTHNESS_GRID)
    assert smooth.cv_errors_[smooth.smoothness_] == min(smooth.cv_errors_.values())
    error = {
        (name, part): np.abs(decoder.predict(f) - p).mean()
        for name, decoder in (("plain", plain), ("smooth", smooth))
        for part, f, p in (("hole", f_hole, hole), ("rest", f_rest, rest))
    }
    assert error["smooth", "hole"] < 0.6 * error["plain", "hole"]
    assert error["smooth", "rest"] < 1.2 * error["plain", "rest"]


def test_map_decoder_without_smoothness_is_least_squares():
    rng = np.random.default_rng(3)
    train = rng.uniform(0, 6, (500, 2))
    f = _landmark_features(train, 0.05, rng)
    decoder = MapDecoder(degree=4, smoothness=0.0).fit(f, train)
    basis = _cosine_basis(train, train.min(axis=0), train.max(axis=0), 4)
    coef = np.linalg.lstsq(basis, f, rcond=None)[0]
    np.testing.assert_allclose(decoder.coef_, coef[1:], atol=1e-5)
    np.testing.assert_allclose(decoder.intercept_, coef[0], atol=1e-5)
    assert not hasattr(decoder, "cv_errors_")


@pytest.mark.parametrize("smoothness", [-1.0, float("nan"), "cv", True])
def test_map_decoder_rejects_a_bad_smoothness(smoothness):
    f = np.random.default_rng(0).normal(size=(20, 3))
    with pytest.raises(ValueError, match=r"smoothness must be a number >= 0 or 'auto', got"):
        MapDecoder(smoothness=smoothness).fit(f, np.random.default_rng(1).uniform(size=(20, 2)))


def test_map_decoder_on_a_line():
    rng = np.random.default_rng(2)
    train, test = rng.uniform(0, 6, 200), rng.uniform(0.2, 5.8, 50)
    train[:2] = [0.0, 6.0]

    def features(u):
        return np.stack([np.cos(np.pi * u / 6), np.cos(2 * np.pi * u / 6)], axis=1)

    decoder = MapDecoder(degree=3).fit(features(train), train)
    estimates = decoder.predict(features(test))
    assert estimates.shape == (50,)
    assert np.abs(estimates - test).max() < 0.02  # the fine grid's step: 6 m / 60 / 4


# -- scikit-learn conventions --------------------------------------------------------------------


def _expected_failed_checks(estimator):
    if isinstance(estimator, MapDecoder):
        return {
            "check_regressor_multioutput": "MapDecoder decodes positions on a line or in the "
            "plane (1 or 2 target columns); the check fits 5 target columns"
        }
    return {}


@parametrize_with_checks(
    [LinearRegressor(), QuadraticRidge(), KNNRegressor(), MapDecoder()],
    expected_failed_checks=_expected_failed_checks,
)
def test_scikit_learn_estimator_checks(estimator, check):
    check(estimator)


def test_clone_pipeline_and_grid_search():
    x, rng = _data(120)
    y = np.column_stack([x[:, 0] ** 2, x[:, 1] * x[:, 2]]) + 0.05 * rng.normal(size=(120, 2))
    original = QuadraticRidge(alpha=3.0).fit(x, y)
    copy = clone(original)
    assert copy.alpha == 3.0 and not hasattr(copy, "pipeline_")
    pipeline = make_pipeline(StandardScaler(), KNNRegressor(n_neighbors=4)).fit(x, y)
    np.testing.assert_allclose(
        pipeline.predict(x),
        KNNRegressor(n_neighbors=4)
        .fit(StandardScaler().fit_transform(x), y)
        .predict(StandardScaler().fit(x).transform(x)),
    )
    search = GridSearchCV(
        make_regressor("quadratic"), {"alpha": [1e-3, 1e4]}, cv=3, scoring="neg_mean_absolute_error"
    ).fit(x, y)
    # A quadratic target: the mild penalty wins over one that shrinks everything towards the mean.
    assert search.best_params_ == {"alpha": 1e-3}
    assert search.best_estimator_.predict(x).shape == (120, 2)
