"""The evaluation loop the localization protocols share, and its settings."""

from __future__ import annotations

import dataclasses
from typing import get_args

import numpy as np
import pytest

from eval.synthetic import synthetic_panoramas
from sfa_gym.cli.figures import quarter_outputs
from sfa_gym.cli.localize import GridExperiment, TrajectoryExperiment
from sfa_gym.features import fit_method, view_features
from sfa_gym.protocols import grid
from sfa_gym.protocols.settings import NETWORKS, NetworkName, SFASettings, WeightSharing
from sfa_gym.protocols.slow_features import SlowFeatureMethod
from sfa_gym.rotation import Rotation
from sfa_gym.sfa.network import WEIGHT_SHARING


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


class GridRuns:
    """Rendered grids held in memory, one per world seed: the RunSource the protocols read."""

    def __init__(self, n_positions: int):
        self.n_positions = n_positions
        self.asked: list[int] = []

    def get(self, request):
        self.asked.append(request.world_seed)
        rng = np.random.default_rng(request.world_seed)
        return GridRun(
            synthetic_panoramas(self.n_positions, 10, 40, seed=request.world_seed),
            rng.uniform(-3, 3, size=(self.n_positions, 2)),
        )


class GridRun:
    def __init__(self, panoramas, positions):
        self.panoramas, self.positions = panoramas, positions

    def __len__(self):
        return len(self.panoramas)


SMALL_GRID = grid.Config(grid=4, n_train=8, n_test=6, step=4, n_splits=3, labels=(3, 5))


def test_a_method_is_fitted_on_every_training_view_and_scored_once_per_regression():
    runs = GridRuns(16)
    found = grid.score(SMALL_GRID, Pixels(), 100, runs, regressors=("linear", "linear"))
    data = found.data
    assert runs.asked == [100]
    views = Rotation(step=4).views(data.panoramas[data.train])[0]
    np.testing.assert_array_equal(found.method.fitted_on_, views.reshape(-1, 10, 40, 3))
    assert list(found.regressions) == ["linear"]  # a regression named twice is scored once
    entry = found.entry()
    assert set(entry) == {"eta_r", "eta_phi", "n_features", "linear"}
    assert list(entry["linear"]) == ["train_test", "paper_splits"]
    assert entry["n_features"] == 10 * 40 * 3
    task = found.task_scores()
    assert task["regressor"] == "linear" and task["n_features"] == 1200
    np.testing.assert_allclose(
        task["mae_percent"], entry["linear"]["train_test"]["mae_percent"], atol=1e-4
    )
    assert task["score"] == pytest.approx(np.mean(task["mae_percent"]))


def test_the_first_evaluation_is_the_task_score_and_few_labels_scores_each_count():
    config = dataclasses.replace(SMALL_GRID, evaluations=("few_labels", "train_test"))
    found = grid.score(config, Pixels(), 100, GridRuns(16))
    task = found.task_scores()
    assert set(found.regressions["linear"].few_labels) == {3, 5}
    assert task["score"] == pytest.approx(np.mean([task["labels_3"], task["labels_5"]]))


def test_unseen_worlds_fit_the_method_on_the_other_world_only():
    runs = GridRuns(16)
    found = grid.score(SMALL_GRID, Pixels(), 100, runs, fit_world_seed=105)
    assert runs.asked == [100, 105]
    other = runs.get(grid.requests(SMALL_GRID, 105)["grid"])
    train, _ = grid.select_positions(SMALL_GRID, 16)
    views = Rotation(step=4).views(other.panoramas[train])[0]
    np.testing.assert_array_equal(found.method.fitted_on_, views.reshape(-1, 10, 40, 3))


def test_two_sweeps_visit_every_training_position_along_the_rows_then_along_the_columns():
    config = dataclasses.replace(SMALL_GRID, grid=6, n_train=20, n_test=6, order="sweeps")
    side = np.arange(6, dtype=float)
    xy = np.array([(x, y) for y in side for x in (side if y % 2 == 0 else side[::-1])])
    train, _ = grid.select_positions(config, len(xy))
    sequence = grid.training_sequence(config, train, xy)
    np.testing.assert_array_equal(sequence[:20], train)  # the rows' sweep: the visiting order
    columns = xy[sequence[20:]]
    assert sorted(sequence[20:]) == sorted(train)  # every position once more
    assert (np.diff(columns[:, 0]) >= 0).all()  # x never goes back: column after column
    for k, x in enumerate(np.unique(columns[:, 0])):
        ys = columns[columns[:, 0] == x, 1]
        assert (np.diff(ys) > 0).all() if k % 2 == 0 else (np.diff(ys) < 0).all()
    other = dataclasses.replace(config, order="serpentine")
    np.testing.assert_array_equal(grid.training_sequence(other, train, xy), train)


def test_with_two_sweeps_the_method_is_fitted_on_each_training_view_twice():
    config = dataclasses.replace(SMALL_GRID, order="sweeps")
    found = grid.score(config, Pixels(), 100, GridRuns(16))
    data = found.data
    sequence = grid.training_sequence(config, data.train, data.positions)
    assert len(sequence) == 2 * len(data.train)
    views = Rotation(step=4).views(data.panoramas[sequence])[0]
    np.testing.assert_array_equal(found.method.fitted_on_, views.reshape(-1, 10, 40, 3))


@pytest.mark.parametrize(
    ("world_seed", "message"), [(-1, "world_seed must be >= 0, got -1"), (1.5, "must be an int")]
)
def test_a_bad_world_seed_is_refused_before_any_run_is_asked_for(world_seed, message):
    runs = GridRuns(16)
    with pytest.raises((TypeError, ValueError), match=message):
        grid.score(SMALL_GRID, Pixels(), world_seed, runs)
    assert runs.asked == []


@pytest.mark.parametrize("command", ["localize", "localize-run", "localize-outdoor", "navigate"])
def test_every_command_refuses_a_negative_world_seed_before_creating_its_folder(
    command, tmp_path, capsys
):
    from sfa_gym.cli.main import main

    out = tmp_path / "out"
    assert main([command, "--world-seed", "-1", "--out", str(out)]) != 0
    assert "world_seed must be >= 0, got -1" in capsys.readouterr().err
    assert not out.exists()


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

    from sfa_gym.plugins import load_method_plugin

    band_means = load_method_plugin("band_means")(n_bands=2)  # subclassed here
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


def test_the_auto_network_is_the_preset_made_for_the_panoramas():
    from sfa_gym.plugins import load_method_plugin
    from sfa_gym.protocols.settings import SFASettings
    from sfa_gym.sfa import presets

    auto = SFASettings(network="auto")
    assert auto.make_model(40, 350).layers == presets.paper_sim()
    assert auto.make_model(60, 600).layers == presets.paper_outdoor()
    assert auto.make_model(10, 40).layers == presets.tiny(10, 40, 32, 32)
    # paper_sim cannot tile the outdoor camera: the leaderboard's SFA chooses by itself
    with pytest.raises(ValueError, match="column stride 7 must divide the width 12"):
        SFASettings(network="paper_sim").make_model(60, 600).fit_rotations(
            np.zeros((4, 60, 600, 3), dtype=np.uint8), step=5
        )
    assert load_method_plugin("sfa")().settings.network == "auto"


def test_a_fast_path_with_indices_is_asked_only_for_the_scored_rotations(panoramas):
    from sfa_gym.plugins import load_method, load_method_plugin

    raw = load_method_plugin("raw_pixels")(height=2, width=8)
    asked = []

    class Counting(type(raw)):
        def transform_rotations(self, panoramas, step, indices=None):
            found = super().transform_rotations(panoramas, step, indices)
            asked.append(found.shape[1])
            return found

    rotation, picked = Rotation(step=4), np.array([9, 0, 4])
    method = fit_method(Counting(**raw.get_params()), panoramas, rotation)
    some = view_features(method, panoramas, rotation, picked, progress=False)
    assert set(asked) == {3}  # never all ten
    every = view_features(method, panoramas, rotation, progress=False)
    np.testing.assert_array_equal(some, every[:, picked])
    # the same through load_method (in process, one BLAS thread): the indices pass through
    with load_method("raw_pixels", {"height": 2, "width": 8}) as isolated:
        fit_method(isolated, panoramas, rotation)
        across = view_features(isolated, panoramas, rotation, picked, progress=False)
    np.testing.assert_array_equal(across, some)
