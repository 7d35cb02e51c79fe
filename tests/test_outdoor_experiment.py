"""The outdoor protocol: settings and their errors, each appearance condition changes one thing,
and a short drive through the real outdoor env end to end through the CLI."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from sfa_gym.cli.localize import OutdoorExperiment
from sfa_gym.geometry import in_rectangle
from sfa_gym.protocols.outdoor import CONDITIONS
from sfa_gym.protocols.settings import SFASettings
from sfa_gym.recording.runfile import load_run
from sfa_gym.sim.worlds import load_world_spec


def test_each_condition_changes_one_thing_against_the_run_right_after_training():
    config = OutdoorExperiment(start_hour=9.0, later_hours=3.0)
    drive = config.env_kwargs("after", 0)
    declared = load_world_spec("paper_outdoor").dynamics
    assert drive.pop("dynamics") == dataclasses.replace(declared, start_hour=9.0)
    assert drive["rover"] == "outdoor" and drive["sensor"]
    # the test runs start where the "after" part of the drive does: 5900 frames of 0.1 s later
    hour = 9.0 + 590.0 / 3600.0
    fog = {"overcast": 1.0, "visibility_m": config.fog_visibility_m}
    for condition, change in (
        ("later", {"start_hour": hour + 3.0}),
        ("no_movers", {"movers": False}),
        ("overcast", {"overcast": 1.0}),
        ("other_day", {"day": 1}),
        ("fog", fog),
        ("rearranged", {"arrangement": 1}),
        ("wet", {"ground": "wet"}),
        ("snow", {"ground": "snow"}),
    ):
        kwargs = config.env_kwargs(condition, 0)
        dynamics = kwargs.pop("dynamics")
        assert dynamics.start_hour == pytest.approx(change.pop("start_hour", hour))
        assert dynamics == dataclasses.replace(declared, start_hour=dynamics.start_hour, **change)
        assert kwargs == drive
    assert set(CONDITIONS) == {
        "after",
        "later",
        "overcast",
        "no_movers",
        "other_day",
        "fog",
        "rearranged",
        "other_season",
        "wet",
        "snow",
    }


def test_other_seasons_test_later_in_the_year_with_the_seasons_of_the_drive():
    config = OutdoorExperiment(
        day_of_year=300,
        seasons=True,
        conditions=("after", "other_season"),
        season_days=(92, 183),
    )
    assert config.test_conditions == ("after", "other_season+92d", "other_season+183d")
    drive = config.env_kwargs("after", 0)["dynamics"]
    assert (drive.day_of_year, drive.seasons) == (300, True)
    for name, date in (("other_season+92d", 27), ("other_season+183d", 118)):  # wraps the year
        kwargs = config.env_kwargs(name, 0)
        dynamics = kwargs.pop("dynamics")
        assert dynamics == dataclasses.replace(
            drive, day_of_year=date, start_hour=dynamics.start_hour
        )
        assert dynamics.start_hour == pytest.approx(config.start_hour + 590.0 / 3600.0)


def test_ablation_switches_reach_the_env_kwargs():
    config = OutdoorExperiment(dynamics=False, sensor=False, vibration=False, camera="cylindrical")
    kwargs = config.env_kwargs("after", 0)
    assert kwargs["dynamics"] is False and kwargs["sensor"] is False
    assert kwargs["rover"] == "default" and kwargs["camera"] == "cylindrical"


@pytest.mark.parametrize(
    ("changes", "match"),
    [
        ({"conditions": ("after", "sunset")}, "conditions must be one of"),
        ({"conditions": ()}, "conditions must be a non-empty tuple"),
        ({"dynamics": False, "conditions": ("after", "overcast")}, r"\['overcast'\].*dynamics"),
        ({"start_hour": 24.0}, r"start_hour must lie in \[0, 24\)"),
        ({"later_hours": float("nan")}, "later_hours must be a finite number"),
        ({"train_frames": 5}, "train_frames must be >= 10"),
        ({"frame_dt": 0.0}, "frame_dt must be a positive number of seconds"),
        ({"spacing": -1.0}, "spacing must be a positive number"),
        ({"panorama": (60, 601)}, "601"),
        ({"camera": "fisheye"}, "camera must be one of"),
        ({"sensor": 1}, "sensor must be True or False"),
        ({"normalise": "equalise"}, "normalise must be one of"),
        ({"train_also": (0.0,)}, "train_also must be a tuple of non-zero hours"),
        ({"train_also": (2.0,), "dynamics": False}, "train_also .* needs dynamics=True"),
        ({"train_also": (2.0,), "train_also_order": "days"}, "train_also_order must be one of"),
        ({"train_also_order": "rotations"}, "orders the train_also runs: give train_also"),
        ({"conditions": ("after", "other_season")}, "other_season .* give a day_of_year|date the"),
        (
            {"conditions": ("after", "other_season"), "day_of_year": 100, "season_days": 365},
            r"season_days must be a whole number of days in 1\.\.364",
        ),
        ({"seasons": True}, "seasons=True sets the foliage by the date: give a day_of_year"),
    ],
)
def test_bad_settings_are_named(changes, match):
    with pytest.raises((ValueError, TypeError), match=match):
        dataclasses.replace(OutdoorExperiment(), **changes).validate()


def test_short_outdoor_drive_end_to_end(tmp_path, capsys):
    """250 training and 250 test frames every 0.8 s (short versions of the paper's paths,
    driven at its speed, sampled 8 times less often), 16 x 160 panoramas, a tiny network, band
    means beside SFA."""
    from sfa_gym.cli.main import main

    out = tmp_path / "outdoor"
    baselines = tmp_path / "plugins"
    baselines.mkdir()
    from sfa_gym.plugins import default_plugin_folder

    folder, _ = default_plugin_folder()
    (baselines / "band_means.py").write_text((folder / "band_means.py").read_text())
    args = [
        "localize-outdoor",
        "--out",
        str(out),
        "--baselines",
        str(baselines),
        "--quiet",
        "--train-frames",
        "250",
        "--test-frames",
        "250",
        "--frame-dt",
        "0.8",
        "--spacing",
        "2",
        "--test-spacing",
        "2",
        "--panorama",
        "16",
        "160",
        "--network",
        "tiny",
        "--node-dim",
        "8",
        "--conditions",
        "after",
        "no_movers",
    ]
    assert main(args) == 0
    table = capsys.readouterr().out
    assert "after x/y %" in table and "no_movers x/y %" in table and "paper (2013)" in table
    results = json.loads((out / "results.json").read_text())
    assert results["protocol"] == "outdoor" and results["n_rotations"] == 32
    for name in ("trajectories.png", "estimates.png", "error_map.png", "firing_maps.png"):
        assert (out / name).stat().st_size > 10_000

    drive = load_run(out / "drive.run")
    assert len(drive) == 500 and drive.metadata["env_id"] == "sfa_gym/OmniRoverOutdoor-v0"
    assert drive.metadata["rover"]["mast_stiffness"] > 0 and drive.metadata["camera"] == "mirror"
    region = results["unvisited_region"]
    xy = drive.positions
    # the training part never enters the region, the test part does
    assert not in_rectangle(xy[:250], region).any() and in_rectangle(xy[250:], region).any()
    # the no_movers test run drives the same path as the "after" part
    alone = load_run(out / "test_no_movers.run")
    assert np.abs(alone.positions - xy[250:]).max() < 0.05

    sfa = results["methods"]["hierarchical_sfa"]
    assert max(sfa["eta_phi"]) < 0.1
    mean_guess = np.abs(xy[250:] - xy[:250].mean(axis=0)).mean(axis=0)
    for condition in ("after", "no_movers"):
        error = sfa["quadratic"][condition]["all"]["mae_m"]
        # the slow features know where the rover is: far better than guessing the mean
        assert np.all(np.array(error) < 0.6 * mean_guess), (condition, error, mean_guess)
    assert "band_means" in results["methods"]


def test_training_runs_interleave_frame_by_frame():
    from sfa_gym.protocols.outdoor import interleave

    a = np.arange(6).reshape(3, 2)
    got = interleave([a, a + 100, a + 200])
    np.testing.assert_array_equal(got[:4], [[0, 1], [100, 101], [200, 201], [2, 3]])
    assert got.shape == (9, 2)


def test_sfa_settings_default_to_the_network_of_the_panorama_size():
    assert OutdoorExperiment().sfa == SFASettings(network="auto")
