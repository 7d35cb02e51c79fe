"""End-to-end smoke runs of the command line with tiny budgets, and its error handling."""

from __future__ import annotations

import json

import numpy as np
import pytest

from sfa_gym.cli import main
from sfa_gym.recording.runfile import load_run
from sfa_gym.sfa.io import load_model


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
    assert results["config"]["sfa"]["node_dim"] == 10 and results["config"]["grid"] == 10
    sfa = results["methods"]["hierarchical_sfa"]
    assert len(sfa["eta_phi"]) == 8
    # fitted on 60 positions, tested on 30 others of a 6 m arena: a loose but real bound
    assert max(sfa["linear"]["train_test"]["mae_percent"]) < 15.0, sfa["linear"]
    # the slowest output codes position far more than orientation
    assert sfa["eta_r"][0] > 0.5 and sfa["eta_phi"][0] < 0.2
    for name in ("firing_maps.png", "estimates.png", "error_map.png", "sfa_model.npz"):
        assert (out / name).stat().st_size > 1000, name
    assert "hierarchical_sfa" in (out / "results.txt").read_text()
    assert load_model(out / "sfa_model.npz").weight_sharing == "rows"  # the default


def test_localize_rejects_an_impossible_grid(tmp_path, capsys):
    argv = ["localize", "--out", str(tmp_path), "--grid", "5", "--n-train", "20", "--n-test", "10"]
    assert main(argv) == 2
    assert "do not fit on a 5 x 5 grid" in capsys.readouterr().err
    # a grid the machine cannot hold is refused before anything is written, the size named
    out = tmp_path / "huge"
    argv = ["localize", "--out", str(out), "--grid", "1000000", "--n-train", "20", "--n-test"]
    assert main([*argv, "10"]) == 2
    assert "grid 1000000 (1000000000000 positions) would need" in capsys.readouterr().err
    assert not out.exists()


def test_localize_run_protocol_end_to_end(tmp_path):
    out = tmp_path / "traj"
    argv = ["localize-run", "--out", str(out), "--spacing", "2.0", "--frame-every", "8"]
    argv += ["--eval-rotations", "4", "--node-dim", "8", "--no-baselines", "--quiet"]
    # options that only the generated command line reaches: the test driver and its loop
    argv += ["--test-insets", "1.0", "--test-every", "2", "--margin", "0.6"]
    assert main([*argv, "--weight-sharing", "layer"]) == 0
    results = json.loads((out / "results.json").read_text())
    assert results["protocol"] == "trajectory"
    assert results["config"]["sfa"]["weight_sharing"] == "layer"
    assert results["config"]["test_insets"] == [1.0] and results["config"]["margin"] == 0.6
    assert results["config"]["test_every"] == 2
    assert load_model(out / "sfa_model.npz").weight_sharing == "layer"
    sfa = results["methods"]["hierarchical_sfa"]
    assert len(sfa["eta_phi"]) == 8
    assert "hierarchical_sfa" in (out / "results.txt").read_text()


def _one_line_error(capsys) -> str:
    err = capsys.readouterr().err
    assert err.startswith("error: ") and err.count("\n") == 1, err
    assert "Traceback" not in err
    return err


@pytest.mark.parametrize("command", ["localize", "localize-run", "record"])
def test_an_unknown_env_is_a_one_line_error_and_writes_nothing(command, tmp_path, capsys):
    out = tmp_path / ("x.run" if command == "record" else "x")
    assert main([command, "--env", "sfa_gym/NoSuchEnv-v0", "--out", str(out)]) == 2
    err = _one_line_error(capsys)
    assert "'sfa_gym/NoSuchEnv-v0' is not a registered env" in err
    assert "sfa_gym/OmniRover-v0" in err  # says what exists
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("command", ["localize", "localize-run", "record"])
def test_an_out_that_is_a_file_is_a_one_line_error(command, tmp_path, capsys):
    out = tmp_path / ("x.run" if command == "record" else "x")
    out.write_text("not a folder\n")
    assert main([command, "--out", str(out), "--quiet"]) == 2
    err = _one_line_error(capsys)
    assert repr(str(out)) in err and ("is a file" in err or "is not a directory" in err)
    assert out.read_text() == "not a folder\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["x.run" if command == "record" else "x"]


@pytest.mark.parametrize(
    ("options", "message"),
    [
        (["--driver", "lawnmower", "--spacing", "0"], "spacing must be"),
        (["--driver", "lawnmower", "--spin", "nan"], "spin must be a finite number"),
        (["--driver", "randomwalk", "--steps", "5", "--turn-probability", "2"], "turn_probab"),
        (["--driver", "randomwalk"], "never finishes"),
        (["--driver", "grid", "--grid", "0"], "grid must be a positive int"),
        (["--steps", "0"], "n_steps must be a positive int"),
    ],
)
def test_record_checks_every_option_before_writing_anything(options, message, tmp_path, capsys):
    out = tmp_path / "bad.run"
    assert main(["record", "--out", str(out), "--quiet", *options]) == 2
    assert message in _one_line_error(capsys)
    # nothing that would block the corrected command
    assert list(tmp_path.iterdir()) == []
