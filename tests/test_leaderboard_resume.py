"""A sweep loses nothing finished: each task's file is written as it finishes, a rerun runs only
the tasks not finished (a stale task file is computed again), a failing method or a dead Ray
worker leaves every other result written, and an unwritable results folder is refused before
any task."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
from test_leaderboard import BAND_MEANS, TINY, _write_track

from sfa_gym.leaderboard import backends
from sfa_gym.leaderboard.evaluate import IN_PROCESS
from sfa_gym.leaderboard.sweep import SweepError, run_sweep
from sfa_gym.leaderboard.tracks import load_track

ROOT = Path(__file__).resolve().parents[1]


def _plugin(folder: Path, name: str, tail: str = "") -> Path:
    """band_means under another name, with ``tail`` appended (a ``make_method`` there wins over
    band_means's ``METHOD``)."""
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"{name}.py"
    path.write_text(BAND_MEANS.read_text() + tail)
    return path


RAISES = """

class Raises(BandMeans):
    def fit(self, views, sequence_ids=None):
        raise RuntimeError("boom in fit")


def make_method(**args):
    return Raises(**args)
"""


@pytest.fixture
def calls(monkeypatch):
    """Every task the local backend runs, in order."""
    ran = []
    run_task = backends.run_task

    def counted(task):
        ran.append(task)
        return run_task(task)

    monkeypatch.setattr(backends, "run_task", counted)
    return ran


def _result(path: Path) -> dict:
    (result,) = json.loads(path.read_text())["results"]
    return result


def _files(results: Path) -> dict[str, bytes]:
    return {str(p.relative_to(results)): p.read_bytes() for p in sorted(results.rglob("*.json"))}


def test_a_rerun_runs_no_finished_task_and_a_stale_one_again(tmp_path, calls, capsys):
    tracks, results = tmp_path / "tracks", tmp_path / "results"
    method = _plugin(tmp_path / "plugins", "means")
    track = load_track(_write_track(tracks, TINY))
    common = {"cache_dir": tmp_path / "cache", "verbose": False}

    (pair,) = run_sweep([track], [(method, {})], results, **common)
    assert [t.world_seed for t in calls] == [100, 101]
    task_file = results / "tasks" / "tiny" / "means" / "100.json"
    record = json.loads(task_file.read_text())
    assert record["identity"]["track"]["track_version"] == 1
    assert record["identity"]["method"]["args"]["n_bands"] == 8  # all of them, defaults too
    assert record["output"]["scores"]["score"] == _result(pair)["per_world_seed"]["100"]
    first = _files(results)
    assert len(first) == 3  # two tasks and the pair

    calls.clear()
    assert run_sweep([track], [(method, {})], results, **common) == [pair]
    assert calls == []  # nothing ran again
    assert _files(results) == first  # and every file is as it was, byte for byte

    task_file.unlink()  # one task lost: only it runs
    run_sweep([track], [(method, {})], results, **common)
    assert [t.world_seed for t in calls] == [100]
    task_file.write_text(task_file.read_text()[:50])  # a damaged file: computed again
    run_sweep([track], [(method, {})], results, **common)
    assert [t.world_seed for t in calls] == [100, 100]
    scores = json.loads(first["tiny/means.json"])["results"][0]["per_world_seed"]
    assert _result(pair)["per_world_seed"] == scores  # same seed

    calls.clear()
    capsys.readouterr()
    method.write_text(method.read_text() + "\n# another version of the method\n")
    run_sweep([track], [(method, {})], results, **{**common, "verbose": True})
    assert [t.world_seed for t in calls] == [100, 101]  # a stale method file: computed again
    assert "world seed 101: computed again (stale: its method.sha256 differs)" in (
        capsys.readouterr().err
    )
    new_sha = _result(pair)["method_sha256"]
    assert new_sha != json.loads(first["tiny/means.json"])["results"][0]["method_sha256"]
    assert json.loads(task_file.read_text())["identity"]["method"]["sha256"] == new_sha

    calls.clear()
    run_sweep([track], [(method, {})], results, quick=True, **common)
    # the quick size scores fewer world seeds and changes nothing else: its task is the full
    # size's of the same seed, taken from its file
    assert calls == []
    quick_task = json.loads((results / "tasks" / "tiny" / "means.quick" / "100.json").read_text())
    assert quick_task["identity"]["quick"] is True
    assert quick_task["output"] == json.loads(task_file.read_text())["output"]
    assert quick_task["provenance"]["same_task_as"] == "tiny / means / world seed 100, full size"
    calls.clear()
    # a quick section edited (one more world seed, a smaller grid): the quick tasks are stale,
    # the full size's are not
    edited = {**TINY, "quick": {"world_seeds": 2, "params": {"grid": 5, "n_train": 12}}}
    track = load_track(_write_track(tracks, edited))
    run_sweep([track], [(method, {})], results, **common)
    assert calls == []
    run_sweep([track], [(method, {})], results, quick=True, **common)
    assert [t.world_seed for t in calls] == [100, 101]

    calls.clear()
    bumped = load_track(_write_track(tracks, {**TINY, "track_version": 2}))
    run_sweep([bumped], [(method, {})], results, quick=True, **common)
    assert [t.world_seed for t in calls] == [100]  # another track version: again
    calls.clear()
    run_sweep([bumped], [(method, {})], results, **common)
    assert [t.world_seed for t in calls] == [101]  # 100: the quick task of this version
    calls.clear()
    run_sweep([bumped], [(method, {})], results, resume=False, **common)
    assert len(calls) == 2  # resume=False: every task


def test_a_failing_method_loses_no_other_result_and_fails_the_command(tmp_path, calls, capsys):
    from sfa_gym.cli.main import main

    tracks, results = tmp_path / "tracks", tmp_path / "results"
    _write_track(tracks, TINY)
    raises = _plugin(tmp_path / "plugins", "raises", RAISES)
    argv = ["leaderboard", "run", "--method", str(raises), str(BAND_MEANS), "--track", "tiny"]
    argv += ["--tracks", str(tracks), "--results", str(results), "--cache", str(tmp_path / "c")]

    assert main(argv) == 1
    err = capsys.readouterr().err
    assert "2 task(s) failed" in err
    assert "tiny / raises / world seed 100: RuntimeError: boom in fit" in err
    assert "tiny / raises / world seed 101: RuntimeError: boom in fit" in err
    assert len(calls) == 4  # the failures did not stop band_means, which came after them
    assert list(_result(results / "tiny" / "band_means.json")["per_world_seed"]) == ["100", "101"]
    assert not (results / "tiny" / "raises.json").exists()
    failed = json.loads((results / "tasks" / "tiny" / "raises" / "100.json").read_text())
    assert failed["output"] is None
    assert failed["failure"] == {"type": "RuntimeError", "message": "boom in fit", "attempts": 1}

    calls.clear()
    assert main(argv) == 1  # a rerun runs the failed tasks again, and nothing else
    assert [Path(t.method_path).stem for t in calls] == ["raises", "raises"]
    assert main([*argv[:3], str(BAND_MEANS), *argv[5:]]) == 0  # band_means alone: finished
    assert "2 of 2 task(s) finished before" in capsys.readouterr().err


def test_an_unwritable_results_folder_is_refused_before_any_task(tmp_path, calls, capsys):
    from sfa_gym.cli.main import main

    tracks = tmp_path / "tracks"
    _write_track(tracks, TINY)
    blocker = tmp_path / "a_file"
    blocker.write_text("not a folder")
    argv = ["leaderboard", "run", "--method", str(BAND_MEANS), "--track", "tiny"]
    argv += ["--tracks", str(tracks), "--cache", str(tmp_path / "c")]
    assert main([*argv, "--results", str(blocker / "results")]) == 2
    err = capsys.readouterr().err
    assert f"the results folder '{blocker / 'results'}' cannot be written to" in err
    if os.geteuid() != 0:  # root writes into a read-only folder anyway
        locked = tmp_path / "locked"
        locked.mkdir(mode=0o500)
        assert main([*argv, "--results", str(locked)]) == 2
        assert f"the results folder '{locked}' cannot be written to" in capsys.readouterr().err
    assert calls == []


def test_two_methods_with_one_label_are_refused(tmp_path, calls):
    track = load_track(_write_track(tmp_path / "tracks", TINY))
    other = _plugin(tmp_path / "elsewhere", "band_means")
    with pytest.raises(ValueError, match="2 methods of the sweep are labelled 'band_means'"):
        run_sweep([track], [(BAND_MEANS, {}), (other, {})], tmp_path / "results", verbose=False)
    assert calls == []


STOPS_ITSELF = """

import os, signal


def make_method(**args):
    with open({counter!r}, "a") as file:
        file.write("made\\n")
    with open({counter!r}) as file:
        if len(file.readlines()) == 2:  # the second task: stopped as a scheduler would
            os.kill(os.getpid(), signal.SIGTERM)
    return BandMeans(**args)
"""


def test_sigterm_keeps_the_finished_tasks_and_the_same_command_resumes(tmp_path, monkeypatch):
    # the plug-in stands for the scheduler: it signals the evaluator, which a plug-in in its own
    # worker process cannot do
    monkeypatch.setenv(IN_PROCESS, "1")
    tracks, results = tmp_path / "tracks", tmp_path / "results"
    _write_track(tracks, TINY)
    counter = tmp_path / "made.txt"
    method = _plugin(tmp_path / "plugins", "stops", STOPS_ITSELF.format(counter=str(counter)))
    argv = ["leaderboard", "run", "--method", str(method), "--track", "tiny"]
    argv += ["--tracks", str(tracks), "--results", str(results), "--cache", str(tmp_path / "c")]
    run = subprocess.run(
        [sys.executable, "-m", "sfa_gym.cli", *argv],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert run.returncode == 128 + 15, run.stderr
    assert "stopped by SIGTERM" in run.stderr and "1 of 2 task(s) finished and kept" in run.stderr
    assert (results / "tasks" / "tiny" / "stops" / "100.json").exists()
    assert not (results / "tasks" / "tiny" / "stops" / "101.json").exists()
    assert not (results / "tiny" / "stops.json").exists()

    from sfa_gym.cli.main import main

    assert main(argv) == 0  # the third method made: world seed 101 only
    assert counter.read_text().splitlines() == ["made"] * 3
    assert list(_result(results / "tiny" / "stops.json")["per_world_seed"]) == ["100", "101"]


CRASHES = """

import os


def make_method(**args):
    with open({counter!r}, "a") as file:
        file.write("made\\n")
    with open({counter!r}) as file:
        if len(file.readlines()) <= {crashes}:
            os._exit(1)  # the worker dies, as when the kernel kills it
    return BandMeans(**args)
"""


def test_on_ray_a_dead_worker_is_retried_once_and_failures_are_recorded(tmp_path, monkeypatch):
    pytest.importorskip("ray", reason="ray is not installed (pip install 'sfa-gym[ray]')")
    # the plug-in stands for whatever kills a Ray worker: it must run in that worker's process
    monkeypatch.setenv(IN_PROCESS, "1")
    import ray

    track = load_track(_write_track(tmp_path / "tracks", {**TINY, "world_seeds": [100]}))
    once, always = tmp_path / "once.txt", tmp_path / "always.txt"
    plugins = tmp_path / "plugins"
    methods = [
        (_plugin(plugins, "crashes_once", CRASHES.format(counter=str(once), crashes=1)), {}),
        (_plugin(plugins, "crashes", CRASHES.format(counter=str(always), crashes=9)), {}),
        (_plugin(plugins, "raises", RAISES), {}),
    ]
    results = tmp_path / "results"
    try:
        with pytest.raises(SweepError) as raised:
            run_sweep(
                [track],
                methods,
                results,
                backend="ray",
                num_cpus=2,
                cache_dir=tmp_path / "cache",
                verbose=False,
            )
    finally:
        ray.shutdown()
    (what, failure), (raised_what, raised_failure) = raised.value.failures
    assert raised_what == "tiny / raises / world seed 100"  # the plug-in's own exception,
    assert str(raised_failure) == "RuntimeError: boom in fit"  # not retried
    assert raised_failure.attempts == 1
    assert what == "tiny / crashes / world seed 100"
    assert failure.error_type == "WorkerCrashedError" and failure.attempts == 2
    assert "the Ray worker running the task died" in failure.message
    assert always.read_text().splitlines() == ["made"] * 2  # run, retried once, given up
    assert once.read_text().splitlines() == ["made"] * 2  # died once, then finished
    assert raised.value.written == [results / "tiny" / "crashes_once.json"]
    recorded = json.loads((results / "tasks" / "tiny" / "crashes" / "100.json").read_text())
    assert recorded["failure"]["type"] == "WorkerCrashedError"
