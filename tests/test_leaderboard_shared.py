"""Grid tracks whose settings differ only in what they evaluate (the paper's splits, training
-> test, few labels) fit a method once per world seed: one task scores them all, each track's
task and result file are what running it alone gives, and a track fitted on another world
(``unseen_worlds``) is not joined."""

from __future__ import annotations

import json
from pathlib import Path

from test_leaderboard import BAND_MEANS, TINY, _write_track

from sfa_gym.leaderboard.sweep import run_sweep
from sfa_gym.leaderboard.tracks import load_track

# the settings all four tracks share (a track's Config is the same but for its evaluation)
PARAMS = {**TINY["params"], "n_splits": 5, "labels": [3, 5]}
EVALUATIONS = {
    "tiny_test": "train_test",
    "tiny_splits": "paper_splits",
    "tiny_labels": "few_labels",
    "tiny_unseen": "unseen_worlds",
}


def _tracks(folder: Path) -> list:
    tracks = []
    for name, evaluation in EVALUATIONS.items():
        data = {**TINY, "name": name, "evaluation": evaluation, "params": PARAMS}
        data["world_seeds"] = [100]
        if evaluation == "unseen_worlds":
            data["fit_world_seeds"] = [105]
        tracks.append(load_track(_write_track(folder, data)))
    return tracks


def _task(results: Path, track: str, seed: int) -> dict:
    return json.loads((results / "tasks" / track / "band_means" / f"{seed}.json").read_text())


def test_grid_tracks_that_differ_in_their_evaluation_share_one_task(tmp_path):
    tracks = _tracks(tmp_path / "tracks")
    cache, results = tmp_path / "cache", tmp_path / "results"
    written = run_sweep(tracks, [(BAND_MEANS, {})], results, cache_dir=cache, verbose=False)
    assert [p.parent.name for p in written] == list(EVALUATIONS)
    runner = _task(results, "tiny_test", 100)
    assert runner["output"]["seconds"] > 0 and "scored_with" not in runner["provenance"]
    assert set(runner["output"]["shared"]) == {"paper_splits", "few_labels"}
    for name in ("tiny_splits", "tiny_labels"):
        joined = _task(results, name, 100)
        assert joined["provenance"]["scored_with"] == "tiny_test / band_means / world seed 100"
        assert joined["output"]["seconds"] == 0.0 and "shared" not in joined["output"]
    unseen = _task(results, "tiny_unseen", 100)  # fitted on another world: its own task
    assert unseen["output"]["seconds"] > 0 and "scored_with" not in unseen["provenance"]
    labels = _task(results, "tiny_labels", 100)["output"]["scores"]
    assert set(labels) >= {"score", "labels_3", "labels_5"}
    # what a task scored for others stays in its task file, not in its track's result
    (runner_result,) = json.loads((results / "tiny_test" / "band_means.json").read_text())[
        "results"
    ]
    assert "shared" not in json.dumps(runner_result) and runner_result["parts"] is None

    # each track alone (the same cache: nothing is rendered again) scores the same
    for track in tracks[:3]:
        alone = tmp_path / f"alone_{track.name}"
        run_sweep([track], [(BAND_MEANS, {})], alone, cache_dir=cache, verbose=False)
        mine, theirs = _task(results, track.name, 100), _task(alone, track.name, 100)
        assert mine["output"]["scores"] == theirs["output"]["scores"]
        assert mine["identity"] == theirs["identity"]
        assert "shared" not in theirs["output"]
    # a rerun reuses every task
    again = run_sweep(tracks, [(BAND_MEANS, {})], results, cache_dir=cache, verbose=False)
    assert again == written


def test_a_finished_task_is_not_joined_and_the_others_still_share(tmp_path):
    tracks = _tracks(tmp_path / "tracks")[:3]
    cache, results = tmp_path / "cache", tmp_path / "results"
    # the paper's splits ran alone in an earlier sitting
    run_sweep(tracks[1:2], [(BAND_MEANS, {})], results, cache_dir=cache, verbose=False)
    before = _task(results, "tiny_splits", 100)
    run_sweep(tracks, [(BAND_MEANS, {})], results, cache_dir=cache, verbose=False)
    assert _task(results, "tiny_splits", 100) == before
    runner = _task(results, "tiny_test", 100)
    assert set(runner["output"]["shared"]) == {"few_labels"}
    joined = _task(results, "tiny_labels", 100)
    assert joined["provenance"]["scored_with"] == "tiny_test / band_means / world seed 100"
