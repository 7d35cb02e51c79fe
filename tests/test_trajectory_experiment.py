"""The trajectory (outdoor) localization protocol end to end, on tiny real runs.

A short lawn-mower training run (three rows 2 m apart, skipping the south-west corner) and one
rectangular test loop through that corner are rendered at 10 x 40 pixels; a tiny hierarchical
SFA network and the band-means baseline are fitted and evaluated.
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

from sfa_gym.cli.localize import TrajectoryExperiment, run_trajectory_experiment
from sfa_gym.cli.results import format_table
from sfa_gym.geometry import in_rectangle
from sfa_gym.plugins import load_method_plugin
from sfa_gym.protocols.settings import SFASettings
from sfa_gym.recording.runfile import load_run

BASELINES = Path(__file__).resolve().parents[1] / "baselines"

TINY = TrajectoryExperiment(
    panorama=(10, 40),
    spacing=2.0,
    pattern="rows",
    margin=1.0,
    test_insets=(1.0,),
    frame_every=4,
    test_every=2,
    step=4,
    eval_rotations=5,
    sfa=SFASettings(network="tiny", node_dim=8),
)


@pytest.fixture(scope="module")
def experiment(tmp_path_factory):
    out = tmp_path_factory.mktemp("trajectory")
    band_means = load_method_plugin(BASELINES / "band_means.py")()
    results = run_trajectory_experiment(
        TINY, out, methods=[(band_means, ("linear",))], progress=False
    )
    return out, results


def test_writes_results_model_runs_and_figures(experiment):
    out, results = experiment
    for name in ("results.json", "sfa_model.npz"):
        assert (out / name).is_file()
    for name in ("trajectories", "estimates", "error_map", "firing_maps"):
        assert (out / f"{name}.png").stat().st_size > 10_000, name
    assert json.loads((out / "results.json").read_text()) == results
    assert results["format"] == "sfa-gym-localization"
    assert results["protocol"] == "trajectory"
    assert results["config"] == json.loads(json.dumps(dataclasses.asdict(TINY)))
    # 40 columns in steps of 4: 10 rotations, 5 of them evaluated, evenly spaced
    assert results["n_rotations"] == 10 and results["eval_windows"] == [0, 2, 4, 6, 8]
    assert set(results["methods"]) == {"hierarchical_sfa", "band_means"}
    table = format_table(results)
    assert "hierarchical_sfa" in table and "band_means" in table and "paper (2013)" in table


def test_training_run_avoids_the_excluded_region_and_the_test_run_crosses_it(experiment):
    out, results = experiment
    train, test = load_run(out / "train.run"), load_run(out / "test.run")
    assert train.complete and test.complete
    assert not in_rectangle(train.positions, TINY.exclude).any()
    assert in_rectangle(test.positions, TINY.exclude).any()
    assert results["runs"]["train"]["n_frames"] == len(train)
    assert results["runs"]["train"]["n_used"] == len(range(0, len(train), TINY.frame_every))
    assert results["runs"]["train"]["n_used_in_excluded"] == 0
    assert results["runs"]["test"]["n_used_in_excluded"] > 0
    sfa = results["methods"]["hierarchical_sfa"]["linear"]
    assert sfa["excluded"] is not None and sfa["visited"] is not None


def test_sfa_localizes_the_test_run_far_better_than_chance(experiment):
    out, results = experiment
    train, test = load_run(out / "train.run"), load_run(out / "test.run")
    test_xy = test.positions[:: TINY.test_every]
    # a regression that learned nothing predicts about the mean training position
    chance = np.abs(test_xy - train.positions.mean(axis=0)).mean(axis=0)
    span = test_xy.max(axis=0) - test_xy.min(axis=0)
    sfa = results["methods"]["hierarchical_sfa"]
    for regression in ("linear", "quadratic"):
        entry = sfa[regression]["train_test"]
        np.testing.assert_allclose(entry["range_m"], span, atol=1e-4)
        assert np.all(np.array(entry["mae_percent"]) < 25.0), (regression, entry)
        assert np.all(np.array(entry["mae_m"]) < 0.6 * chance), (regression, entry, chance)
    # the slow features are nearly orientation invariant over the evaluation windows
    assert max(sfa["eta_phi"]) < 0.1
    assert min(sfa["eta_r"]) > 0.9


def test_outputs_are_reused_on_a_second_call(experiment):
    out, results = experiment
    stamps = {name: (out / name / "run.json").stat().st_mtime_ns for name in ("train.run",)}
    again = run_trajectory_experiment(TINY, out, progress=False, figures=False)
    assert (out / "train.run" / "run.json").stat().st_mtime_ns == stamps["train.run"]
    # same seed, same runs, same features, same numbers
    assert again["methods"]["hierarchical_sfa"] == results["methods"]["hierarchical_sfa"]


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"frame_every": 0}, "frame_every must be a positive int"),
        ({"eval_rotations": 0}, "eval_rotations must be a positive int"),
        ({"spacing": 0.0}, "spacing must be positive"),
        ({"pattern": "spiral"}, "pattern must be one of"),
        ({"exclude": (-1.0, -2.0, -3.0, -1.5)}, "exclude must be finite with xmin < xmax"),
        ({"exclude": (0.0, 1.0)}, "exclude must be a rectangle"),
        ({"test_driver": "figure8"}, "test_driver must be one of"),
        ({"test_driver": "random_walk"}, "set test_steps"),
        ({"test_insets": ()}, "test_insets must be a non-empty tuple"),
        ({"train_steps": 1}, "train_steps must be None or an int >= 2"),
        ({"panorama": (10,)}, "panorama must be None or"),
        ({"sfa": SFASettings(network="huge")}, "network must be one of"),
        ({"sfa": SFASettings(weight_sharing="columns")}, "weight_sharing must be one of"),
        ({"sfa": SFASettings(node_dim=0)}, "node_dim must be a positive int"),
        ({"step": 3}, "not a multiple of step 3"),
        ({"env_id": "sfa_gym/Nope-v0"}, "is not a registered env"),
    ],
)
def test_validate_names_the_bad_setting(change, message, tmp_path):
    config = dataclasses.replace(TINY, **change)
    with pytest.raises(ValueError, match=message):
        config.validate()
    # run_trajectory_experiment validates before rendering anything
    with pytest.raises(ValueError, match=message):
        run_trajectory_experiment(config, tmp_path / "out", progress=False)
    assert not (tmp_path / "out").exists()
