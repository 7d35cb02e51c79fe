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


def _result(track: str, label: str, seeds: dict[int, float], higher: bool = False) -> dict:
    """A result at the quick size, of the track file's quick size (the fields the table reads)."""
    return {
        "track": track,
        "track_version": 1,
        "quick": True,
        "size_params": json.loads(json.dumps(_quick_size(track))),
        "method": label,
        "score": summarize(list(seeds.values()), higher_is_better=higher),
        "per_world_seed": {str(s): v for s, v in seeds.items()},
        "isolation": ["bwrap"],
    }


def _file(*results: dict, **fields: object) -> str:
    """A results file holding ``results`` (a sweep's: no description, unless ``fields``)."""
    return json.dumps(
        {"format": FORMAT, "schema_version": SCHEMA_VERSION, **fields, "results": results}
    )


def test_the_reference_results_are_found_and_read():
    results = load_results(reference_folder(), REFERENCE)
    assert {r["_source"] for r in results} == {REFERENCE}
    assert {"few_labels", "nav_open", "outdoor_paper"} <= {r["track"] for r in results}
    few = next(r for r in results if r["track"] == "few_labels" and r["method"] == "pca")
    seeds = list(few["per_world_seed"].values())
    assert few["score"]["mean"] == pytest.approx(sum(seeds) / len(seeds))


def test_your_results_are_shown_beside_the_reference(tmp_path, capsys):
    mine = tmp_path / "results" / "few_labels" / "my_method.quick.json"
    mine.parent.mkdir(parents=True)
    mine.write_text(_file(_result("few_labels", "my_method", {100: 3.25, 101: 3.75})))
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
        r for r in load_results(reference_folder()) if r["track"] == "few_labels" and r["quick"]
    ]
    assert reference  # the committed quick board has few_labels
    for r in reference:
        row = next(line for line in lines if line.startswith(f"| {r['method']} | "))
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
    mine.write_text(_file(_result("few_labels", "my_method", {100: 3.25, 101: 3.75})))
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
        (r["method"], r["track"]): r["score"]
        for r in load_results(reference_folder())
        if not r["quick"]
    }
    full = [r for r in rows if r["source"] == REFERENCE and r["quick"] == "False"]
    assert full
    for r in full:
        score = reference[(r["method"], r["track"])]
        assert float(r["mean"]) == score["mean"]
        if score["ci95"]:
            assert [float(r["ci95_low"]), float(r["ci95_high"])] == score["ci95"]


def test_a_gathered_result_without_a_field_is_named(tmp_path):
    (tmp_path / "board.json").write_text(
        _file({"track": "few_labels", "method": "pca", "quick": True}, description="")
    )
    with pytest.raises(ValueError, match=r"board.json, entry 0 lacks 'track_version'"):
        load_results(tmp_path)


def test_publish_gathers_a_run_into_one_file_the_table_reads_alike(tmp_path, capsys):
    results = tmp_path / "results"
    for track, label, seeds in (
        ("few_labels", "mine", {100: 3.25, 101: 3.75}),
        ("train_test", "mine", {100: 1.5, 101: 2.5}),
    ):
        path = results / track / f"{label}.quick.json"
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(_file(_result(track, label, seeds)))
    out = tmp_path / "published" / "quick.json"
    out.parent.mkdir()
    args = ["leaderboard", "publish", "--results", str(results), "--out", str(out)]
    assert main(args) == 0
    assert "2 results" in capsys.readouterr().out
    gathered = json.loads(out.read_text())
    assert [e["track"] for e in gathered["results"]] == ["few_labels", "train_test"]
    assert gathered["description"] and gathered["format"] == FORMAT
    again = {r["track"]: r for r in load_results(out.parent, REFERENCE)}
    assert again["train_test"]["score"]["mean"] == 2.0
    assert list(again["few_labels"]["per_world_seed"].values()) == [3.25, 3.75]

    # two runs of the same (track, size, method) in one folder: refused, not mixed
    twin = results / "copy" / "few_labels" / "mine.quick.json"
    twin.parent.mkdir(parents=True)
    twin.write_text(_file(_result("few_labels", "mine", {100: 9.0})))
    assert main(args) != 0
    assert "few_labels" in capsys.readouterr().err


def test_publish_extends_a_published_file_keeping_its_results_whole(tmp_path, capsys):
    results = tmp_path / "results"
    path = results / "few_labels" / "mine.quick.json"
    path.parent.mkdir(parents=True)
    path.write_text(_file(_result("few_labels", "mine", {100: 3.25, 101: 3.75})))
    earlier = tmp_path / "earlier.json"
    assert main(["leaderboard", "publish", "--results", str(results), "--out", str(earlier)]) == 0
    entry = json.loads(earlier.read_text())["results"][0]
    # what a run records beside the scores: seconds, phases, isolation, its file's hash
    entry |= {"task_seconds": [12.5, 13.0], "task_phases": [{"fit": 12.0}, {"fit": 12.5}]}
    entry |= {"isolation": ["bwrap"], "result_sha256": "ab" * 32}
    later = tmp_path / "later"
    path = later / "train_test" / "mine.quick.json"
    path.parent.mkdir(parents=True)
    path.write_text(_file(_result("train_test", "mine", {100: 1.5, 101: 2.5})))
    (later / "earlier.json").write_text(_file(entry, description="d"))
    out = tmp_path / "out.json"
    args = ["leaderboard", "publish", "--results", str(later), "--out", str(out)]
    assert main(args) == 0
    assert "2 results" in capsys.readouterr().out
    kept, added = json.loads(out.read_text())["results"]
    assert kept == entry
    assert added["track"] == "train_test" and added["per_world_seed"] == {"100": 1.5, "101": 2.5}

    # a sweep's result of a published result's track, size and method replaces it: a rerun
    rerun = later / "few_labels" / "mine.quick.json"
    rerun.parent.mkdir(parents=True)
    rerun.write_text(_file(_result("few_labels", "mine", {100: 3.0, 101: 4.0})))
    assert main(args) == 0
    replaced, added_again = json.loads(out.read_text())["results"]
    assert replaced["per_world_seed"] == {"100": 3.0, "101": 4.0} and added_again == added
    # two sweep results of one key are still refused (two runs mixed in one folder)
    twice = later / "again" / "few_labels" / "mine.quick.json"
    twice.parent.mkdir(parents=True)
    twice.write_text(rerun.read_text())
    assert main(args) != 0
    assert "more than one result of (track, quick, method)" in capsys.readouterr().err
    shutil.rmtree(later / "again")
    rerun.unlink()

    # a kept result whose plug-ins ran unconfined is refused as a sweep's would be
    entry["isolation"] = ["bwrap", "process"]
    (later / "earlier.json").write_text(_file(entry, description="d"))
    assert main(args) != 0
    assert "ran unconfined" in capsys.readouterr().err
    # and a kept result is checked like every result: a mean that its seeds do not give is named
    entry["isolation"] = ["bwrap"]
    entry["score"] = entry["score"] | {"mean": 1.0}
    (later / "earlier.json").write_text(_file(entry, description="d"))
    assert main(args) != 0
    assert "earlier.json" in capsys.readouterr().err


def test_navigation_spl_is_checked_and_shown_beside_the_success_rate(tmp_path, capsys):
    result = _result("nav_open", "mine", {100: 0.75, 101: 0.5}, higher=True)
    result["spl"] = {"mean": 0.375, "per_world_seed": {"100": 0.5, "101": 0.25}}
    path = tmp_path / "nav_open" / "mine.quick.json"
    path.parent.mkdir(parents=True)
    path.write_text(_file(result))
    assert main(["leaderboard", "table", "--results", str(tmp_path), "--markdown"]) == 0
    table = capsys.readouterr().out
    spl_rows = table.split("Navigation: SPL")[1].splitlines()
    mine = next(line for line in spl_rows if line.startswith("| mine | yours |"))
    assert " 0.38 |" in mine  # the mean of 0.5 and 0.25, in its track's column
    # the reference boards' navigation results show theirs
    assert any(line.startswith("| sfa | reference |") for line in spl_rows)
    # an SPL outside [0, 1] is refused by name
    result["spl"]["per_world_seed"]["101"] = 1.5
    path.write_text(_file(result))
    with pytest.raises(ValueError, match=r"per_world_seed\[101\] is 1.5; expected \[0, 1\]"):
        load_results(tmp_path)
    result["spl"] = [0.5]
    path.write_text(_file(result))
    with pytest.raises(ValueError, match=r"'spl' is \[0.5\]; expected"):
        load_results(tmp_path)
