"""Intervals that respect the score: a leaderboard summary stays in the score's range on hostile
inputs, has none below three seeds, prints as ``[a, b]`` or ``(n=2)``; an edited summary, or
results of an older schema, are refused."""

from __future__ import annotations

import json
import math

import pytest

from sfa_gym.intervals import format_interval, summarize, t_interval, wilson
from sfa_gym.leaderboard.results import (
    FORMAT,
    ResultError,
    check_result,
    load_results,
    reference_folder,
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
    assert t_interval(values) == pytest.approx((mean - half, mean + half))


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


def _result(values: dict[int, float], higher: bool) -> dict:
    """A result of ``values`` per world seed, its score summarized by :func:`summarize`."""
    return {
        "track": "nav_open",
        "track_version": 3,
        "quick": False,
        "method": "m",
        "score": summarize(list(values.values()), higher),
        "per_world_seed": {str(s): v for s, v in values.items()},
        "isolation": ["bwrap"],
    }


SPREAD = {100: 0.0, 101: 0.9, 102: 1.0}
"""Success rates of three seeds whose t interval leaves [0, 1] at both ends."""


def test_a_tampered_summary_is_refused():
    edited = _result(SPREAD, True)
    edited["score"]["mean"] += 0.05
    with pytest.raises(ResultError, match="score.mean is"):
        check_result(edited, "edited")
    # a result that records the unclipped interval of its seeds (schema 1's)
    unclipped = _result(SPREAD, True)
    unclipped["score"]["ci95"] = list(t_interval(list(SPREAD.values())))
    with pytest.raises(ResultError, match="score.ci95 is"):
        check_result(unclipped, "unclipped")


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (
            lambda r: r["score"].update(interval="t"),
            "'score.interval' is 't'; expected 't-clipped'",
        ),
        (lambda r: r["score"].pop("interval"), "lacks 'score.interval'"),
        (lambda r: r["per_world_seed"].update({"100": 1.5}), "leaves the score's range"),
    ],
)
def test_another_interval_or_a_score_out_of_range_is_refused(edit, message):
    result = _result(SPREAD, True)
    edit(result)
    with pytest.raises(ResultError, match=message):
        check_result(result, "bad")


@pytest.mark.parametrize(
    ("data", "version"),
    [
        ({"format": "sfa-gym-leaderboard-result", "schema_version": 2}, "2"),
        ({"format": "sfa-gym-leaderboard-result", "schema_version": 1}, "1"),
        ({"description": "", "results": []}, r"2 \(a gathered file without a format\)"),
        ({"format": FORMAT, "schema_version": 4, "results": []}, "4"),
    ],
)
def test_results_of_another_schema_are_refused_naming_the_converter(tmp_path, data, version):
    (tmp_path / "old.json").write_text(json.dumps(data))
    expected = rf"old.json: leaderboard results of schema_version {version}; this sfa_gym reads "
    with pytest.raises(ResultError, match=expected + r"schema_version 3: convert it with scripts/"):
        load_results(tmp_path)
    (tmp_path / "old.json").write_text(json.dumps({**data, "format": "sfa-gym-leaderboard-task"}))
    assert load_results(tmp_path) == []  # a task file: no results


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
