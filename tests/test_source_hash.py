"""A sweep's tasks run on the sources the sweep started with: a task whose package sources
changed at its start or during it fails instead of scoring with a mix of code versions, and
each task file records the hash it ran on."""

from __future__ import annotations

import json
import shutil
from dataclasses import replace
from pathlib import Path

import pytest
from test_leaderboard import BAND_MEANS, TINY, _write_track

import sfa_gym
from sfa_gym import source_hash
from sfa_gym.leaderboard import evaluate
from sfa_gym.leaderboard.evaluate import Task, run_task
from sfa_gym.leaderboard.sweep import SweepError, run_sweep
from sfa_gym.leaderboard.tracks import load_track


@pytest.fixture
def package_copy(tmp_path, monkeypatch) -> Path:
    """A copy of the sfa_gym sources, which the hash reads instead of the installed ones."""
    copy = tmp_path / "copy" / "sfa_gym"
    shutil.copytree(
        Path(sfa_gym.__file__).parent, copy, ignore=shutil.ignore_patterns("__pycache__")
    )
    monkeypatch.setattr(source_hash, "_PACKAGE", copy)
    return copy


def test_the_hash_reads_the_sources_from_disk_each_time(package_copy):
    installed = source_hash.package_sources_sha256(Path(sfa_gym.__file__).parent)
    before = source_hash.package_sources_sha256()
    assert before == installed  # the same files, the same relative paths
    source_hash.check_sources(before, "now")
    source_hash.check_sources(None, "now")  # no hash given: nothing to check
    rotation = package_copy / "rotation.py"
    rotation.write_text(rotation.read_text() + "\n# edited\n")
    with pytest.raises(source_hash.SourcesChangedError, match=before[:12]) as raised:
        source_hash.check_sources(before, "now")
    assert "now (sha256 " in str(raised.value) and str(package_copy) in str(raised.value)
    # a new file is another version too
    rotation.write_text(rotation.read_text().removesuffix("\n# edited\n"))
    assert source_hash.package_sources_sha256() == before
    (package_copy / "extra.py").write_text("")
    assert source_hash.package_sources_sha256() != before


def _edits(path: Path):
    """A stand-in for the protocol's scoring that edits ``path`` while the task runs."""

    def scores(*args, **kwargs):
        path.write_text(path.read_text() + "\n# edited during the task\n")
        return {"score": 1.0}, {}

    return scores


def test_a_task_fails_when_the_sources_change_before_or_during_it(
    tmp_path, package_copy, monkeypatch
):
    track = str(_write_track(tmp_path / "tracks", TINY))
    task = Task(track, str(BAND_MEANS), {}, 100, cache_dir=str(tmp_path / "cache"))
    started = source_hash.package_sources_sha256()
    monkeypatch.setattr(evaluate, "_protocol_scores", lambda *a, **k: ({"score": 1.0}, {}))
    assert run_task(replace(task, code_sha256=started))["scores"] == {"score": 1.0}
    with pytest.raises(source_hash.SourcesChangedError, match="at the task's start"):
        run_task(replace(task, code_sha256="0" * 64))
    monkeypatch.setattr(evaluate, "_protocol_scores", _edits(package_copy / "rotation.py"))
    with pytest.raises(source_hash.SourcesChangedError, match="at the task's end"):
        run_task(replace(task, code_sha256=started))


def test_a_sweep_records_its_hash_and_fails_the_tasks_of_edited_sources(
    tmp_path, package_copy, monkeypatch, capsys
):
    track = load_track(_write_track(tmp_path / "tracks", TINY))
    results = tmp_path / "results"
    common = {"cache_dir": tmp_path / "cache", "verbose": False, "quick": True}
    started = source_hash.package_sources_sha256()
    run_sweep([track], [(BAND_MEANS, {})], results, **common)
    task_file = results / "tasks" / "tiny" / "band_means.quick" / "100.json"
    record = json.loads(task_file.read_text())
    assert record["provenance"]["code_sha256"] == started
    assert record["output"]["scores"]["score"] > 0

    # resumed on other sources: the finished task is kept, and the sweep says so
    rotation = package_copy / "rotation.py"
    rotation.write_text(rotation.read_text() + "\n# edited after the task\n")
    run_sweep([track], [(BAND_MEANS, {})], results, **{**common, "verbose": True})
    assert "1 of them ran on other sfa_gym sources than these" in capsys.readouterr().err
    assert json.loads(task_file.read_text()) == record

    task_file.unlink()
    monkeypatch.setattr(evaluate, "_protocol_scores", _edits(rotation))
    with pytest.raises(SweepError, match="not those the sweep started with"):
        run_sweep([track], [(BAND_MEANS, {})], results, **common)
    failed = json.loads(task_file.read_text())
    assert failed["output"] is None and failed["failure"]["type"] == "SourcesChangedError"
