"""``sfa-gym leaderboard table`` trusts nothing it reads: a result whose stored mean does not
follow from its seeds' scores, that lies in another track's folder, is truncated, lacks a field
or has a wrong type is skipped and named, the rest still shown; a result of another track
version gets a column of its own."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from sfa_gym.cli.main import main
from sfa_gym.leaderboard.results import (
    FORMAT,
    REFERENCE,
    SCHEMA_VERSION,
    ResultError,
    load_results,
    reference_folder,
    summarize,
)
from sfa_gym.leaderboard.table import load_board
from sfa_gym.leaderboard.tracks import load_track

ROOT = Path(__file__).resolve().parents[1]
GOOD = {100: 3.25, 101: 3.75}
"""The quick world seeds of few_labels (tracks/few_labels.json, version 1) and their scores."""
QUICK_SIZE = json.loads(json.dumps(load_track(ROOT / "tracks" / "few_labels.json").sized(True)[1]))
"""The parameters of few_labels at its quick size, as a result records them."""


def _result(label: str, seeds: dict[int, float] = GOOD, **fields: object) -> dict:
    """A correct result of few_labels at the quick size; ``fields`` override its fields."""
    return {
        "track": "few_labels",
        "track_version": 1,
        "quick": True,
        "size_params": QUICK_SIZE,
        "method": label,
        "score": summarize(list(seeds.values()), higher_is_better=False),
        "per_world_seed": {str(s): v for s, v in seeds.items()},
        "isolation": ["bwrap"],
        **fields,
    }


def _write(results: Path, result: dict, name: str | None = None, folder: str = "few_labels"):
    path = results / folder / (name or f"{result['method']}.quick.json")
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(
        json.dumps({"format": FORMAT, "schema_version": SCHEMA_VERSION, "results": [result]})
    )
    return path


def _edit(data: dict, **fields: object) -> str:
    """The text of results file ``data`` with its result's ``fields`` replaced."""
    return json.dumps({**data, "results": [{**data["results"][0], **fields}]})


def _table(results: Path, capsys) -> tuple[int, str, str]:
    """The table command on ``results`` alone: exit status, stdout, stderr."""
    status = main(
        ["leaderboard", "table", "--markdown", "--no-reference", "--results", str(results)]
    )
    out, err = capsys.readouterr()
    return status, out, err


def _columns(out: str) -> list[str]:
    """The column names of the table in ``out``."""
    header = next(line for line in out.splitlines() if line.startswith("| method | source |"))
    return header.strip("| ").split(" | ")


def _row(out: str, label: str) -> str:
    return next(line for line in out.splitlines() if line.startswith(f"| {label} | yours |"))


def test_a_correct_result_is_shown_unchanged(tmp_path, capsys):
    _write(tmp_path, _result("good"))
    status, out, err = _table(tmp_path, capsys)
    assert status == 0 and "skipped" not in err and "apart" not in err
    assert _row(out, "good") == "| good | yours | 3.50 (n=2) |"


def test_a_result_that_records_no_commit_is_shown(tmp_path, capsys):
    _write(tmp_path, {**_result("bare"), "git_commit": None})
    status, out, err = _table(tmp_path, capsys)
    assert status == 0 and "skipped" not in err
    assert _row(out, "bare") == "| bare | yours | 3.50 (n=2) |"


def test_an_edited_mean_is_refused_with_both_numbers(tmp_path, capsys):
    _write(tmp_path, _result("good"))
    edited = _result("edited", {100: 14.0, 101: 14.02})
    edited["score"]["mean"] = 0.01
    path = _write(tmp_path, edited)
    status, out, err = _table(tmp_path, capsys)
    assert status == 0 and "| edited |" not in out and _row(out, "good")
    line = next(line for line in err.splitlines() if str(path) in line)
    assert line.startswith("warning: skipped") and "score.mean is 0.01" in line
    assert "give 14.01" in line
    # a round-off difference in the last digits is not an edit
    nudged = _result("nudged")
    nudged["score"]["mean"] += 1e-12
    _write(tmp_path, nudged)
    assert "| nudged | yours | 3.50 (n=2) |" in _table(tmp_path, capsys)[1]


@pytest.mark.parametrize(
    ("folder", "name", "track", "expected"),
    [
        ("few_labels", "moved.quick.json", {"track": "train_test"}, "track 'train_test'"),
        ("few_labels", "moved.json", {}, "at the quick size"),
        ("few_labels", "other_label.quick.json", {}, "method 'moved'"),
    ],
)
def test_a_file_whose_place_disagrees_with_its_content_is_refused(
    tmp_path, capsys, folder, name, track, expected
):
    _write(tmp_path, _result("good"))
    path = _write(tmp_path, _result("moved", **track), name, folder)
    status, out, err = _table(tmp_path, capsys)
    assert status == 0 and "| moved |" not in out and _row(out, "good")
    line = next(line for line in err.splitlines() if str(path) in line)
    assert expected in line and "must agree with its content" in line


@pytest.mark.parametrize(
    ("damage", "expected"),
    [
        (lambda text, data: text[: len(text) // 2], "cannot be read as JSON"),
        (lambda text, r: _edit(r, score=None), "'score' is None; expected object"),
        (lambda text, r: _edit(r, per_world_seed={}), "'per_world_seed' is empty"),
        (lambda text, r: _edit(r, track_version="1"), "'track_version' is '1'; expected int"),
        (
            lambda text, r: text.replace('"100": 3.25', '"100": "3.25"'),
            "[100] is '3.25'; expected a number",
        ),
        (lambda text, r: text.replace('"quick": true', '"quick": 1'), "'quick' is 1"),
        (lambda text, r: json.dumps([r]), "is not a results file"),
        (
            lambda text, r: text.replace('"100": 3.25', '"100": NaN'),
            "[100] is nan; expected a number",
        ),
        (
            lambda text, r: _edit(r, parts_per_world_seed={"101": [1]}),
            "[101] is [1]; expected {part: number}",
        ),
        (lambda text, r: _edit(r, versions="numpy 2"), "'versions' is 'numpy 2'"),
    ],
    ids=[
        "truncated",
        "no score",
        "no seeds",
        "version text",
        "score text",
        "quick int",
        "list",
        "score nan",
        "parts list",
        "versions text",
    ],
)
def test_a_damaged_file_is_named_and_the_rest_is_shown(tmp_path, capsys, damage, expected):
    _write(tmp_path, _result("good"))
    path = _write(tmp_path, _result("bad"))
    path.write_text(damage(path.read_text(), json.loads(path.read_text())))
    status, out, err = _table(tmp_path, capsys)
    assert status == 0 and "| bad |" not in out and _row(out, "good")
    line = next(line for line in err.splitlines() if str(path) in line)
    assert line.startswith("warning: skipped") and expected in line
    # without a list to note it in, reading stops at it, naming it
    with pytest.raises(ResultError, match=expected.replace("(", r"\(").replace("[", r"\[")):
        load_results(tmp_path)


def test_nothing_left_to_show_still_names_the_skipped_files(tmp_path, capsys):
    path = _write(tmp_path, _result("bad"))
    path.write_text("{")
    status, _, err = _table(tmp_path, capsys)
    assert status == 2 and f"warning: skipped {path}" in err and "error: no leaderboard" in err


def test_a_quick_result_of_another_quick_size_gets_a_column_of_its_own(tmp_path, capsys):
    # the quick section of a track file can change without a new track version
    _write(tmp_path, _result("good"))
    _write(tmp_path, _result("smaller", size_params={**QUICK_SIZE, "grid": 8}))
    unknown = _result("unknown")
    del unknown["size_params"]  # written before results recorded their size
    _write(tmp_path, unknown)
    status, out, err = _table(tmp_path, capsys)
    assert status == 0
    assert _columns(out)[2:] == [
        "few_labels (quick)",
        "few_labels other size (quick)",
        "few_labels size not recorded (quick)",
    ]
    assert _row(out, "good") == "| good | yours | 3.50 (n=2) | - | - |"
    assert _row(out, "smaller") == "| smaller | yours | - | 3.50 (n=2) | - |"
    assert _row(out, "unknown") == "| unknown | yours | - | - | 3.50 (n=2) |"
    assert "'grid': 8" in err and "does not record its quick size" in err


def test_another_track_version_or_seed_set_gets_a_column_of_its_own(tmp_path, capsys):
    _write(tmp_path, _result("good"))
    old = _write(tmp_path, _result("old", {100: 9.0, 101: 9.5}, track_version=7))
    partial = _write(tmp_path, _result("partial", {100: 1.0}))
    status, out, err = _table(tmp_path, capsys)
    assert status == 0
    assert _columns(out) == [
        "method",
        "source",
        "few_labels (quick)",
        "few_labels seeds [100] (quick)",
        "few_labels v7 (quick)",
    ]
    assert _row(out, "good") == "| good | yours | 3.50 (n=2) | - | - |"
    assert _row(out, "old") == "| old | yours | - | - | 9.25 (n=2) |"
    assert _row(out, "partial") == "| partial | yours | - | 1.00 (n=1) | - |"
    assert "- few_labels v7 (quick): track version 7; the track file is version 1" in out
    assert f"warning: {old}: track version 7; the track file is version 1" in err
    assert f"warning: {partial}: world seeds [100]; the track file's are [100, 101]" in err
    # a track of its own folder of track files: its results are taken as they are
    board = load_board(tmp_path, tracks=tmp_path / "no tracks here")
    assert board.tracks == ["few_labels (quick)"] and not board.apart


def test_a_bad_gathered_entry_is_skipped_alone(tmp_path):
    entries = json.loads((reference_folder() / "quick.json").read_text())["results"][:3]
    entries[1]["score"]["mean"] += 1.0
    entries[2]["per_world_seed"] = {"first": 1.0}
    header = {"format": FORMAT, "schema_version": SCHEMA_VERSION, "description": ""}
    (tmp_path / "quick.json").write_text(json.dumps(header | {"results": entries}))
    skipped: list[str] = []
    (kept,) = load_results(tmp_path, REFERENCE, skipped)
    assert kept["method"] == entries[0]["method"]
    assert [line.split(":")[0] for line in skipped] == [
        f"{tmp_path / 'quick.json'}, entry 1",
        f"{tmp_path / 'quick.json'}, entry 2",
    ]
    assert "score.mean is" in skipped[0] and "expected seeds" in skipped[1]


def test_the_committed_reference_loads_without_a_warning(capsys):
    skipped: list[str] = []
    results = load_results(reference_folder(), REFERENCE, skipped)
    assert results and skipped == []
    board = load_board(reference_folder(), skipped=skipped)
    assert skipped == [] and not board.apart
    assert main(["leaderboard", "table", "--markdown", "--results", str(reference_folder())]) == 0
    err = capsys.readouterr().err
    assert "skipped" not in err and "apart" not in err


def test_publish_refuses_a_folder_with_an_edited_result(tmp_path, capsys):
    _write(tmp_path / "results", _result("good"))
    edited = _result("edited")
    edited["score"]["ci95"] = [3.0, 4.0]
    path = _write(tmp_path / "results", edited)
    out = tmp_path / "quick.json"
    args = ["leaderboard", "publish", "--results", str(tmp_path / "results"), "--out", str(out)]
    assert main(args) == 2 and not out.exists()
    err = capsys.readouterr().err
    assert str(path) in err and "score.ci95 is [3.0, 4.0]" in err


@pytest.mark.parametrize("isolation", ["process", "in-process"])
def test_publish_refuses_results_whose_plug_ins_ran_unconfined(tmp_path, capsys, isolation):
    _write(tmp_path / "results", _result("confined"))
    path = _write(tmp_path / "results", _result("loose", isolation=["bwrap", isolation]))
    out = tmp_path / "quick.json"
    args = ["leaderboard", "publish", "--results", str(tmp_path / "results"), "--out", str(out)]
    assert main(args) == 2 and not out.exists()
    err = capsys.readouterr().err
    assert str(path) in err and "ran unconfined" in err
    path.unlink()  # the confined result alone is published, saying how it ran
    assert main(args) == 0
    (entry,) = json.loads(out.read_text())["results"]
    assert entry["isolation"] == ["bwrap"]


def test_a_task_records_how_its_plug_ins_ran(monkeypatch):
    from sfa_gym.leaderboard.evaluate import IN_PROCESS, isolation
    from sfa_gym.sandbox.process import confinement

    assert isolation() == ("bwrap" if confinement() is not None else "process")
    monkeypatch.setenv(IN_PROCESS, "1")
    assert isolation() == "in-process"


def test_a_result_edited_consistently_after_it_was_written_is_refused(tmp_path, capsys):
    from sfa_gym.leaderboard.results import content_sha256

    stored = _result("honest")
    _write(tmp_path, stored | {"content_sha256": content_sha256(stored)})
    # a forger who rewrites a seed's score and the summary to match: the summary checks pass,
    # the content hash does not
    forged = {**stored, "method": "forged", "content_sha256": content_sha256(stored)}
    forged["per_world_seed"] = {"100": 0.5, "101": 0.5}
    forged["score"] = summarize([0.5, 0.5], higher_is_better=False)
    path = _write(tmp_path, forged)
    status, out, err = _table(tmp_path, capsys)
    assert status == 0
    assert _row(out, "honest") == "| honest | yours | 3.50 (n=2) |"
    assert "| forged |" not in out
    assert f"{path}: its content was changed after it was written" in err
