"""``sfa-gym leaderboard compare``: a run of the board against a reference, world seed by world
seed and part by part, with what else differs where a score does."""

from __future__ import annotations

import json

import pytest
from test_leaderboard_table import _file, _result

from sfa_gym.cli.main import main
from sfa_gym.leaderboard.compare import compare_results, read_results


def _write(folder, track, label, seeds, parts=None, **fields):
    """A sweep's result of ``label`` on ``track`` at the quick size under ``folder``;
    ``parts``: per world seed, the score's parts."""
    result = _result(track, label, seeds) | fields
    if parts is not None:
        result["parts_per_world_seed"] = {str(s): p for s, p in parts.items()}
        names = parts[next(iter(parts))]
        result["parts"] = {n: sum(p[n] for p in parts.values()) / len(parts) for n in names}
    path = folder / track / f"{label}.quick.json"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(_file(result))
    return path


def _publish(results, out):
    assert main(["leaderboard", "publish", "--results", str(results), "--out", str(out)]) == 0


def test_a_rerun_that_scores_the_same_is_equal_and_a_changed_score_is_found(tmp_path, capsys):
    reference, run = tmp_path / "reference", tmp_path / "run"
    numerics = {"blas": "openblas Haswell"}
    for folder in (reference, run):
        _write(folder, "few_labels", "mine", {100: 3.25, 101: 3.75}, cpu_numerics=numerics)
        _write(folder, "train_test", "mine", {100: 1.5, 101: 2.5})
    published = tmp_path / "published.json"
    _publish(reference, published)

    args = ["leaderboard", "compare", "--results", str(run), "--reference", str(published)]
    assert main(args) == 0
    out = capsys.readouterr().out
    assert "| `few_labels` | quick | mine | equal | 2 of 2 | 0 | - |" in out
    assert out.rstrip().endswith("2 equal")

    # one seed's score changed in its last stored digit, on a CPU of other numerics
    _write(run, "few_labels", "mine", {100: 3.25, 101: 3.7500001}, cpu_numerics={"blas": "Zen"})
    assert main(args) == 1  # a score that differs fails the command
    out = capsys.readouterr().out
    assert "| `few_labels` | quick | mine | differs | 2 of 2 | 1e-07 | cpu numerics |" in out
    assert out.rstrip().endswith("1 differs, 1 equal")


def test_parts_and_missing_results_are_compared_too(tmp_path, capsys):
    reference, run = tmp_path / "reference", tmp_path / "run"
    parts = {100: {"after": 3.0, "later": 4.0}, 101: {"after": 3.5, "later": 5.0}}
    _write(reference, "outdoor_paper", "mine", {100: 3.5, 101: 4.25}, parts)
    _write(reference, "few_labels", "mine", {100: 3.25, 101: 3.75})
    moved = {100: {"after": 3.0, "later": 4.5}, 101: {"after": 3.5, "later": 4.5}}
    _write(run, "outdoor_paper", "mine", {100: 3.5, 101: 4.25}, moved)  # the same parts' means
    _write(run, "train_test", "theirs", {100: 1.5})

    rows = {r.track: r for r in compare_results(read_results(reference), read_results(run))}
    assert rows["outdoor_paper"].status == "differs"
    assert rows["outdoor_paper"].largest_difference == pytest.approx(0.5)  # seed by seed
    # a result that records only the parts' means (published before schema 3): those are
    # compared, and they are equal
    _publish(run, tmp_path / "run.json")
    gathered = json.loads((tmp_path / "run.json").read_text())
    for entry in gathered["results"]:
        entry.pop("parts_per_world_seed", None)
    (tmp_path / "run.json").write_text(json.dumps(gathered))
    means = compare_results(read_results(reference), read_results(tmp_path / "run.json"))
    assert next(r for r in means if r.track == "outdoor_paper").status == "equal"
    assert rows["few_labels"].status == "reference only"
    assert rows["train_test"].status == "run only"

    args = ["leaderboard", "compare", "--results", str(run), "--reference", str(reference)]
    assert main(args) == 1
    out = capsys.readouterr().out
    assert "few_labels" not in out  # what the run did not score is left out...
    assert main([*args, "--all"]) == 1
    assert "| `few_labels` | quick | mine | reference only | 0 of 2 | - | - |" in (
        capsys.readouterr().out
    )  # ...unless asked for


def test_a_result_file_replaces_a_gathered_entry_and_two_entries_are_refused(tmp_path):
    reference, run = tmp_path / "reference", tmp_path / "run"
    _write(reference, "few_labels", "mine", {100: 3.25, 101: 3.75})
    published = tmp_path / "published.json"
    _publish(reference, published)
    # the run's folder holds the published file copied in and the result run since
    run.mkdir()
    (run / "earlier.json").write_text(published.read_text())
    _write(run, "few_labels", "mine", {100: 3.25, 101: 3.5})
    (row,) = compare_results(read_results(published), read_results(run))
    assert row.status == "differs" and row.largest_difference == pytest.approx(0.25)

    (run / "twice.json").write_text(published.read_text())
    with pytest.raises(ValueError, match=r"the run holds more than one result of .*few_labels"):
        compare_results(read_results(published), read_results(run))
    with pytest.raises(FileNotFoundError, match="nowhere"):
        read_results(tmp_path / "nowhere")
