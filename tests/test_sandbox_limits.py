"""The limits of a plug-in's worker: time limits set from the command line or a track file (the
command line's over the track's over the defaults), a memory limit that stops a plug-in which
allocates past it without harming the evaluator, and options refused before anything starts."""

from __future__ import annotations

import copy
import json
import os
import re
from pathlib import Path

import numpy as np
import pytest
from test_leaderboard import TINY, _write_track, band_means_fitting
from test_sandbox import _views

from sfa_gym.cli.main import main
from sfa_gym.leaderboard.evaluate import Task, run_task, task_limits
from sfa_gym.leaderboard.tracks import TrackError, load_track, track_from_dict
from sfa_gym.plugins import load_method
from sfa_gym.sandbox import Limits, PluginOutOfMemory, PluginTimeout

ROOT = Path(__file__).resolve().parents[1]
BAND_MEANS = ROOT / "baselines" / "band_means.py"

HOG = """
from dataclasses import dataclass
import numpy as np

@dataclass(frozen=True)
class Args:
    mib: int = 2048

class Hog:
    name = "hog"
    def __init__(self, mib=2048):
        self.mib = mib
    def fit(self, views, sequence_ids=None):
        self.input_shape_ = views.shape[1:]
        self.held = np.ones(self.mib * 2**20, dtype=np.uint8)  # touched: really allocated
        return self
    def transform(self, views):
        return np.zeros((len(views), 2))

METHOD = Hog
"""


def _slow(tmp_path: Path) -> Path:
    return band_means_fitting(tmp_path / "slow.py", "import time\ntime.sleep(600)")


# ------------------------------------------------------------------------------ time limits


def test_the_command_line_limits_override_the_tracks_which_override_the_defaults():
    track = track_from_dict(
        {**copy.deepcopy(TINY), "time_limits": {"fit": 5, "transform": 7}, "memory_limit_mb": 900},
        "tiny.json",
    )
    assert task_limits(track, Task("t", "m")) == Limits(fit=5, transform=7, memory_mb=900)
    given = Task("t", "m", time_limits={"fit": 3}, memory_limit_mb=800)
    assert task_limits(track, given) == Limits(fit=3, transform=7, memory_mb=800)
    plain = track_from_dict(copy.deepcopy(TINY), "tiny.json")
    assert task_limits(plain, Task("t", "m")) == Limits()
    assert "time_limits" not in plain.describe()  # a file without limits is described as it is


def test_a_time_limit_of_the_track_file_stops_a_plugin(tmp_path):
    track = _write_track(tmp_path / "tracks", {**copy.deepcopy(TINY), "time_limits": {"fit": 2}})
    assert load_track(track).time_limits == {"fit": 2}
    task = Task(str(track), str(_slow(tmp_path)), {}, 100, cache_dir=str(tmp_path / "cache"))
    with pytest.raises(PluginTimeout, match=r"slow\.py took longer than its limit of 2 s for fit"):
        run_task(task)


def test_a_time_limit_from_the_command_line_reaches_every_task(tmp_path, capsys):
    # the track allows ten minutes; the command line's two seconds win
    tracks = tmp_path / "tracks"
    _write_track(tracks, {**copy.deepcopy(TINY), "time_limits": {"fit": 600}})
    results = tmp_path / "results"
    status = main(
        [
            "leaderboard",
            "run",
            "--method",
            str(_slow(tmp_path)),
            "--track",
            "tiny",
            "--time-limits",
            "fit=2",
            "transform=30",
            "--tracks",
            str(tracks),
            "--results",
            str(results),
            "--cache",
            str(tmp_path / "cache"),
        ]
    )
    err = capsys.readouterr().err
    assert status == 1
    for seed in (100, 101):  # both world seeds of the full size
        assert f"world seed {seed}: FAILED, PluginTimeout" in err
    assert err.count("took longer than its limit of 2 s for fit()") >= 2
    files = sorted((results / "tasks" / "tiny").glob("*/*.json"))
    assert [f.name for f in files] == ["100.json", "101.json"]
    for file in files:  # each task's failure is recorded with the limit
        assert "limit of 2 s" in json.loads(file.read_text())["failure"]["message"]


@pytest.mark.parametrize(
    ("option", "message"),
    [
        (["--time-limits", "fitt=10"], "--time-limits: no time limit named 'fitt'"),
        (["--time-limits", "fit=0"], "time limit fit must be a positive number of seconds"),
        (["--time-limits", "fit=soon"], "time limit fit must be a positive number.*'soon'"),
        (["--time-limits", "fit"], "--time-limits takes NAME=VALUE items, got 'fit'"),
        (["--memory-limit-mb", "0"], "--memory-limit-mb must be a positive int of MiB, got 0"),
        (["--backend", "ray", "--num-cpus", "0"], "--num-cpus must be an int >= 1.*got 0"),
        (["--num-cpus", "-2"], "--num-cpus must be an int >= 1.*got -2"),
    ],
)
def test_bad_limits_on_the_command_line_are_refused_before_anything_starts(
    tmp_path, capsys, option, message
):
    results = tmp_path / "results"
    argv = ["leaderboard", "run", "--method", "band_means", "--results", str(results), *option]
    assert main(argv) == 2
    assert re.search(message, capsys.readouterr().err)
    assert not results.exists()  # refused before a task or a results folder


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"time_limits": {"fitt": 3}}, r"tiny\.json: time_limits: no time limit named 'fitt'"),
        ({"time_limits": {"act": 0}}, r"tiny\.json: time_limits: time limit act must be a pos"),
        ({"time_limits": {"fit": "1h"}}, r"tiny\.json: time_limits: time limit fit .*'1h'"),
        ({"time_limits": [1800]}, r"tiny\.json: time_limits must be an object"),
        ({"memory_limit_mb": -1}, r"tiny\.json: memory_limit_mb must be a positive int"),
        ({"memory_limit_mb": 1.5}, r"tiny\.json: memory_limit_mb must be a positive int"),
    ],
)
def test_bad_limits_in_a_track_file_are_refused_naming_file_and_field(change, message):
    with pytest.raises(TrackError, match=message):
        track_from_dict({**copy.deepcopy(TINY), **change}, "tiny.json")


# ----------------------------------------------------------------------------- memory limit


def test_a_plugin_past_its_memory_limit_fails_naming_it_and_the_evaluator_goes_on(tmp_path):
    hog = tmp_path / "hog.py"
    hog.write_text(HOG)
    with load_method(hog, limits=Limits(memory_mb=600)) as method:
        with pytest.raises(PluginOutOfMemory, match=r"hog\.py ran out of its memory limit of 600"):
            method.fit(_views())
        # the worker itself survived its refused allocation
        assert method.transform(_views()).shape == (6, 2)
    # under the limit the same plug-in fits; and the evaluator's own memory was never limited
    with load_method(hog, {"mib": 100}, limits=Limits(memory_mb=600)) as method:
        assert method.fit(_views()).transform(_views()).shape == (6, 2)
    assert np.ones(2**30, dtype=np.uint8).sum() == 2**30


def test_a_memory_limit_reaches_a_leaderboard_task(tmp_path):
    hog = tmp_path / "hog.py"
    hog.write_text(HOG)
    track = _write_track(tmp_path / "tracks", {**copy.deepcopy(TINY), "memory_limit_mb": 600})
    cache = str(tmp_path / "cache")
    with pytest.raises(PluginOutOfMemory, match="memory limit of 600 MiB in fit"):
        run_task(Task(str(track), str(hog), {}, 100, cache_dir=cache))
    with pytest.raises(PluginOutOfMemory, match="memory limit of 500 MiB in fit"):
        run_task(Task(str(track), str(hog), {}, 100, cache_dir=cache, memory_limit_mb=500))
    # the task after them runs as usual
    assert run_task(Task(str(track), str(BAND_MEANS), {}, 100, cache_dir=cache))["scores"]


def test_the_default_memory_limit_is_three_quarters_of_the_machine():
    import os

    machine = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") // 2**20
    assert Limits().memory_mb == pytest.approx(machine * 3 / 4, abs=1)
    with pytest.raises(ValueError, match="memory limit memory_mb must be a positive int"):
        Limits(memory_mb=0)


def test_tasks_that_run_at_once_share_the_default_memory_limit(tmp_path):
    from sfa_gym.leaderboard.evaluate import task_limits
    from sfa_gym.leaderboard.sweep import concurrent_tasks
    from sfa_gym.leaderboard.tracks import load_track

    whole = Limits().memory_mb
    assert concurrent_tasks("local", None, None) == 1
    assert concurrent_tasks("ray", None, 3) == 3
    assert concurrent_tasks("ray", "auto", None) is None  # each node's own CPUs
    track = load_track(_write_track(tmp_path / "tracks", copy.deepcopy(TINY)))
    shared = task_limits(track, Task(str(track.path), "band_means", concurrent_tasks=3))
    assert shared.memory_mb == whole // 3
    per_node = task_limits(track, Task(str(track.path), "band_means", concurrent_tasks=None))
    assert per_node.memory_mb == whole // (os.cpu_count() or 1)
    # a limit given explicitly is each worker's own
    given = Task(str(track.path), "band_means", memory_limit_mb=700, concurrent_tasks=3)
    assert task_limits(track, given).memory_mb == 700
    with pytest.raises(ValueError, match="sharing must be a positive int"):
        Limits.of({}, None, 0)
