"""Localization on real rendered panoramas: baselines -> regression -> metrics -> plots."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from sfa_gym.localization import eta, random_split_mae
from sfa_gym.localization.plots import estimate_vs_truth, firing_maps
from sfa_gym.localization.regression import LinearRegressor
from sfa_gym.plugins import load_method_plugin
from sfa_gym.rotation import rotated_views
from sfa_gym.sim.camera import PanoramaSpec
from sfa_gym.sim.env import OmniRoverEnv

BASELINES = Path(__file__).resolve().parents[1] / "baselines"


@pytest.fixture(scope="module")
def grid_views():
    """All 8 rotated views (step 5) of 10 x 40 panoramas at an 8 x 8 grid of positions, each
    rendered at a random heading: views (64, 8, 10, 40, 3), positions (64, 2)."""
    env = OmniRoverEnv(panorama=PanoramaSpec(width=40, height=10))
    env.reset(seed=0)
    positions = env.grid_positions(8)
    yaws = np.random.default_rng(0).uniform(-np.pi, np.pi, len(positions))
    panoramas = []
    for (x, y), yaw in zip(positions, yaws, strict=True):
        obs, _ = env.reset(options={"pose": (float(x), float(y), float(yaw))})
        panoramas.append(obs)
    env.close()
    views = np.stack([rotated_views(p, step=5)[0] for p in panoramas])
    return views, positions


def _features(name: str, views: np.ndarray) -> np.ndarray:
    n, k = views.shape[:2]
    flat = views.reshape(n * k, *views.shape[2:])
    method = load_method_plugin(BASELINES / f"{name}.py")().fit(flat)
    return method.transform(flat).reshape(n, k, -1)


@pytest.mark.parametrize("name", ["band_means", "fft_magnitude"])
def test_rotation_invariant_baselines_have_no_orientation_variance(grid_views, name):
    views, _ = grid_views
    eta_r, eta_phi = eta(_features(name, views))
    np.testing.assert_allclose(eta_phi, 0.0, atol=1e-20)
    np.testing.assert_allclose(eta_r, 1.0, rtol=1e-12)


def test_raw_pixels_depend_on_orientation(grid_views):
    views, _ = grid_views
    _, eta_phi = eta(_features("raw_pixels", views))
    assert eta_phi.max() > 0.1


def test_features_localize_far_better_than_chance(grid_views, tmp_path):
    views, positions = grid_views
    features = _features("band_means", views)
    result = random_split_mae(features, positions, lambda: LinearRegressor(alpha=1.0), n_splits=5)
    shuffled = np.random.default_rng(1).permutation(positions)
    chance = random_split_mae(features, shuffled, lambda: LinearRegressor(alpha=1.0), n_splits=5)
    assert np.all(result.mae_percent < 25.0), result.mae_percent
    assert np.all(result.mae_percent < 0.5 * chance.mae_percent), (result, chance)
    # The plots of a real result render.
    fig, _ = firing_maps(features[:, :, :4], positions, n_outputs=4)
    fig.savefig(tmp_path / "band_means_firing_maps.png", dpi=50)
    regressor = LinearRegressor(alpha=1.0).fit(
        features.reshape(-1, features.shape[2]), np.repeat(positions, 8, axis=0)
    )
    estimates = (
        regressor.predict(features.reshape(-1, features.shape[2])).reshape(64, 8, 2).mean(axis=1)
    )
    fig, _ = estimate_vs_truth(estimates, positions)
    fig.savefig(tmp_path / "estimates.png", dpi=50)
    assert all(
        (tmp_path / f).stat().st_size > 2_000
        for f in ("band_means_firing_maps.png", "estimates.png")
    )
