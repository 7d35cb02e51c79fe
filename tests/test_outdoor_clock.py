"""The outdoor protocol's clock and weather as options: the sun of a date and place, the weather
and mover day, several later offsets and other days in one run (one condition each), the old
single-value forms unchanged, bad values named, and a track naming them scored end to end."""

from __future__ import annotations

import dataclasses
import json
import math
import re
from pathlib import Path

import pytest
from test_leaderboard_outdoor import TINY_PARAMS

from sfa_gym.cli.localize import OutdoorExperiment
from sfa_gym.leaderboard.tracks import TrackError, track_from_dict
from sfa_gym.protocols.outdoor import Config, requests
from sfa_gym.sim.worlds import load_world_spec
from sfa_gym.sim.worlds.sun import daylight_hours

ROOT = Path(__file__).resolve().parents[1]
# the test runs start when the drive's test part does: 5900 frames of 0.1 s after 10:00
HOUR = 10.0 + 590.0 / 3600.0
ALL = ("after", "later", "overcast", "no_movers", "other_day")


def test_several_later_offsets_and_other_days_give_one_condition_each():
    config = Config(conditions=ALL, later_hours=(2.0, 6.0), other_days=(1, 3))
    assert config.test_conditions == (
        "after",
        "later+2h",
        "later+6h",
        "overcast",
        "no_movers",
        "other_day+1",
        "other_day+3",
    )
    for name, hours in (("later+2h", 2.0), ("later+6h", 6.0)):
        assert config.env_kwargs(name, 0)["dynamics"].start_hour == pytest.approx(HOUR + hours)
    declared = load_world_spec("paper_outdoor").dynamics
    for name, day in (("other_day+1", 1), ("other_day+3", 3)):
        dynamics = config.env_kwargs(name, 0)["dynamics"]
        assert dynamics == dataclasses.replace(
            declared, day=declared.day + day, start_hour=dynamics.start_hour
        )
        assert dynamics.start_hour == pytest.approx(HOUR)
    config = dataclasses.replace(config, panorama=(40, 350))
    runs = requests(config, 0)
    assert list(runs) == ["drive", *config.test_conditions[1:]]
    assert len({r.key() for r in runs.values()}) == len(runs)  # every run its own render
    with pytest.raises(ValueError, match=r"unknown test condition 'later'.*'later\+2h'"):
        config.env_kwargs("later", 0)


def test_a_single_offset_keeps_the_old_names_and_runs():
    old = OutdoorExperiment(conditions=ALL, start_hour=9.0, later_hours=3.0)
    assert old.test_conditions == ALL
    # one offset in a tuple names it; the run is the same as the single value's
    one = dataclasses.replace(old, later_hours=(3.0,), other_days=(1,))
    assert one.test_conditions == ("after", "later+3h", "overcast", "no_movers", "other_day+1")
    assert one.env_kwargs("later+3h", 0) == old.env_kwargs("later", 0)
    assert one.env_kwargs("other_day+1", 0) == old.env_kwargs("other_day", 0)
    panorama = dataclasses.replace(old, panorama=(40, 350))
    keys = {n: r.key() for n, r in requests(panorama, 0).items()}
    again = dataclasses.replace(one, panorama=(40, 350))
    assert requests(again, 0)["later+3h"].key() == keys["later"]


def test_the_date_place_and_day_reach_every_run():
    config = Config(conditions=ALL, day_of_year=15, latitude_deg=50.0, day=2, train_also=(1.0,))
    declared = load_world_spec("paper_outdoor").dynamics
    dated = dataclasses.replace(declared, day_of_year=15, latitude_deg=50.0, day=2)
    assert config.world_dynamics() == dated
    for condition, change in (
        ("after", {}),
        ("later", {}),
        ("no_movers", {"movers": False}),
        ("overcast", {"overcast": 1}),
        ("other_day", {"day": 3}),
    ):
        dynamics = config.env_kwargs(condition, 0)["dynamics"]
        assert dynamics == dataclasses.replace(dated, start_hour=dynamics.start_hour, **change)
    config = dataclasses.replace(config, panorama=(40, 350))
    runs = requests(config, 0)
    dynamics = runs["train_+1h"].env_kwargs["dynamics"]
    assert dynamics == dataclasses.replace(dated, start_hour=config.start_hour + 1.0)
    plain = dataclasses.replace(config, day_of_year=None, latitude_deg=None, day=None)
    undated = requests(plain, 0)
    assert all(runs[n].key() != undated[n].key() for n in runs)
    # the winter sun: a short day
    sunrise, sunset = dated.daylight
    assert (sunrise, sunset) == daylight_hours(15, 50.0) and sunset - sunrise < 9


@pytest.mark.parametrize(
    ("changes", "match"),
    [
        ({"day_of_year": 0}, "day_of_year must be an integer in 1..366, got 0"),
        ({"day_of_year": 15, "latitude_deg": -91.0}, "latitude_deg must be a number of degrees"),
        ({"latitude_deg": 50.0}, "latitude_deg=50.0 places the sun by date"),
        ({"day": -1}, "day must be an int >= 0, got -1"),
        ({"day_of_year": 15, "dynamics": False}, r"\['day_of_year'\] set the world's dynamics"),
        ({"later_hours": (2.0, 6.0)}, r"later_hours=\(2.0, 6.0\) gives the offsets of the 'later'"),
        ({"conditions": ("later",), "later_hours": ()}, "later_hours must be a number or a non"),
        ({"conditions": ("later",), "later_hours": (2.0, 2.0)}, r"later_hours \[2.0, 2.0\] rep"),
        ({"conditions": ("later",), "later_hours": (2.0, 2.0000001)}, "repeats an offset"),
        ({"conditions": ("later",), "later_hours": (2.0, math.inf)}, "later_hours must be a fin"),
        ({"conditions": ("other_day",), "other_days": (1, 0)}, "other_days must be a whole num"),
        ({"conditions": ("other_day",), "other_days": 1.5}, "got 1.5"),
    ],
)
def test_bad_clock_settings_are_named(changes, match):
    with pytest.raises((ValueError, TypeError), match=match):
        dataclasses.replace(Config(), **changes).validate()


def _track(**params) -> dict:
    data = json.loads((ROOT / "tracks" / "outdoor_appearance.json").read_text())
    data["name"] = "outdoor_winter"
    data["params"].update(params)
    return data


def test_a_track_can_name_the_clock_and_weather():
    track = track_from_dict(
        _track(conditions=["later"], later_hours=[2, 6], day_of_year=15, latitude_deg=50, day=1)
    )
    config = track.config(quick=True)
    assert config.later_hours == (2, 6) and config.day_of_year == 15 and config.day == 1
    assert config.test_conditions == ("later+2h", "later+6h")  # "after" is scored beside
    with pytest.raises(TrackError, match=re.escape("day_of_year must be an integer in 1..366")):
        track_from_dict(_track(day_of_year=400))
    with pytest.raises(TrackError, match="other_days must be a whole number of days"):
        track_from_dict(_track(other_days=[1, -1]))


# the short versions of the paper's paths at 16 x 160 pixels of the tiny outdoor track
CLOCK = ("start_hour", "later_hours", "conditions")  # what these tests set themselves
TINY = {k: v for k, v in TINY_PARAMS.items() if k not in CLOCK}


def test_a_winter_day_tested_two_and_six_hours_later_through_the_command_line(tmp_path, capsys):
    from sfa_gym.cli.main import main

    out = tmp_path / "winter"
    args = ["localize-outdoor", "--out", str(out), "--quiet", "--no-baselines"]
    for name, value in TINY.items():
        values = value if isinstance(value, list) else [value]
        args += [f"--{name.replace('_', '-')}", *map(str, values)]
    args += ["--day-of-year", "15", "--latitude-deg", "50", "--start-hour", "9"]
    args += ["--conditions", "after", "later", "--later-hours", "2", "6", "--network", "auto"]
    args += ["--node-dim", "8"]  # the tiny network (auto at 16 x 160), small
    assert main(args) == 0
    table = capsys.readouterr().out
    assert "later+2h x/y %" in table and "later+6h x/y %" in table
    results = json.loads((out / "results.json").read_text())
    assert list(results["runs"]) == ["train", "after", "later+2h", "later+6h"]
    start = 9.0 + 133 * 1.6 / 3600.0
    for name, hours in (("later+2h", 2), ("later+6h", 6)):
        assert results["runs"][name]["run_start_hour"] == pytest.approx(start + hours)
        assert (out / f"test_{name}.run").is_dir()
    linear = results["methods"]["hierarchical_sfa"]["linear"]
    assert list(linear) == ["after", "later+2h", "later+6h"]
    assert all(math.isfinite(v) for c in linear.values() for v in c["all"]["mae_percent"])


def test_a_winter_track_scores_each_later_offset(tmp_path):
    from sfa_gym.leaderboard.results import load_results
    from sfa_gym.leaderboard.sweep import run_sweep
    from sfa_gym.leaderboard.tracks import load_track

    data = _track(**TINY, conditions=["later"], later_hours=[2, 6], day_of_year=15, latitude_deg=50)
    data.update(world_seeds=[300], quick={"world_seeds": 1})
    (tmp_path / "outdoor_winter.json").write_text(json.dumps(data))
    track = load_track(tmp_path / "outdoor_winter.json")
    band_means = ROOT / "baselines" / "band_means.py"
    run_sweep([track], [(band_means, {})], tmp_path / "results", cache_dir=tmp_path / "cache")
    (task,) = (tmp_path / "results" / "tasks").rglob("*.json")
    scores = json.loads(task.read_text())["output"]["scores"]
    assert load_results(tmp_path / "results")[0]["parts"] == scores["parts"]
    assert list(scores["renders"]) == ["drive", "later+2h", "later+6h"]
    parts = scores["parts"]
    assert scores["score"] == pytest.approx((parts["later+2h"] + parts["later+6h"]) / 2)
    assert parts["later+2h"] != parts["later+6h"]  # two runs at two hours of a winter day


def test_the_textured_tracks_render_the_same_places_textured_and_cover_each_other():
    from sfa_gym.leaderboard.tracks import list_tracks
    from sfa_gym.protocols.outdoor import covers

    tracks = {t.name: t for t in list_tracks(ROOT / "tracks")}
    flat, textured = tracks["outdoor_paper"], tracks["outdoor_paper_textured"]
    assert textured.world_seeds == flat.world_seeds  # the same places, flat and textured
    flat_config, textured_config = flat.config(quick=False), textured.config(quick=False)
    assert dataclasses.replace(textured_config, textures=False) == flat_config
    # the flat world's runs keep the cache keys they had before the setting existed
    assert "textures" not in flat_config.env_kwargs("after", 300)
    assert textured_config.env_kwargs("after", 300)["textures"] is True
    flat_keys = {n: r.key() for n, r in requests(flat_config, 300).items()}
    textured_keys = {n: r.key() for n, r in requests(textured_config, 300).items()}
    assert flat_keys["drive"] != textured_keys["drive"]
    # one task of the textured appearance track scores the textured paper track, not the flat
    appearance = tracks["outdoor_appearance_textured"].config(quick=False)
    assert covers(appearance, textured_config) and not covers(appearance, flat_config)
    with pytest.raises(TypeError, match="textures must be True or False, got 1"):
        dataclasses.replace(Config(), textures=1).validate()


def test_white_balance_vignetting_and_blur_reach_the_env_only_when_switched_on():
    from sfa_gym.sim.camera.sensor import SensorSpec

    plain = Config().env_kwargs("after", 300)
    assert plain["sensor"] is True  # the runs of before keep their cache keys
    kwargs = Config(white_balance=True, vignetting=0.3).env_kwargs("later", 300)
    assert kwargs["sensor"] == SensorSpec(white_balance=True, vignetting=0.3)
    blurred = Config(exposure_s=0.02).env_kwargs("after", 300)
    assert blurred["sensor"] == SensorSpec(exposure_s=0.02)
    keys = {Config(white_balance=w).env_kwargs("after", 300)["sensor"] for w in (False, True)}
    assert len(keys) == 2
    for changes, match in (
        ({"vignetting": 1.0}, r"vignetting must be a number in \[0, 1\), got 1.0"),
        ({"white_balance": True, "sensor": False}, "effects of the sensor: sensor=True"),
        ({"vignetting": 0.2, "camera": "cylindrical"}, "needs the mirror camera"),
        ({"white_balance": 1}, "white_balance must be True or False, got 1"),
        ({"exposure_s": 0.01, "sensor": False}, "effects of the sensor: sensor=True"),
        ({"exposure_s": -1.0}, "exposure_s must be a finite number of seconds >= 0, got -1.0"),
    ):
        with pytest.raises((ValueError, TypeError), match=match):
            dataclasses.replace(Config(), **changes).validate()
