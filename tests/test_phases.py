"""Seconds per phase: nested phases count apart, nothing is counted outside a measurement."""

from __future__ import annotations

import time

import pytest

from sfa_gym.phases import measure, phase


def test_a_nested_phase_is_not_counted_twice():
    with measure() as phases:
        with phase("features"):
            time.sleep(0.05)
            with phase("render"):
                time.sleep(0.1)
        time.sleep(0.03)
    seconds = phases.as_dict()
    assert seconds["render"] == pytest.approx(0.1, abs=0.05)
    assert seconds["features"] == pytest.approx(0.05, abs=0.04)
    assert seconds["other"] == pytest.approx(0.03, abs=0.03)
    assert seconds["features"] < seconds["render"]


def test_phases_add_up_over_repeats_and_only_inside_a_measurement():
    with phase("fit"):  # no measurement: not recorded anywhere
        time.sleep(0.01)
    with measure() as phases:
        for _ in range(3):
            with phase("fit"):
                time.sleep(0.02)
    assert set(phases.as_dict()) == {"fit", "other"}
    assert phases.as_dict()["fit"] >= 0.06


def test_an_unknown_phase_is_named():
    with pytest.raises(ValueError, match=r"phase must be one of .*got 'fitting'"):
        with phase("fitting"):
            pass
