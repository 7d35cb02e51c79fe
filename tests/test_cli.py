"""End-to-end smoke runs of the command line with tiny budgets."""

from __future__ import annotations

import json

import numpy as np

from sfa_gym.cli import main
from sfa_gym.recording.runfile import load_run
from sfa_gym.sfa import HierarchicalSFA


def test_record_writes_a_run_a_panorama_strip_and_a_trajectory(tmp_path):
    out = tmp_path / "drive.run"
    assert (
        main(["record", "--driver", "lawnmower", "--steps", "30", "--out", str(out), "--quiet"])
        == 0
    )
    run = load_run(out)
    assert len(run) == 30 and run.complete
    assert run.panoramas[0].shape == (40, 350, 3)
    # the rover moved: a scripted drive, not a still image
    assert np.linalg.norm(run.poses[-1, :2] - run.poses[0, :2]) > 0.3
    assert (tmp_path / "drive_panoramas.png").stat().st_size > 1000
    assert (tmp_path / "drive_trajectory.png").stat().st_size > 1000


def test_localize_on_a_tiny_grid_learns_position(tmp_path):
    out = tmp_path / "loc"
    argv = ["localize", "--out", str(out), "--grid", "10", "--n-train", "60", "--n-test", "30"]
    argv += ["--node-dim", "10", "--n-splits", "5", "--no-baselines", "--quiet"]
    assert main(argv) == 0
    results = json.loads((out / "results.json").read_text())
    sfa = results["methods"]["hierarchical_sfa"]
    assert len(sfa["eta_phi"]) == 8
    # fitted on 60 positions, tested on 30 others of a 6 m arena: a loose but real bound
    assert max(sfa["linear"]["train_test"]["mae_percent"]) < 15.0, sfa["linear"]
    # the slowest output codes position far more than orientation
    assert sfa["eta_r"][0] > 0.5 and sfa["eta_phi"][0] < 0.2
    for name in ("firing_maps.png", "estimates.png", "error_map.png", "sfa_model.npz"):
        assert (out / name).stat().st_size > 1000, name
    assert "hierarchical_sfa" in (out / "results.txt").read_text()
    assert HierarchicalSFA.load(out / "sfa_model.npz").weight_sharing == "rows"  # the default


def test_localize_rejects_an_impossible_grid(tmp_path, capsys):
    argv = ["localize", "--out", str(tmp_path), "--grid", "5", "--n-train", "20", "--n-test", "10"]
    assert main(argv) == 2
    assert "do not fit on a 5 x 5 grid" in capsys.readouterr().err


def test_localize_run_protocol_end_to_end(tmp_path):
    out = tmp_path / "traj"
    argv = ["localize-run", "--out", str(out), "--spacing", "2.0", "--frame-every", "8"]
    argv += ["--eval-rotations", "4", "--node-dim", "8", "--no-baselines", "--quiet"]
    assert main([*argv, "--weight-sharing", "layer"]) == 0
    results = json.loads((out / "results.json").read_text())
    assert results["protocol"] == "trajectory"
    assert results["config"]["weight_sharing"] == "layer"
    assert HierarchicalSFA.load(out / "sfa_model.npz").weight_sharing is True
    sfa = results["methods"]["hierarchical_sfa"]
    assert len(sfa["eta_phi"]) == 8
    assert (out / "sfa_model.npz").is_file()
    assert "hierarchical_sfa" in (out / "results.txt").read_text()
