"""Every table of README.md and docs/ says what its committed result file says."""

from __future__ import annotations

import re
import shutil

import pytest

from eval.tables.tables import (
    check_pages,
    default_pages,
    regenerate,
    render,
    repository_root,
    table_specs,
)
from sfa_gym.cli.main import main

ROOT = repository_root()
README = ROOT / "README.md"


def test_readme_and_docs_tables_match_their_result_files():
    pages = default_pages(ROOT)
    # the README carries one headline table per task, each generated
    assert len(table_specs(README.read_text())) >= 4
    mismatches = check_pages(pages, ROOT)
    assert mismatches == [], "\n".join(str(m) for m in mismatches)


def test_every_generated_table_names_a_committed_result_file():
    for page in default_pages(ROOT):
        for spec in table_specs(page.read_text()):
            files = [w for w in spec.split()[1:] if "=" not in w]
            assert files, f"{page}: table {spec!r} names no result file"
            for name in files:
                assert name.startswith("published/"), f"{page}: {name} is not under published/"
                assert (ROOT / name).is_file(), f"{page}: {name} does not exist"


def _edit_first_digit_of_a_table(text: str) -> tuple[str, str, str]:
    """``text`` with one digit of the first generated table's first number row changed."""
    start = text.index("<!-- generated: ")
    body = text.index("-->", start) + 4
    end = text.index("<!-- end generated -->", body)
    rows = text[body:end].splitlines(keepends=True)
    offset = body
    for row in rows:
        match = re.search(r"\d+\.\d+", row)
        if match:
            old = match.group()
            new = old[:-1] + str((int(old[-1]) + 1) % 10)
            at = offset + match.start()
            return text[:at] + new + text[at + len(old) :], old, new
        offset += len(row)
    raise AssertionError("the first generated table has no decimal number")


def test_check_names_the_page_the_table_and_the_edited_number(tmp_path):
    page = tmp_path / "README.md"
    edited, old, new = _edit_first_digit_of_a_table(README.read_text())
    page.write_text(edited)
    mismatches = check_pages([page], ROOT)
    assert len(mismatches) == 1
    message = str(mismatches[0])
    assert str(page) in message
    assert table_specs(edited)[0] in message
    assert f"{new} where the result file gives {old}" in message


def test_command_fails_on_an_edited_page_and_regenerating_repairs_it(tmp_path, capsys):
    shutil.copy(README, tmp_path / "README.md")
    page = tmp_path / "README.md"
    assert main(["docs-tables", "--check", "--pages", str(page)]) == 0
    page.write_text(_edit_first_digit_of_a_table(page.read_text())[0])
    assert main(["docs-tables", "--check", "--pages", str(page)]) == 1
    assert str(page) in capsys.readouterr().err
    assert main(["docs-tables", "--pages", str(page)]) == 0
    assert page.read_text() == README.read_text()


def test_regenerate_fills_an_empty_table_from_its_file(tmp_path):
    spec = "board published/leaderboard/quick.json tracks=train_test methods=band_means"
    page = tmp_path / "page.md"
    page.write_text(f"<!-- generated: {spec} -->\n<!-- end generated -->\n")
    assert len(check_pages([page], ROOT)) == 1
    page.write_text(regenerate(page.read_text(), ROOT))
    assert "| `train_test` (1) | MAE % |" in page.read_text()
    assert check_pages([page], ROOT) == []


def test_board_intervals_and_seconds_come_from_the_file():
    from eval.tables.cost_formatters import board_memory_table, board_seconds_table
    from eval.tables.formatters import board_table

    record = {
        "track": "t",
        "track_version": 1,
        "method": "m",
        # the file's stored interval is of an older method: the table recomputes today's
        "score": {"mean": 2.0, "ci95": [-0.5, 4.5], "higher_is_better": False},
        "per_world_seed": {"100": 0.5, "101": 0.5, "102": 5.0},
        "task_seconds": [10.0, 20.0],
    }
    two = {**record, "method": "two", "per_world_seed": {"100": 1.5, "101": 2.5}}
    files = [{"results": [record, {**record, "method": "n", "task_seconds": [None, 3.0]}, two]}]
    # t: 2.0 +- 4.303 * 2.598 / sqrt(3) = 2.0 +- 6.45, clipped at MAE 0
    assert "| `t` (1) | MAE % | **2.00** [0.00, 8.45] | **2.00** (n=2) |" in board_table(
        files, {"intervals": "1", "methods": "m,two"}
    )
    from eval.tables.formatters import quick_vs_full_table

    rows = [{"track": "t", "kendall_tau": 0.8, "quick_order": ["a", "b"], "full_order": ["b", "a"]}]
    assert (
        quick_vs_full_table([{"tracks": rows}], {}).splitlines()[2]
        == "| `t` | 0.80 | a > b | b > a |"
    )
    seconds = board_seconds_table(files, {"methods": "m,n"}).splitlines()
    assert seconds[2] == "| `t` | 15 | - |"  # the mean of a world seed; unrecorded: none
    assert seconds[3] == "| all these tasks, minutes | 0 | 0 |"
    record["task_phases"] = [{"render": 4.0, "fit": 120.0}, {"fit": 240.0}]
    fits = board_seconds_table([{"results": [record]}], {"phase": "fit"}).splitlines()
    assert fits[0] == "| track: fit s per world seed | m |"
    assert fits[2:] == ["| `t` | 180 |", "| all these tasks, minutes | 6 |"]
    # tasks scored within another track's task: no cost of their own, left out of the mean
    shared = {**record, "method": "s", "task_seconds": [0.0, 0.0], "task_phases": [{}, {}]}
    mixed = {**record, "method": "x", "task_seconds": [90.0, 0.0]}
    mixed["task_phases"] = [{"fit": 80.0}, {}]
    both = [{"results": [shared, mixed]}]
    assert board_seconds_table(both, {}).splitlines()[2:] == [
        "| `t` | shared | 90 |",
        "| all these tasks, minutes | 0 | 2 |",
    ]
    assert board_seconds_table(both, {"phase": "fit"}).splitlines()[2] == "| `t` | shared | 80 |"
    # a task of a file that recorded no phases for it: no fit seconds, not an error
    unrecorded = {**record, "method": "u", "task_phases": [{"fit": 80.0}, None]}
    fits = board_seconds_table([{"results": [unrecorded]}], {"phase": "fit"}).splitlines()
    assert fits[2] == "| `t` | - |"
    record["task_peak_rss_mb"] = [
        {"evaluator": 512.0, "plugins": 1024.0},
        {"evaluator": 2048.0, "plugins": 768.0},
    ]
    unrecorded = {**record, "method": "n", "task_peak_rss_mb": [None, None]}
    memory = board_memory_table([{"results": [record, unrecorded]}], {}).splitlines()
    assert memory[0] == "| track: peak GiB, plug-in (evaluator) | m | n |"
    assert memory[2] == "| `t` | 1.00 (2.00) | - |"  # the largest over the world seeds


def test_navigation_controllers_show_success_and_spl_from_the_file():
    from eval.tables.formatters import nav_controllers_table

    def record(method, track, seeds, spl):
        score = {"mean": sum(seeds) / len(seeds), "ci95": None, "higher_is_better": True}
        per_seed = {str(100 + i): v for i, v in enumerate(seeds)}
        return {"track": track, "track_version": 3, "method": method, "score": score,
                "per_world_seed": per_seed, "spl": {"mean": spl, "per_world_seed": {}}}  # fmt: skip

    files = [
        {"results": [record("sfa", "nav_open", [0.9, 0.8], 0.7), {"track": "x", "method": "y"}]},
        {"results": [record("band_means+alv", "nav_maze", [0.5, 0.5, 0.5], 0.25)]},
    ]
    lines = nav_controllers_table(files, {"methods": "band_means+alv,sfa"}).splitlines()
    assert lines[0] == (
        "| method | `nav_open` success | `nav_open` SPL | `nav_maze` success | `nav_maze` SPL |"
    )
    assert lines[2] == "| band_means+alv | - | - | 0.50 [0.50, 0.50] | 0.25 |"
    assert lines[3] == "| sfa | 0.85 (n=2) | 0.70 | - | - |"
    with pytest.raises(ValueError, match="no navigation result with an SPL"):
        nav_controllers_table([{"results": [{"track": "x", "method": "y"}]}], {})


def test_board_seeds_pair_each_world_with_the_reference_methods():
    from eval.tables.formatters import board_seeds_table

    def record(method, track, seeds):
        return {"track": track, "method": method, "per_world_seed": seeds}

    files = [
        {"results": [record("sfa", "t", {"100": 0.9, "101": 0.7}), record("sfa", "u", {})]},
        {"results": [record("deep", "t", {"100": 0.8, "101": 0.75})]},
    ]
    lines = board_seeds_table(files, {"track": "t", "minus": "sfa"}).splitlines()
    assert lines[0] == "| method | world 100 | world 101 |"
    assert lines[2:] == [
        "| sfa | 0.90 | 0.70 |",
        "| deep | 0.80 | 0.75 |",
        "| deep - sfa | -0.10 | +0.05 |",  # the difference on the same world, signed
    ]
    assert len(board_seeds_table(files, {"track": "t", "methods": "deep"}).splitlines()) == 3
    with pytest.raises(ValueError, match=r"\['pca'\] on track 't'"):
        board_seeds_table(files, {"track": "t", "minus": "pca"})
    with pytest.raises(ValueError, match="needs track=NAME"):
        board_seeds_table(files, {})
    files[1]["results"][0]["per_world_seed"] = {"100": 0.8}  # a world short: nothing to pair
    with pytest.raises(ValueError, match=r"'deep' on track 't' has world seeds \['100'\]"):
        board_seeds_table(files, {"track": "t", "minus": "sfa"})


@pytest.mark.parametrize(
    ("spec", "message"),
    [
        ("nonsense published/leaderboard/quick.json", "unknown table generator 'nonsense'"),
        ("board published/missing.json", "result file 'published/missing.json' not found"),
        ("board", "names no result file"),
        ("board published/leaderboard/quick.json tracks=no_such", "'no_such' has no result"),
    ],
)
def test_bad_markers_are_refused_with_what_is_wrong(spec, message):
    with pytest.raises(ValueError, match=re.escape(message)):
        render(spec, ROOT)


def test_run_reading_rows_name_the_reader_and_whether_it_had_uncommitted_changes():
    from eval.tables.cost_formatters import run_reading_table

    row = {"copy_mb": 288.4, "peak_growth_mb": 322.0, "ratio": 0.944, "read_s": 0.18}
    row |= {"anon_growth_mb": 289.0, "file_growth_mb": 0.0}
    clean = {"commit": "aa72c751053303cb2c1d64adca0340b7ed2fa60b", "rows": {"panoramas[:]": row}}
    dirty = {**clean, "commit": clean["commit"] + "+dirty"}
    lines = run_reading_table([clean, dirty], {}).splitlines()
    assert lines[2] == "| `panoramas[:]` (aa72c75) | 288 | 322 | 0.94 | 289 | 0 | 0.18 |"
    assert lines[3].startswith("| `panoramas[:]` (aa72c75+dirty) |")
