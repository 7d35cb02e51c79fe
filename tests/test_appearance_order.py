"""The appearance-order study's pieces: reading SFA's errors from the protocol's results,
the means over the worlds and the table generated from them (the runs themselves:
``python -m eval.studies.appearance_order``)."""

from __future__ import annotations

import dataclasses
import json

import pytest

from eval.studies.appearance_order import (
    QUICK,
    REGRESSIONS,
    SETTINGS,
    _config,
    _same_settings,
    condition_errors,
    summarise,
)

CONDITIONS = ["after", "later", "overcast", "other_day"]


def _results(offset: float) -> dict:
    """A protocol ``results.json`` of SFA alone, its errors shifted by ``offset``."""

    def entry(x: float) -> dict:
        return {"all": {"mae_percent": [x, x + 2.0]}, "unvisited": None}

    regressions = {
        r: {c: entry(i + j + offset) for j, c in enumerate(CONDITIONS)}
        for i, r in enumerate(REGRESSIONS)
    }
    return {"methods": {"hierarchical_sfa": {"eta_phi": [0.001, 0.004], **regressions}}}


def test_errors_are_the_mean_of_x_and_y_per_condition():
    found = condition_errors(_results(1.0), "quadratic")
    assert found == {"after": 3.0, "later": 4.0, "overcast": 5.0, "other_day": 6.0}


def test_rows_are_means_over_the_worlds_with_intervals():
    def world(offset: float) -> dict:
        out = {r: condition_errors(_results(offset), r) for r in REGRESSIONS}
        return {**out, "max_eta_phi": 0.004 + offset / 1000}

    rows = summarise({s: [world(0.0), world(2.0), world(4.0)] for s in SETTINGS}, CONDITIONS)
    linear = rows["frames"]["linear"]
    assert linear["after"]["mean"] == pytest.approx(3.0)  # 1, 3, 5
    assert linear["after"]["interval"][0] < 3.0 < linear["after"]["interval"][1]
    assert linear["per_seed"]["changed_mean"] == [3.0, 5.0, 7.0]  # later/overcast/other_day
    assert rows["one"]["changes"] == {}
    assert rows["rotations"]["changes"]["train_also_order"] == "rotations"
    assert rows["rotations"]["max_eta_phi"]["mean"] == pytest.approx(0.006)
    two = summarise({s: [world(0.0), world(2.0)] for s in SETTINGS}, CONDITIONS)
    assert two["one"]["map"]["later"]["interval"] is None  # two worlds: no interval


def test_the_table_has_a_row_per_training_and_regression():
    from eval.tables.study_formatters import appearance_order_table

    def world(offset: float) -> dict:
        out = {r: condition_errors(_results(offset), r) for r in REGRESSIONS}
        return {**out, "max_eta_phi": 0.0021}

    rows = summarise({s: [world(0.0), world(1.0), world(2.0)] for s in SETTINGS}, CONDITIONS)
    lines = appearance_order_table([{"conditions": CONDITIONS, "rows": rows}], {}).splitlines()
    assert len(lines) == 2 + 3 * 3
    assert lines[0].endswith("| mean of later, overcast, other_day | max eta_phi |")
    assert lines[2].startswith("| the training run alone | linear | 2.00 [")
    assert lines[2].endswith("| 0.0021 |")
    assert "inside each frame's rotations | map decoder | 4.00 [" in lines[-1]


def test_a_finished_setting_is_reused_only_with_the_same_settings():
    config = _config("rotations", 11)
    assert config.world_seed == 11 and config.appearances == 2
    assert dataclasses.replace(QUICK, world_seed=11).appearances == 1
    written = {"config": json.loads(json.dumps(dataclasses.asdict(config)))}
    assert _same_settings(written, config)
    assert not _same_settings(written, _config("frames", 11))
    assert not _same_settings(written, _config("rotations", 12))
