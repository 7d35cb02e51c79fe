"""The quick-vs-full comparison: Kendall's tau of the two method orders per track, in each
track's direction, from result folders as the leaderboard writes them."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from eval.studies.quick_vs_full import Args, compare, main
from sfa_gym.leaderboard.results import make_result, result_path, write_results
from sfa_gym.leaderboard.tracks import load_track

ROOT = Path(__file__).resolve().parents[1]


def _write(folder, track_name, method, scores, quick):
    track = load_track(ROOT / "tracks" / f"{track_name}.json")
    tasks = [
        {"world_seed": seed, "fit_world_seed": seed, "scores": {"score": s}, "seconds": 1.0}
        for seed, s in zip(track.sized(quick)[0], scores, strict=False)
    ]
    result = make_result(
        track=track,
        quick=quick,
        method={"label": method},
        tasks=tasks,
        higher_is_better=track.kind == "navigation",
        backend="local",
    )
    write_results(result_path(folder, track_name, method, quick), [result])


def test_same_order_is_one_and_the_reverse_minus_one():
    quick = {"t": {"higher_is_better": False, "versions": {1}, "scores": {"a": 1, "b": 2, "c": 3}}}
    same = {"t": {"higher_is_better": False, "versions": {1}, "scores": {"a": 5, "b": 6, "c": 9}}}
    reverse = {
        "t": {"higher_is_better": False, "versions": {1}, "scores": {"a": 3, "b": 2, "c": 1}}
    }
    assert compare(quick, same)[0]["kendall_tau"] == 1.0
    assert compare(quick, reverse)[0]["kendall_tau"] == -1.0
    assert compare(quick, same)[0]["full_order"] == ["a", "b", "c"]  # lower is better


def test_the_comparison_reads_result_folders_and_orders_by_the_tracks_direction(tmp_path, capsys):
    quick, full = tmp_path / "quick", tmp_path / "full"
    for method, q, f in (("a", 0.9, 0.8), ("b", 0.5, 0.6), ("c", 0.1, 0.7)):
        _write(quick, "nav_open", method, [q, q], True)
        _write(full, "nav_open", method, [f] * 5, False)
    out = tmp_path / "qvf.json"
    main(Args(quick=quick, full=full, json=out))
    (row,) = json.loads(out.read_text())["tracks"]
    assert row["full_order"] == ["a", "c", "b"]  # success: higher is better
    assert row["quick_order"] == ["a", "b", "c"]
    assert row["kendall_tau"] == pytest.approx(1 / 3, abs=1e-4)
    assert "below 0.8" in capsys.readouterr().out
