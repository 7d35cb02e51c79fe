"""A sweep plans its tasks from what a plug-in's worker reports of its ``Args``: the evaluator
never imports the file, a refused argument is named with its file before any task runs, and the
arguments a task's identity records are those the plug-in gives in-process."""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest
from test_leaderboard import TINY, _write_track

from sfa_gym.leaderboard import sweep
from sfa_gym.leaderboard.evaluate import IN_PROCESS
from sfa_gym.leaderboard.results import method_label
from sfa_gym.leaderboard.sweep import run_sweep
from sfa_gym.leaderboard.task_files import task_identity
from sfa_gym.leaderboard.tracks import load_track
from sfa_gym.plugin_files import PluginError, list_plugin_files
from sfa_gym.plugins import load_plugin
from sfa_gym.sandbox import PluginTimeout, describe_plugin

ROOT = Path(__file__).resolve().parents[1]
BAND_MEANS = ROOT / "baselines" / "band_means.py"

# At import: a line on stderr (inherited by a worker) and, where it may write, a line in a file.
SPY = """

import os as _os, sys as _sys

print(f"plug-in imported in pid {_os.getpid()}", file=_sys.stderr)
try:
    with open(MARKER, "a") as _file:
        _file.write(f"{_os.getpid()}\\n")
except OSError:  # a confined worker cannot write outside its scratch folder
    pass
"""


@pytest.fixture
def planned(monkeypatch):
    """The tasks each sweep hands its backend (none is run: planning is what is tested)."""
    handed = []

    def run_each(tasks, backend, **options):
        handed.extend(tasks)
        return iter(())

    monkeypatch.setattr(sweep, "run_each", run_each)
    return handed


def _spy(tmp_path: Path) -> tuple[Path, Path]:
    marker = tmp_path / "imported_in.txt"
    path = tmp_path / "spy.py"
    path.write_text(BAND_MEANS.read_text() + SPY.replace("MARKER", repr(str(marker))))
    return path, marker


def _pids(marker: Path) -> list[int]:
    return [int(line) for line in marker.read_text().split()] if marker.exists() else []


def test_a_sweep_plans_its_tasks_without_importing_the_plugin(
    tmp_path, planned, capfd, monkeypatch
):
    track = load_track(_write_track(tmp_path / "tracks", TINY))
    spy, marker = _spy(tmp_path)
    run_sweep([track], [(spy, {"n_bands": 4})], tmp_path / "results", quick=True, verbose=False)
    assert [(t.method_path, t.method_args) for t in planned] == [(str(spy), {"n_bands": 4})]
    err = capfd.readouterr().err
    assert "plug-in imported in pid" in err  # its worker read its Args
    assert f"plug-in imported in pid {os.getpid()}\n" not in err
    assert os.getpid() not in _pids(marker)

    # in-process mode keeps importing the file into the evaluator (what the test would catch)
    monkeypatch.setenv(IN_PROCESS, "1")
    run_sweep([track], [(spy, {"n_bands": 4})], tmp_path / "results2", quick=True)
    assert os.getpid() in _pids(marker)


@pytest.mark.parametrize(
    ("method", "args", "named"),
    [
        ("band_means", {"n_bandz": 4}, r"unknown argument 'n_bandz'"),
        ("band_means", {"n_bands": "four"}, r"argument n_bands must be int, got 'four'"),
        ("sfa", {"node_dim": -1}, r"node_dim.*-1"),  # refused by the factory, not by Args
    ],
)
def test_bad_arguments_are_refused_naming_the_file_before_any_task(
    tmp_path, planned, method, args, named
):
    track = load_track(_write_track(tmp_path / "tracks", TINY))
    path = ROOT / "baselines" / f"{method}.py"
    with pytest.raises(ValueError, match=rf"{path}.*{named}"):
        run_sweep([track], [(path, args)], tmp_path / "results", quick=True, verbose=False)
    assert planned == []
    assert not (tmp_path / "results").exists()


def test_a_bad_controller_argument_is_named_with_its_file():
    path = ROOT / "baselines" / "controllers" / "run_and_tumble.py"
    with pytest.raises(ValueError, match=rf"{path}.*argument patience must be int"):
        describe_plugin(path, "controller", {"patience": 2.5}, limit=60)


def test_a_plugin_that_hangs_while_describing_is_stopped_at_the_load_limit(tmp_path):
    path = tmp_path / "sleeps.py"
    path.write_text(BAND_MEANS.read_text() + "\nimport time\ntime.sleep(60)\n")
    with pytest.raises(PluginTimeout, match=r"sleeps\.py took longer than its limit of 2 s"):
        describe_plugin(path, "method", {}, limit=2)


def test_a_file_that_breaks_the_contract_is_a_plugin_error(tmp_path):
    path = tmp_path / "no_args.py"
    path.write_text("def make_method(**kwargs):\n    return None\n")
    with pytest.raises(PluginError, match=rf"{path} defines no Args dataclass"):
        describe_plugin(path, "method", {}, limit=60)


def _as_before(kind: str, path: Path, args: dict) -> dict:
    """What a sweep recorded of a plug-in when it imported the file itself."""
    import dataclasses

    from sfa_gym.plugins import file_sha256

    factory = load_plugin(path, kind)
    filled = factory.arguments(args)
    defaults = {f.name: f.default for f in dataclasses.fields(factory.args_type)}
    return {
        "name": factory.name,
        "label": method_label(factory.name, filled, defaults),
        "path": str(factory.path),
        "sha256": file_sha256(factory.path),
        "args": dict(args),
        "all_args": filled,
    }


SOME_ARGS = {"band_means": {"n_bands": 4}, "pca": {"whiten": False}, "sfa": {"node_dim": 16}}


@pytest.mark.parametrize(
    ("kind", "path"),
    [("method", p) for p in list_plugin_files(ROOT / "baselines")]
    + [("controller", p) for p in list_plugin_files(ROOT / "baselines" / "controllers")],
    ids=lambda v: getattr(v, "stem", v),
)
def test_the_shipped_baselines_keep_their_labels_and_task_identities(tmp_path, kind, path):
    track = load_track(_write_track(tmp_path / "tracks", TINY))
    for args in ({}, SOME_ARGS.get(path.stem, {})):
        before = _as_before(kind, path, args)
        now = sweep._describe(kind, path, args, [])
        assert json.loads(json.dumps(now)) == json.loads(json.dumps(before))
        assert now["label"] == before["label"]
        assert task_identity(track, True, 100, now, None) == task_identity(
            track, True, 100, before, None
        )


def test_the_command_line_names_the_file_and_the_argument_and_runs_nothing(tmp_path, capsys):
    from sfa_gym.cli.main import main

    tracks, results = tmp_path / "tracks", tmp_path / "results"
    _write_track(tracks, TINY)
    argv = ["leaderboard", "run", "--method", str(BAND_MEANS), "--method-args", "n_bandz=4"]
    argv += ["--track", "tiny", "--tracks", str(tracks), "--results", str(results)]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert f"error: {BAND_MEANS}: unknown argument 'n_bandz'" in err
    assert not results.exists()
