"""``sfa-gym leaderboard table``: your results beside the committed reference results, each row
labelled by its source; ``--markdown`` prints the table alone; gathered files read with clear
errors."""

from __future__ import annotations

import csv
import json
import shutil
from pathlib import Path

import pytest

from sfa_gym.cli.main import main
from sfa_gym.leaderboard.results import (
    FORMAT,
    REFERENCE,
    SCHEMA_VERSION,
    load_results,
    reference_folder,
    summarize,
)
from sfa_gym.leaderboard.tracks import load_track

ROOT = Path(__file__).resolve().parents[1]


def _quick_size(track: str) -> dict:
    return load_track(ROOT / "tracks" / f"{track}.json").sized(True)[1]


def _result(track: str, label: str, seeds: dict[int, float]) -> dict:
    """A result file of the leaderboard's format (the fields the table reads)."""
    values = list(seeds.values())
    return {
        "format": FORMAT,
        "schema_version": SCHEMA_VERSION,
        "track": {
            "name": track,
            "quick": True,
            "track_version": 1,
            # the quick size of the track file, as a result records it
            "size_params": json.loads(json.dumps(_quick_size(track))),
        },
        "method": {"label": label},
        "score": summarize(values, higher_is_better=False),
        "tasks": [{"world_seed": s, "scores": {"score": v}} for s, v in seeds.items()],
        "provenance": {"git_commit": None},
    }


def test_the_reference_results_are_found_and_read():
    results = load_results(reference_folder(), REFERENCE)
    assert {r["_source"] for r in results} == {REFERENCE}
    tracks = {r["track"]["name"] for r in results}
    assert {"few_labels", "nav_open", "outdoor_paper"} <= tracks
    few = next(
        r for r in results if r["track"]["name"] == "few_labels" and r["method"]["label"] == "pca"
    )
    seeds = [t["scores"]["score"] for t in few["tasks"]]
    assert few["score"]["mean"] == pytest.approx(sum(seeds) / len(seeds))


def test_your_results_are_shown_beside_the_reference(tmp_path, capsys):
    mine = tmp_path / "results" / "few_labels" / "my_method.quick.json"
    mine.parent.mkdir(parents=True)
    mine.write_text(json.dumps(_result("few_labels", "my_method", {100: 3.25, 101: 3.75})))
    out = tmp_path / "out"
    assert main(["leaderboard", "table", "--results", str(mine.parents[1]), "--out", str(out)]) == 0
    table = (out / "LEADERBOARD.md").read_text()
    assert (out / "leaderboard.png").stat().st_size > 1000
    lines = table.splitlines()
    header = next(line for line in lines if line.startswith("| method | source |"))
    column = header.split(" | ").index("few_labels (quick)")
    yours = next(line for line in lines if line.startswith("| my_method | yours |"))
    assert yours.split(" | ")[column] == "3.50 (n=2)"
    # the reference rows of the same track, from the committed file
    reference = [
        r
        for r in load_results(reference_folder())
        if r["track"]["name"] == "few_labels" and r["track"]["quick"]
    ]
    assert reference  # the committed quick board has few_labels
    for r in reference:
        row = next(line for line in lines if line.startswith(f"| {r['method']['label']} | "))
        assert row.split(" | ")[1] == REFERENCE
        assert row.split(" | ")[column] == f"{r['score']['mean']:.2f} (n=2)"  # two seeds

    capsys.readouterr()
    assert main(["leaderboard", "table", "--results", str(mine.parents[1]), "--no-reference"]) == 0
    alone = capsys.readouterr().out
    assert "| my_method | yours | 3.50 (n=2) |" in alone and "| reference |" not in alone


def test_markdown_prints_the_table_and_writes_nothing(tmp_path, capsys):
    empty = tmp_path / "none"
    assert main(["leaderboard", "table", "--markdown", "--results", str(empty)]) == 0
    captured = capsys.readouterr()
    assert f"no results of yours under {empty}" in captured.err
    assert "| band_means | reference |" in captured.out
    assert not empty.exists()


def test_csv_holds_the_cells_of_the_markdown_table_with_their_numbers(tmp_path, capsys):
    mine = tmp_path / "results" / "few_labels" / "my_method.quick.json"
    mine.parent.mkdir(parents=True)
    mine.write_text(json.dumps(_result("few_labels", "my_method", {100: 3.25, 101: 3.75})))
    path = tmp_path / "board" / "leaderboard.csv"
    args = ["leaderboard", "table", "--markdown", "--results", str(mine.parents[1])]
    assert main([*args, "--csv", str(path)]) == 0
    markdown = capsys.readouterr().out
    with open(path, newline="", encoding="utf-8") as file:
        rows = list(csv.DictReader(file))
    # a line per filled cell of the markdown table, in its order
    lines = [line for line in markdown.split("\n\n")[2].splitlines()[2:]]
    header = markdown.split("\n\n")[2].splitlines()[0].split(" | ")[2:]
    header[-1] = header[-1].rstrip(" |")
    cells = [
        (line.split(" | ")[0][2:], line.split(" | ")[1], column)
        for line in lines
        for column, cell in zip(header, line.rstrip(" |").split(" | ")[2:], strict=True)
        if cell != "-"
    ]
    assert [(r["method"], r["source"], r["column"]) for r in rows] == cells
    yours = next(r for r in rows if r["source"] == "yours")
    assert yours["column"] == "few_labels (quick)" and yours["track"] == "few_labels"
    assert float(yours["mean"]) == 3.5 and yours["n"] == "2" and yours["ci95_low"] == ""
    assert yours["quick"] == "True" and yours["higher_is_better"] == "False"
    # the reference numbers as stored, not as printed
    reference = {
        (r["method"]["label"], r["track"]["name"]): r["score"]
        for r in load_results(reference_folder())
        if not r["track"]["quick"]
    }
    full = [r for r in rows if r["source"] == REFERENCE and r["quick"] == "False"]
    assert full
    for r in full:
        score = reference[(r["method"], r["track"])]
        assert float(r["mean"]) == score["mean"]
        if score["ci95"]:
            assert [float(r["ci95_low"]), float(r["ci95_high"])] == score["ci95"]


def test_a_gathered_entry_without_a_field_is_named(tmp_path):
    (tmp_path / "board.json").write_text(
        json.dumps({"results": [{"track": "few_labels", "method": "pca"}]})
    )
    with pytest.raises(ValueError, match=r"board.json.*lacks \['track_version', 'quick'"):
        load_results(tmp_path)


def test_publish_gathers_a_run_into_one_file_the_table_reads_alike(tmp_path, capsys):
    results = tmp_path / "results"
    for track, label, seeds in (
        ("few_labels", "mine", {100: 3.25, 101: 3.75}),
        ("train_test", "mine", {100: 1.5, 101: 2.5}),
    ):
        path = results / track / f"{label}.quick.json"
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps(_result(track, label, seeds)))
    out = tmp_path / "published" / "quick.json"
    out.parent.mkdir()
    args = ["leaderboard", "publish", "--results", str(results), "--out", str(out)]
    assert main(args) == 0
    assert "2 results" in capsys.readouterr().out
    gathered = json.loads(out.read_text())
    assert [e["track"] for e in gathered["results"]] == ["few_labels", "train_test"]
    again = {r["track"]["name"]: r for r in load_results(out.parent, REFERENCE)}
    assert again["train_test"]["score"]["mean"] == 2.0
    assert [t["scores"]["score"] for t in again["few_labels"]["tasks"]] == [3.25, 3.75]

    # two runs of the same (track, size, method) in one folder: refused, not mixed
    twin = results / "copy" / "few_labels" / "mine.quick.json"
    twin.parent.mkdir(parents=True)
    twin.write_text(json.dumps(_result("few_labels", "mine", {100: 9.0})))
    assert main(args) != 0
    assert "few_labels" in capsys.readouterr().err


def test_publish_extends_a_published_file_keeping_its_entries_whole(tmp_path, capsys):
    results = tmp_path / "results"
    path = results / "few_labels" / "mine.quick.json"
    path.parent.mkdir(parents=True)
    path.write_text(json.dumps(_result("few_labels", "mine", {100: 3.25, 101: 3.75})))
    earlier = tmp_path / "earlier.json"
    assert main(["leaderboard", "publish", "--results", str(results), "--out", str(earlier)]) == 0
    entry = json.loads(earlier.read_text())["results"][0]
    # what a run records and a result file's shape cannot hold again: seconds, phases, isolation
    entry |= {"task_seconds": [12.5, 13.0], "task_phases": [{"fit": 12.0}, {"fit": 12.5}]}
    entry |= {"isolation": ["bwrap"], "result_sha256": "ab" * 32}
    later = tmp_path / "later"
    path = later / "train_test" / "mine.quick.json"
    path.parent.mkdir(parents=True)
    path.write_text(json.dumps(_result("train_test", "mine", {100: 1.5, 101: 2.5})))
    (later / "earlier.json").write_text(json.dumps({"description": "d", "results": [entry]}))
    out = tmp_path / "out.json"
    args = ["leaderboard", "publish", "--results", str(later), "--out", str(out)]
    assert main(args) == 0
    assert "2 results" in capsys.readouterr().out
    kept, added = json.loads(out.read_text())["results"]
    assert kept == entry
    assert added["track"] == "train_test" and added["per_world_seed"] == {"100": 1.5, "101": 2.5}

    # a result file of a published entry's track, size and method replaces the entry: a rerun
    rerun = later / "few_labels" / "mine.quick.json"
    rerun.parent.mkdir(parents=True)
    rerun.write_text(json.dumps(_result("few_labels", "mine", {100: 3.0, 101: 4.0})))
    assert main(args) == 0
    replaced, added_again = json.loads(out.read_text())["results"]
    assert replaced["per_world_seed"] == {"100": 3.0, "101": 4.0} and added_again == added
    # two result files of one key are still refused (two runs mixed in one folder)
    twice = later / "again" / "few_labels" / "mine.quick.json"
    twice.parent.mkdir(parents=True)
    twice.write_text(rerun.read_text())
    assert main(args) != 0
    assert "more than one result of (track, quick, method)" in capsys.readouterr().err
    shutil.rmtree(later / "again")
    rerun.unlink()

    # an entry whose plug-ins ran unconfined is refused as a result file's task would be
    entry["isolation"] = ["bwrap", "process"]
    (later / "earlier.json").write_text(json.dumps({"description": "d", "results": [entry]}))
    assert main(args) != 0
    assert "ran unconfined" in capsys.readouterr().err
    # and a kept entry is checked like every result: a mean that its seeds do not give is named
    entry["isolation"] = ["bwrap"]
    entry["score"] = entry["score"] | {"mean": 1.0}
    (later / "earlier.json").write_text(json.dumps({"description": "d", "results": [entry]}))
    assert main(args) != 0
    assert "earlier.json" in capsys.readouterr().err


def test_navigation_spl_is_gathered_checked_and_shown_beside_the_success_rate(tmp_path, capsys):
    results = tmp_path / "results"
    result = _result("nav_open", "mine", {100: 0.75, 101: 0.5})
    result["score"] = summarize([0.75, 0.5], higher_is_better=True)
    for task, spl in zip(result["tasks"], (0.5, 0.25), strict=True):
        task["scores"]["spl"] = spl
    path = results / "nav_open" / "mine.quick.json"
    path.parent.mkdir(parents=True)
    path.write_text(json.dumps(result))
    out = tmp_path / "published" / "quick.json"
    out.parent.mkdir()
    assert main(["leaderboard", "publish", "--results", str(results), "--out", str(out)]) == 0
    entry = json.loads(out.read_text())["results"][0]
    assert entry["spl"] == {"mean": 0.375, "per_world_seed": {"100": 0.5, "101": 0.25}}
    capsys.readouterr()
    assert main(["leaderboard", "table", "--results", str(out.parent), "--markdown"]) == 0
    table = capsys.readouterr().out
    spl_rows = table.split("Navigation: SPL")[1].splitlines()
    mine = next(line for line in spl_rows if line.startswith("| mine | yours |"))
    assert " 0.38 |" in mine  # the mean of 0.5 and 0.25, in its track's column
    # the reference boards' navigation results show theirs
    assert any(line.startswith("| sfa | reference |") for line in spl_rows)
    # an SPL outside [0, 1] is refused by name, in a result file and in a gathered entry
    result["tasks"][1]["scores"]["spl"] = 1.5
    path.write_text(json.dumps(result))
    with pytest.raises(ValueError, match=r"task 1: 'scores.spl' is 1.5; expected \[0, 1\]"):
        load_results(results)
    entry["spl"] = [0.5]
    out.write_text(json.dumps({"results": [entry]}))
    with pytest.raises(ValueError, match=r"'spl' is \[0.5\]; expected"):
        load_results(out.parent)
