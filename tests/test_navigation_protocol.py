"""The navigation protocol's settings: a track's params are its Config, the rover-fits rule has
one home, and ``navigate`` recomputes a stored model made with other settings."""

from __future__ import annotations

import dataclasses
import json
import warnings
from pathlib import Path

import numpy as np
import pytest

import sfa_gym  # noqa: F401  (registers the ids)
from sfa_gym.leaderboard.tracks import load_track, track_from_dict
from sfa_gym.navigation.controllers import GradientSettings
from sfa_gym.protocols import navigation
from sfa_gym.protocols.settings import SFASettings

ROOT = Path(__file__).resolve().parents[1]


def test_track_params_are_the_protocol_config():
    path = ROOT / "tracks" / "nav_open.json"
    data = json.loads(path.read_text())
    config = load_track(path).config(quick=False)
    assert isinstance(config, navigation.Config)
    assert config.seed == 7001 and config.train_headings == "random"
    assert config.gradient == GradientSettings(**data["params"]["gradient"])
    with pytest.raises(ValueError, match="unknown field 'params.train_gird'"):
        track_from_dict({**data, "params": {**data["params"], "train_gird": 4}})
    with pytest.raises(ValueError, match="train_headings must be one of"):
        track_from_dict({**data, "params": {**data["params"], "train_headings": "north"}})


def test_a_non_navigation_env_or_negative_rendered_episodes_are_refused(tmp_path):
    from sfa_gym.cli.main import main
    from sfa_gym.cli.navigate import NavigationExperiment

    with pytest.raises(ValueError, match="'sfa_gym/OmniRover-v0' is not a navigation env; "):
        dataclasses.replace(navigation.Config(), env_id="sfa_gym/OmniRover-v0").validate()
    with pytest.raises(ValueError, match="rendered_episodes must be >= 0, got -1"):
        NavigationExperiment(rendered_episodes=-1).validate()
    out = tmp_path / "out"
    assert main(["navigate", "--env", "sfa_gym/OmniRover-v0", "--out", str(out)]) == 2
    assert not out.exists()  # refused before any folder is made


def test_rover_fits_is_the_rule_reset_checks():
    import gymnasium as gym

    nav = gym.make("sfa_gym/OmniRoverNavObstacles-v0", world_seed=101).unwrapped
    try:
        points = nav.grid_positions(12)
        fits = nav.rover_fits(points)
        assert 0 < fits.sum() < len(points)  # the obstacles take some positions
        clearance = nav.layout.clearance(points)
        np.testing.assert_array_equal(fits, clearance > nav.rover.footprint_radius)
        x, y = points[~fits][0]
        with pytest.raises(ValueError, match="from an obstacle"):
            nav._check_pose((x, y, 0.0))
    finally:
        nav.close()


def test_navigate_recomputes_a_model_stored_with_other_settings(tmp_path, capsys):
    from sfa_gym.cli.navigate import NavigationExperiment, run_navigation_experiment
    from sfa_gym.navigation.field import FeatureField

    config = NavigationExperiment(
        train_grid=5,
        field_spacing=1.5,
        episodes=1,
        controllers=("gradient",),
        sfa=SFASettings(node_dim=8, n_outputs=4),
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # rank deficiency of the small network
        run_navigation_experiment(config, tmp_path, progress=False)
        assert FeatureField.load(tmp_path / "field_sfa.npz").n_features == 4
        assert "other settings" not in capsys.readouterr().out
        # the same settings again: the stored model and field are reused as they are
        before = (tmp_path / "sfa_model.npz").stat().st_mtime_ns
        run_navigation_experiment(config, tmp_path, progress=False)
        assert (tmp_path / "sfa_model.npz").stat().st_mtime_ns == before
        other = dataclasses.replace(config, sfa=SFASettings(node_dim=8, n_outputs=3))
        run_navigation_experiment(other, tmp_path, progress=False)
    assert "other settings (sfa)" in capsys.readouterr().out
    assert FeatureField.load(tmp_path / "field_sfa.npz").n_features == 3


def test_a_field_that_transforms_every_rotation_of_many_nodes_warns_with_the_count():
    from sfa_gym.plugins import load_method

    class PerView:  # a method that can only transform views one by one
        name = "per_view"

        def transform(self, views):
            return views.reshape(len(views), -1)[:, :2].astype(float)

    with pytest.warns(UserWarning, match=r"per_view is not rotation_invariant.*700,000"):
        navigation._warn_per_rotation(PerView(), 2000, 350)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        navigation._warn_per_rotation(PerView(), 100, 350)  # 35,000 views: no warning
        pca = load_method(ROOT / "baselines" / "pca.py", {})
        navigation._warn_per_rotation(pca, 2000, 350)  # its transform_rotations: no warning
        band_means = load_method(ROOT / "baselines" / "band_means.py", {})
        navigation._warn_per_rotation(band_means, 2000, 350)  # rotation invariant: once each
