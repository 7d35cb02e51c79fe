"""Linear SFA and quadratic expansion: known answers, invariants, chunking, errors."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from sklearn.exceptions import NotFittedError

from sfa_gym.sfa import SFA, QuadraticExpansion, RankDeficiencyWarning
from sfa_gym.sfa.expansion import n_quadratic_features, quadratic_expand


def _mixed_sinusoids(n: int = 3000, seed: int = 0):
    rng = np.random.default_rng(seed)
    t = np.linspace(0, 2 * np.pi, n)
    sources = np.c_[np.sin(t), np.cos(3 * t), np.sin(37 * t), np.cos(53 * t), np.sin(71 * t)]
    mixing = rng.standard_normal((5, 5))
    return sources, sources @ mixing + 3.0


def _corr(a: np.ndarray, b: np.ndarray) -> float:
    return float(abs(np.corrcoef(a, b)[0, 1]))


def test_linear_sfa_recovers_the_two_slow_sinusoids_from_a_random_mixture():
    sources, x = _mixed_sinusoids()
    y = SFA(n_components=2).fit(x).transform(x)
    assert _corr(y[:, 0], sources[:, 0]) > 0.99
    assert _corr(y[:, 1], sources[:, 1]) > 0.99


def test_quadratic_sfa_recovers_a_slow_signal_hidden_in_a_quadratic_mixture():
    # Wiskott & Sejnowski's example: sin(t) is only a quadratic function of the inputs
    t = np.linspace(0, 2 * np.pi, 5000)
    slow = np.sin(t)
    x = np.c_[slow + np.cos(11 * t) ** 2, np.cos(11 * t)]
    linear = SFA(n_components=1).fit(x).transform(x)[:, 0]
    expanded = QuadraticExpansion().fit_transform(x)
    y = SFA(n_components=1).fit(expanded).transform(expanded)[:, 0]
    assert _corr(y, slow) > 0.99
    assert _corr(linear, slow) < 0.9  # the linear model cannot find it


@settings(max_examples=15, deadline=None)
@given(
    n=st.integers(40, 200),
    d=st.integers(2, 6),
    seed=st.integers(0, 2**32 - 1),
)
def test_outputs_are_centred_white_and_ordered_by_slowness(n: int, d: int, seed: int):
    rng = np.random.default_rng(seed)
    x = np.cumsum(rng.standard_normal((n, d)), axis=0) + rng.standard_normal((n, d))
    sfa = SFA().fit(x)
    y = sfa.transform(x)
    k = y.shape[1]
    np.testing.assert_allclose(y.mean(axis=0), 0.0, atol=1e-8)
    np.testing.assert_allclose(np.cov(y.T, bias=True).reshape(k, k), np.eye(k), atol=1e-7)
    delta = sfa.delta_values_
    assert np.all(np.diff(delta) >= -1e-12)
    np.testing.assert_allclose(np.mean(np.diff(y, axis=0) ** 2, axis=0), delta, rtol=1e-6)


def test_partial_fit_in_chunks_equals_fit():
    _, x = _mixed_sinusoids(1000)
    whole = SFA(n_components=3).fit(x)
    chunked = SFA(n_components=3)
    for part in np.array_split(x, [1, 130, 131, 600]):
        chunked.partial_fit(part)
    np.testing.assert_allclose(chunked.transform(x), whole.transform(x), atol=1e-9)
    np.testing.assert_allclose(chunked.delta_values_, whole.delta_values_, rtol=1e-9)
    assert chunked.n_samples_seen_ == 1000


def test_no_time_difference_is_formed_across_a_sequence_boundary():
    rng = np.random.default_rng(1)
    a = np.cumsum(rng.standard_normal((300, 3)), axis=0)
    b = np.cumsum(rng.standard_normal((200, 3)), axis=0) + 50.0  # a jump between a and b
    x = np.vstack([a, b])
    ids = np.r_[np.zeros(300, int), np.ones(200, int)]
    with_ids = SFA().fit(x, sequence_ids=ids)
    y = with_ids.transform(x)
    inner = np.vstack([np.diff(y[:300], axis=0), np.diff(y[300:], axis=0)])
    np.testing.assert_allclose(with_ids.delta_values_, np.mean(inner**2, axis=0), rtol=1e-8)
    # the same with two partial fits, the second declared a new sequence
    two = SFA().partial_fit(a).partial_fit(b, new_sequence=True)
    np.testing.assert_allclose(two.transform(x), y, atol=1e-9)
    # and the boundary matters: without ids the jump counts as a (fast) difference
    joined = SFA().fit(x)
    assert not np.allclose(joined.delta_values_, with_ids.delta_values_, rtol=1e-3)


def test_sequence_ids_continue_across_partial_fit_chunks():
    rng = np.random.default_rng(2)
    x = np.cumsum(rng.standard_normal((90, 2)), axis=0)
    ids = np.repeat([0, 1, 2], 30)
    whole = SFA().fit(x, sequence_ids=ids)
    chunked = SFA()
    for sl in (slice(0, 20), slice(20, 45), slice(45, 90)):  # 20..45 spans ids 0 and 1
        chunked.partial_fit(x[sl], sequence_ids=ids[sl])
    np.testing.assert_allclose(chunked.transform(x), whole.transform(x), atol=1e-9)


def test_sign_convention_outputs_rise_with_time_and_do_not_depend_on_chunking():
    _, x = _mixed_sinusoids(2000, seed=5)
    ref = SFA(n_components=4).fit(x).transform(x)
    t = np.arange(len(x))
    for j in range(4):
        c = np.corrcoef(ref[:, j], t)[0, 1]
        assert c > 0 or abs(c) < 1e-6
    for sizes in ([7, 700, 1500], [1000], [3, 4, 5, 1999]):
        model = SFA(n_components=4)
        for part in np.array_split(x, sizes):
            model.partial_fit(part)
        y = model.transform(x)
        np.testing.assert_allclose(y, ref, atol=1e-8)  # same signs, not just same |y|


def test_rank_deficient_input_drops_directions_with_a_warning():
    _, x = _mixed_sinusoids(1000)
    x = np.c_[x, x[:, 0] + x[:, 1], np.full(len(x), 7.0)]  # one dependent, one constant column
    with pytest.warns(RankDeficiencyWarning, match="dropped 2 of 7"):
        sfa = SFA().fit(x)
    assert sfa.n_components_ == 5 and sfa.n_dropped_ == 2
    y = sfa.transform(x)
    np.testing.assert_allclose(np.cov(y.T, bias=True), np.eye(5), atol=1e-6)


def test_full_rank_input_does_not_warn():
    _, x = _mixed_sinusoids(500)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        SFA().fit(x)


@pytest.mark.parametrize(
    ("data", "error", "match"),
    [
        (np.full((50, 3), 2.0), ValueError, "no variance"),
        (np.ones((1, 3)), ValueError, "minimum of 2"),
        (np.ones(10), ValueError, "Expected 2D array"),
        (np.array([["a", "b"], ["c", "d"]]), ValueError, "could not convert string"),
        (np.array([[1.0, np.nan], [2.0, 3.0], [0.0, 1.0]]), ValueError, "NaN"),
    ],
)
def test_bad_training_data_is_rejected_with_a_clear_message(data, error, match):
    with pytest.raises(error, match=match):
        SFA().fit(data)


def test_misuse_errors():
    x = np.random.default_rng(0).standard_normal((100, 3))
    with pytest.raises(NotFittedError, match="not fitted"):
        SFA().transform(x)
    with pytest.raises(ValueError, match="exceeds the input dimension"):
        SFA(n_components=4).fit(x)
    with pytest.raises(ValueError, match="n_components"):
        SFA(n_components=0).fit(x)
    sfa = SFA().fit(x)
    with pytest.raises(ValueError, match="expecting 3 features"):
        sfa.transform(x[:, :2])
    with pytest.raises(ValueError, match="expecting 3 features"):
        sfa.partial_fit(x[:, :2])
    with pytest.raises(ValueError, match="sequence_ids"):
        SFA().fit(x, sequence_ids=np.zeros(5))
    with pytest.raises(ValueError, match="no time differences"):
        SFA().fit(x, sequence_ids=np.arange(100))


def test_quadratic_expansion_is_all_monomials_of_degree_one_and_two():
    rng = np.random.default_rng(0)
    x = rng.standard_normal((7, 4))
    out = QuadraticExpansion().fit_transform(x)
    iu, ju = np.triu_indices(4)
    np.testing.assert_allclose(out, np.c_[x, x[:, iu] * x[:, ju]])
    assert out.shape == (7, n_quadratic_features(4)) == (7, 14)
    np.testing.assert_allclose(quadratic_expand(x.T.copy(), axis=0), out.T)
    assert quadratic_expand(x.astype(np.float32)).dtype == np.float32
    with pytest.raises(NotFittedError):
        QuadraticExpansion().transform(x)
