"""Intervals that respect the score: a leaderboard summary stays in the score's range on hostile
inputs, has none below three seeds, prints as ``[a, b]`` or ``(n=2)``; results that record the
older unclipped interval still verify, and an edited summary is still refused."""

from __future__ import annotations

import copy
import json
import math

import pytest

from sfa_gym.intervals import format_interval, t_interval, wilson
from sfa_gym.leaderboard.results import (
    FORMAT,
    READ_SCHEMA_VERSIONS,
    SCHEMA_VERSION,
    ResultError,
    check_result,
    load_results,
    reference_folder,
    summarize,
)

T_975_4 = 2.7764451051977987
"""Student's t 97.5 % quantile with 4 degrees of freedom (five seeds)."""


@pytest.mark.parametrize(
    ("values", "higher"),
    [
        ([1.0, 1.0, 1.0, 1.0, 1.0], True),  # all successes
        ([0.0, 0.0, 0.0, 0.0, 0.0], True),  # all failures
        ([0.0, 1.0, 0.0, 1.0, 0.05], True),  # a huge spread of success rates
        ([0.02, 0.01, 0.03], True),
        ([0.1, 0.2, 250.0], False),  # a huge spread of MAE
        ([0.0, 0.0, 0.0], False),
    ],
)
def test_a_summary_stays_in_the_score_range(values, higher):
    score = summarize(values, higher)
    lo, hi = score["ci95"]
    assert score["interval"] == "t-clipped" and score["n"] == len(values)
    assert 0.0 <= lo <= score["mean"] <= hi
    assert hi <= (1.0 if higher else math.inf)


def test_the_clipped_interval_is_the_t_interval_inside_the_range():
    values = [0.9, 0.95, 1.0, 0.85, 0.99]  # t reaches above 1: clipped there, not below
    mean, std = 0.938, 0.06300793600809346
    half = T_975_4 * std / math.sqrt(5)
    assert summarize(values, True)["ci95"] == pytest.approx([mean - half, 1.0], rel=1e-12)
    assert mean + half > 1.0
    assert summarize(values, True, "t")["ci95"] == pytest.approx([mean - half, mean + half])


@pytest.mark.parametrize("values", [[0.4], [0.2, 0.9]])
def test_fewer_than_three_seeds_give_no_interval_but_their_number(values):
    score = summarize(values, higher_is_better=True)
    assert score["ci95"] is None and score["n"] == len(values)
    assert format_interval(score["ci95"], score["n"]) == f"(n={len(values)})"


def test_intervals_print_as_brackets():
    assert format_interval([0.0, 0.345], 5) == "[0.00, 0.34]"
    assert format_interval([1.25, 2.0], 3, digits=3) == "[1.250, 2.000]"
    assert format_interval([None, None], 0) == "(n=0)"


def test_the_building_blocks_refuse_what_they_cannot_bound():
    with pytest.raises(ValueError, match="3 successes of 2 trials"):
        wilson(3, 2)
    with pytest.raises(ValueError, match="1 value"):
        t_interval([0.5])
    with pytest.raises(ValueError, match=r"leave the range \[0.0, 1.0\]"):
        t_interval([0.5, 1.5, 0.2], 0.0, 1.0)
    with pytest.raises(ValueError, match="'bootstrap'; expected one of"):
        summarize([0.5, 0.6, 0.7], True, "bootstrap")


def _result(values: dict[int, float], higher: bool, **summary: object) -> dict:
    """A result file of ``values`` per world seed, its score summarized by ``summary``'s
    arguments to :func:`summarize` (``interval``)."""
    return {
        "format": FORMAT,
        "schema_version": SCHEMA_VERSION,
        "track": {"name": "nav_open", "quick": False, "track_version": 3},
        "method": {"label": "m"},
        "score": summarize(list(values.values()), higher, **summary),
        "tasks": [{"world_seed": s, "scores": {"score": v}} for s, v in values.items()],
        "provenance": {"git_commit": None},
    }


SPREAD = {100: 0.0, 101: 0.9, 102: 1.0}
"""Success rates of three seeds whose t interval leaves [0, 1] at both ends."""


def test_a_result_of_the_old_unclipped_interval_still_verifies_and_shows_today_s():
    old = _result(SPREAD, True, interval="t") | {"schema_version": 1}
    lo, hi = old["score"]["ci95"]
    assert lo < 0.0 and hi > 1.0  # what an older file records
    shown = check_result(copy.deepcopy(old), "old")["score"]
    assert shown["interval"] == "t-clipped" and shown["mean"] == old["score"]["mean"]
    assert shown["ci95"] == [0.0, 1.0]
    # and an old file of two seeds, whose interval the new method would not give
    two = _result({100: 0.2, 101: 0.9}, True, interval="t")
    assert two["score"]["ci95"] is not None
    assert check_result(copy.deepcopy(two), "two")["score"]["ci95"] is None


@pytest.mark.parametrize("interval", ["t", "t-clipped"])
def test_a_tampered_summary_is_still_refused(interval):
    result = _result(SPREAD, True, interval=interval)
    edited = copy.deepcopy(result)
    edited["score"]["mean"] += 0.05
    with pytest.raises(ResultError, match="score.mean is"):
        check_result(edited, "edited")
    # a result that claims the other method than its numbers follow
    relabelled = copy.deepcopy(result)
    relabelled["score"]["interval"] = "t-clipped" if interval == "t" else "t"
    with pytest.raises(ResultError, match="score.ci95 is"):
        check_result(relabelled, "relabelled")


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (lambda r: r["score"].update(interval="bootstrap"), "'score.interval' is 'bootstrap'"),
        (lambda r: r["score"].pop("interval"), "lacks 'score.interval'"),
        (lambda r: r["tasks"][0]["scores"].update(score=1.5), "leaves the score's range"),
    ],
)
def test_an_unknown_interval_or_a_score_out_of_range_is_refused(edit, message):
    result = _result(SPREAD, True)
    edit(result)
    with pytest.raises(ResultError, match=message):
        check_result(result, "bad")


def test_old_and_new_result_files_load_and_a_newer_schema_is_refused(tmp_path):
    assert READ_SCHEMA_VERSIONS == (1, 2) and SCHEMA_VERSION == 2
    for label, version, interval in (("old", 1, "t"), ("new", 2, "t-clipped")):
        result = _result(SPREAD, True, interval=interval)
        result.update(schema_version=version, method={"label": label})
        path = tmp_path / "nav_open" / f"{label}.json"
        path.parent.mkdir(exist_ok=True)
        path.write_text(json.dumps(result))
    loaded = {r["method"]["label"]: r["score"] for r in load_results(tmp_path)}
    assert loaded["old"] == loaded["new"]  # shown alike, by today's method
    (tmp_path / "nav_open" / "new.json").write_text(
        json.dumps({**_result(SPREAD, True), "schema_version": 3})
    )
    with pytest.raises(ResultError, match=r"schema_version 3; this sfa_gym reads \[1, 2\]"):
        load_results(tmp_path)


def test_the_published_results_verify_unchanged_and_show_in_range():
    for name in ("quick.json", "full.json"):  # both gathered with today's clipped interval
        published = json.loads((reference_folder() / name).read_text())["results"]
        assert {e["score"]["interval"] for e in published} == {"t-clipped"}, name
    results = load_results(reference_folder())
    assert len(results) > 10
    for r in results:
        score = r["score"]
        higher = score["higher_is_better"]
        if score["n"] < 3:
            assert score["ci95"] is None
            continue
        lo, hi = score["ci95"]
        assert 0.0 <= lo <= score["mean"] <= hi <= (1.0 if higher else math.inf)


def test_the_navigation_table_prints_wilson_intervals_in_brackets():
    from sfa_gym.cli.navigate import format_navigation_table
    from sfa_gym.navigation.evaluate import summarize as summarize_episodes

    episode = dict(
        success=True, spl=0.8, soft_spl=0.9, final_distance=0.1, path_ratio=1.25, collisions=0
    )
    # ten successes, none interior: Wilson's interval reaches 1 and keeps a width below it
    episodes = [{**episode, "steps": 40, "interior": False} for _ in range(10)]
    table = format_navigation_table({"controllers": {"gradient": summarize_episodes(episodes)}})
    row = table.splitlines()[2]
    assert row.startswith("| gradient | 1.00 [0.72, 1.00] | 0.80 [0.80, 0.80] | - | - |"), row
