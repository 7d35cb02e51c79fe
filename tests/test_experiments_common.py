"""The evaluation loop the localization protocols share, and its settings."""

from __future__ import annotations

import dataclasses
from typing import get_args

import numpy as np
import pytest

from sfa_gym.experiments import GridExperiment, SFASettings, TrajectoryExperiment
from sfa_gym.experiments.common import SlowFeatureMethod, evaluate_methods
from sfa_gym.experiments.figures import quarter_outputs
from sfa_gym.protocols.features import fit_method, view_features
from sfa_gym.protocols.settings import NETWORKS, NetworkName, WeightSharing
from sfa_gym.rotation import Rotation
from sfa_gym.sfa.network import WEIGHT_SHARING
from sfa_gym.sfa.synthetic import synthetic_panoramas


class Pixels:
    """Every pixel of a view as a feature: shows which views a method was given."""

    name = "pixels"

    def fit(self, views, sequence_ids=None):
        self.fitted_on_ = np.array(views)
        return self

    def transform(self, views):
        return np.asarray(views, dtype=np.float64).reshape(len(views), -1)


@pytest.fixture(scope="module")
def panoramas():
    return synthetic_panoramas(12, 10, 40, seed=3)


def _rolled(panoramas, step, ks):
    """The rotated views by hand: view k is the panorama shifted by -k * step columns."""
    return np.stack([np.roll(panoramas, -k * step, axis=2) for k in ks], axis=1)


@pytest.mark.parametrize("indices", [None, np.array([0, 3, 7])])
def test_features_of_rotated_views_are_the_features_of_the_shifted_panoramas(panoramas, indices):
    rotation = Rotation(step=4)
    ks = range(10) if indices is None else indices
    got = view_features(Pixels(), panoramas, rotation, indices, progress=False)
    expected = _rolled(panoramas, 4, ks).reshape(len(panoramas), len(ks), -1)
    np.testing.assert_array_equal(got, expected)


def test_a_method_is_fitted_on_all_views_of_one_location_then_the_next(panoramas):
    fitted = fit_method(Pixels(), panoramas[:3], Rotation(step=8))
    expected = _rolled(panoramas[:3], 8, range(5)).reshape(-1, 10, 40, 3)
    np.testing.assert_array_equal(fitted.fitted_on_, expected)


@pytest.fixture(scope="module")
def sfa(panoramas):
    settings = SFASettings(network="tiny", node_dim=6, n_outputs=4)
    return SlowFeatureMethod(settings, Rotation(step=4), progress=False).fit_rotations(panoramas)


def test_the_sfa_rotation_shortcut_agrees_with_transforming_every_view(sfa, panoramas):
    rotation = Rotation(step=4)
    shortcut = view_features(sfa, panoramas, rotation, progress=False)
    views = rotation.views(panoramas)[0]  # (12, 10, H, W, 3): every view, transformed alone
    every_view = sfa.transform(views.reshape(-1, *views.shape[2:])).reshape(12, 10, 4)
    assert shortcut.shape == (12, 10, 4)
    np.testing.assert_allclose(shortcut, every_view, atol=1e-6)
    # some views: picked from the shortcut's, the same numbers
    picked = view_features(sfa, panoramas, rotation, np.array([7, 1, 3]), progress=False)
    np.testing.assert_allclose(picked, every_view[:, [7, 1, 3]], atol=1e-6)


def test_sfa_fits_on_its_own_rotation_and_reads_features_at_any_step(sfa, panoramas):
    # a feature field averages over every column of a network trained with coarser steps
    coarse = view_features(sfa, panoramas, Rotation(step=8), progress=False)
    views = Rotation(step=8).views(panoramas)[0]
    every_view = sfa.transform(views.reshape(-1, *views.shape[2:])).reshape(12, 5, 4)
    np.testing.assert_allclose(coarse, every_view, atol=1e-6)
    unfitted = SlowFeatureMethod(sfa.settings, Rotation(step=4), progress=False)
    with pytest.raises(ValueError, match="set up for Rotation.step=4.*Rotation.step=8"):
        fit_method(unfitted, panoramas, Rotation(step=8))


def test_firing_maps_show_the_views_nearest_the_quarter_turns(sfa, panoramas):
    outputs, phis = quarter_outputs(sfa.model_, panoramas, Rotation(step=4))
    # 10 views of 36 degrees: k = round(q * 10 / 4) for the quarters q (2.5 rounds to 2)
    np.testing.assert_allclose(np.degrees(phis), [0, 72, 180, 288])
    for i, k in enumerate([0, 2, 5, 8]):
        np.testing.assert_array_equal(
            outputs[:, i], sfa.model_.transform(np.roll(panoramas, -4 * k, axis=2))
        )


def test_every_method_sees_the_same_data_and_the_score_adds_to_the_mae(panoramas):
    rng = np.random.default_rng(0)
    xy = rng.uniform(-1, 1, size=(12, 2))
    seen = []

    def score(regressor, f_test, estimates):
        seen.append((regressor, f_test.shape, estimates.shape))
        return {"extra": regressor}

    settings = SFASettings(network="tiny", node_dim=6, n_outputs=4)
    found = evaluate_methods(
        [
            (SlowFeatureMethod(settings, Rotation(step=4), progress=False), ("linear", "map")),
            (Pixels(), ("linear", "linear")),
        ],
        train=(panoramas[:8], xy[:8]),
        test=(panoramas[8:], xy[8:]),
        rotation=Rotation(step=4),
        score=score,
        indices=np.array([0, 5]),
        progress=False,
    )
    assert list(found.methods) == ["hierarchical_sfa", "pixels"]
    assert seen == [
        ("linear", (4, 2, 4), (4, 2)),
        ("map", (4, 2, 4), (4, 2)),
        ("linear", (4, 2, 1200), (4, 2)),  # a regression named twice is evaluated once
    ]
    entry = found.methods["hierarchical_sfa"]
    assert set(entry) == {"eta_r", "eta_phi", "n_features", "linear", "map"}
    assert set(entry["map"]) == {"train_test", "extra"} and entry["map"]["extra"] == "map"
    assert found.estimates.shape == (4, 2) and found.model.input_shape_ == (10, 40, 3)


def test_the_loop_needs_sfa_first_with_the_figure_regression(panoramas):
    with pytest.raises(ValueError, match="the first method must be a SlowFeatureMethod"):
        evaluate_methods(
            [(Pixels(), ("linear",))],
            train=(panoramas, np.zeros((12, 2))),
            test=(panoramas, np.zeros((12, 2))),
            rotation=Rotation(step=4),
            score=lambda *args: {},
        )


def test_the_settings_names_are_the_engines():
    assert sorted(get_args(NetworkName)) == sorted(NETWORKS)
    assert get_args(WeightSharing) == WEIGHT_SHARING


@pytest.mark.parametrize("protocol", [GridExperiment, TrajectoryExperiment])
def test_both_protocols_nest_the_same_sfa_settings(protocol):
    field = {f.name: f for f in dataclasses.fields(protocol)}["sfa"]
    assert field.default == SFASettings()
    assert protocol().rotation == Rotation(step=5)
    with pytest.raises(ValueError, match="n_outputs must be a positive int"):
        protocol(sfa=SFASettings(n_outputs=0)).validate()


def test_rotation_invariant_methods_transform_each_panorama_once(panoramas):
    from sklearn.base import clone

    from sfa_gym.plugins import load_method

    band_means = load_method("band_means", {"n_bands": 2})
    calls = []

    class Counting(type(band_means)):
        def transform(self, views):
            calls.append(len(views))
            return super().transform(views)

    method = fit_method(Counting(**band_means.get_params()), panoramas, Rotation(step=4))
    fast = view_features(method, panoramas, Rotation(step=4), progress=False)
    assert calls == [len(panoramas)]  # the panoramas themselves, no rotated views
    views = Rotation(step=4).views(panoramas)[0]
    brute = clone(band_means).fit(panoramas).transform(views.reshape(-1, *views.shape[2:]))
    np.testing.assert_array_equal(fast, brute.reshape(fast.shape))
    # narrower views are not circular shifts of the panorama: every view is transformed
    calls.clear()
    view_features(method, panoramas, Rotation(step=4, window=20), np.arange(3), progress=False)
    assert calls and sum(calls) == 3 * len(panoramas)
