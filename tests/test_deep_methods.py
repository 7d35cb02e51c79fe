"""The deep feature methods (baselines/deep_sfa.py, baselines/contrastive.py) on real rendered
panoramas of a small grid, with a tiny training budget: shapes, the same features for the same
seed, slower features than the untrained network's, invariance to simulated rotation, pairs
only within a sequence, and errors for bad arguments."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from sklearn.base import clone
from sklearn.exceptions import NotFittedError

pytest.importorskip("torch")

from sfa_gym.deep_methods import neighbour_pairs  # noqa: E402
from sfa_gym.plugins import get_capabilities, load_method_plugin  # noqa: E402
from sfa_gym.recording.ordering import grid_order  # noqa: E402
from sfa_gym.sim.camera import PanoramaSpec  # noqa: E402
from sfa_gym.sim.env import OmniRoverEnv  # noqa: E402

BASELINES = Path(__file__).resolve().parents[1] / "baselines"
NAMES = ["deep_sfa", "contrastive"]
TINY = {
    "output_dim": 4,
    "steps": 60,
    "batch_size": 16,
    "rows": 10,
    "channels": (8, 8),
    "n_frequencies": 3,
    "hidden": 16,
    "n_threads": 1,
    "progress": False,
}
"""A budget of a second or two a fit."""


def _method(name: str, **changes):
    return load_method_plugin(BASELINES / f"{name}.py")(**{**TINY, **changes})


@pytest.fixture(scope="module")
def run() -> np.ndarray:
    """10 x 40 panoramas of a 7 x 7 grid in Hilbert order, each at a random heading: the
    training run (49, 10, 40, 3) uint8, consecutive rows neighbours in space."""
    env = OmniRoverEnv(panorama=PanoramaSpec(width=40, height=10))
    env.reset(seed=0)
    positions = env.grid_positions(7)
    cells = np.stack(np.unravel_index(np.arange(49), (7, 7)), axis=1)
    order = grid_order(cells, "hilbert")
    yaws = np.random.default_rng(0).uniform(-np.pi, np.pi, len(order))
    panoramas = []
    for (x, y), yaw in zip(positions[order], yaws, strict=True):
        obs, _ = env.reset(options={"pose": (float(x), float(y), float(yaw))})
        panoramas.append(obs)
    env.close()
    return np.stack(panoramas)


@pytest.fixture(scope="module")
def fitted(run):
    return {name: _method(name).fit(run) for name in NAMES}


def _slowness(features: np.ndarray) -> float:
    """Mean squared time difference per unit variance, averaged over the features."""
    delta = np.mean(np.diff(features, axis=0) ** 2, axis=0)
    return float(np.mean(delta / features.var(axis=0)))


@pytest.mark.parametrize("name", NAMES)
def test_fit_and_transform_give_one_feature_vector_per_view(fitted, run, name):
    method = fitted[name]
    features = method.transform(run)
    assert method.name == name and features.shape == (49, 4) and features.dtype == np.float64
    assert np.all(np.isfinite(features)) and method.input_shape_ == (10, 40, 3)
    assert method.loss_curve_.shape == (60,) and np.all(np.isfinite(method.loss_curve_))
    capabilities = get_capabilities(method)
    assert capabilities.rotation_invariant and capabilities.regressor == "linear"
    # an estimator: its parameters are the fields of Args; a clone is unfitted
    assert method.get_params() == load_method_plugin(name).arguments(TINY)
    assert not hasattr(clone(method), "encoder_")


@pytest.mark.parametrize("name", NAMES)
def test_the_same_seed_gives_the_same_features_to_the_bit(fitted, run, name):
    again = _method(name).fit(run)
    np.testing.assert_array_equal(again.loss_curve_, fitted[name].loss_curve_)
    np.testing.assert_array_equal(again.transform(run), fitted[name].transform(run))
    other = _method(name, seed=1, steps=1).fit(run)
    assert not np.array_equal(other.transform(run), fitted[name].transform(run))


@pytest.mark.parametrize("name", NAMES)
def test_training_makes_the_features_slower_than_the_untrained_networks(fitted, run, name):
    untrained = _method(name, steps=0).fit(run)
    before = _slowness(untrained.transform(run))
    after = _slowness(fitted[name].transform(run))
    assert after < 0.7 * before, (before, after)


@pytest.mark.parametrize("name", NAMES)
def test_a_simulated_rotation_leaves_the_features_unchanged(fitted, run, name):
    method = fitted[name]
    features = method.transform(run)
    scale = features.std(axis=0)
    for shift in (1, 5, 23):
        turned = method.transform(np.roll(run, shift, axis=2))
        assert np.max(np.abs(turned - features) / scale) < 1e-3, shift


def test_pairs_stay_inside_a_sequence():
    np.testing.assert_array_equal(neighbour_pairs(4, None), [0, 1, 2])
    np.testing.assert_array_equal(neighbour_pairs(6, [0, 0, 1, 1, 1, 2]), [0, 2, 3])
    with pytest.raises(ValueError, match=r"sequence_ids must have shape \(6,\)"):
        neighbour_pairs(6, [0, 0, 1])


def test_sequences_change_what_is_learned(run):
    # every second row its own sequence: the pairs differ, and so does the network
    ids = np.arange(len(run)) // 2
    method = _method("deep_sfa")
    split = method.fit(run, sequence_ids=ids).network_outputs(run)
    whole = _method("deep_sfa").fit(run).network_outputs(run)
    assert not np.array_equal(split, whole)
    with pytest.raises(ValueError, match=r"give 0 pairs"):
        _method("deep_sfa").fit(run, sequence_ids=np.arange(len(run)))


@pytest.mark.parametrize(
    ("changes", "message"),
    [
        ({"steps": -1}, r"steps must be an int >= 0, got -1"),
        ({"batch_size": 0}, r"batch_size must be a positive int, got 0"),
        ({"rows": 0}, r"rows must be a positive int, got 0"),
        ({"learning_rate": 0.0}, r"learning_rate must be a positive number, got 0\.0"),
        ({"channels": ()}, r"channels must be a non-empty tuple of ints"),
        ({"channels": (8, -2)}, r"each of channels must be a positive int, got -2"),
        ({"steps": "3"}, r"argument steps must be int, got '3'"),
        ({"widht": 3}, r"unknown argument 'widht'"),
    ],
)
def test_bad_arguments_are_refused_naming_the_value(changes, message):
    for name in NAMES:
        with pytest.raises(ValueError, match=message):
            _method(name, **changes)


def test_bad_input_is_refused_naming_what_was_expected(fitted, run):
    with pytest.raises(ValueError, match=r"n_frequencies must be at most 21"):
        _method("deep_sfa", n_frequencies=22).fit(run)
    with pytest.raises(ValueError, match=r"needs at least 5 pairs .* 4 views give 3 pairs"):
        _method("deep_sfa", output_dim=8).fit(run[:4])
    with pytest.raises(TypeError, match=r"must be uint8"):
        _method("deep_sfa").fit(run.astype(np.float32))
    with pytest.raises(NotFittedError, match="deep_sfa is not fitted yet"):
        _method("deep_sfa").transform(run)
    with pytest.raises(ValueError, match=r"fitted on views of shape \(10, 40, 3\)"):
        fitted["contrastive"].transform(run[:, :, :20])
