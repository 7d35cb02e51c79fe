"""Known answers for the navigation metrics and the wheel odometry."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from sfa_gym.navigation.metrics import confidence_interval, soft_spl, spl, summarize_episodes
from sfa_gym.navigation.odometry import WheelOdometry


def test_spl_matches_hand_computed_values():
    # success with a path twice the shortest; success with a shorter-than-geodesic path (counts
    # as the geodesic); failure
    got = spl([1, True, 0], shortest=[2.0, 3.0, 1.0], path=[4.0, 2.5, 1.0])
    np.testing.assert_allclose(got, [0.5, 1.0, 0.0])


def test_soft_spl_matches_hand_computed_values():
    # 1 - 0.5 / 2 = 0.75 progress, path 4 for shortest 2: 0.75 * 0.5; overshoot of the start
    # distance: no progress credited
    got = soft_spl(final_distance=[0.5, 3.0, 0.0], shortest=[2.0, 2.0, 1.5], path=[4.0, 1.0, 1.5])
    np.testing.assert_allclose(got, [0.375, 0.0, 1.0])


@pytest.mark.parametrize("shortest, path", [([0.0], [1.0]), ([1.0], [-0.5]), ([math.nan], [1.0])])
def test_bad_lengths_are_refused(shortest, path):
    with pytest.raises(ValueError, match="length"):
        spl([1], shortest, path)


def test_confidence_interval_brackets_the_mean_and_shrinks_with_more_episodes():
    rng = np.random.default_rng(1)
    few, many = rng.random(20) < 0.7, rng.random(2000) < 0.7
    lo, hi = confidence_interval(few)
    assert lo < few.mean() < hi
    lo2, hi2 = confidence_interval(many)
    assert hi2 - lo2 < (hi - lo) / 3
    assert confidence_interval(few) == (lo, hi)  # deterministic


def test_summary_averages_every_key():
    episode = dict(
        success=True,
        spl=0.8,
        soft_spl=0.9,
        final_distance=0.1,
        path_ratio=1.25,
        collisions=1,
        steps=40,
    )
    summary = summarize_episodes([episode, {**episode, "success": False, "spl": 0.0}])
    assert summary["episodes"] == 2
    assert summary["success"]["mean"] == 0.5
    assert summary["spl"]["mean"] == pytest.approx(0.4)
    assert summary["steps"]["mean"] == 40
    # no episodes (no interior pair among a few): no mean, and null rather than NaN in JSON
    empty = summarize_episodes([])
    assert empty["episodes"] == 0
    assert empty["success"] == {"mean": None, "ci95": [None, None]}
    assert json.loads(json.dumps(empty, allow_nan=False))["spl"]["mean"] is None


def test_odometry_integrates_straight_runs_and_turns():
    odo = WheelOdometry(wheel_radius=0.1, effective_track=0.5)
    odo.reset([0, 0, 0, 0])
    x, y, yaw = odo.update([2, 2, 2, 2])  # all wheels turn 2 rad: 0.2 m straight on
    assert (x, y, yaw) == pytest.approx((0.2, 0.0, 0.0))
    # turn in place by a quarter: right wheels forward, left back, arc 0.5 / 2 * pi / 2 each
    quarter = 0.25 * math.pi / 2 / 0.1
    x, y, yaw = odo.update([2 - quarter, 2 - quarter, 2 + quarter, 2 + quarter])
    assert (x, y, yaw) == pytest.approx((0.2, 0.0, math.pi / 2))
    x, y, yaw = odo.update([3 - quarter, 3 - quarter, 3 + quarter, 3 + quarter])
    assert (x, y) == pytest.approx((0.2, 0.1))  # now driving along +y


def test_odometry_follows_a_circle_in_small_steps():
    odo = WheelOdometry(wheel_radius=0.1, effective_track=0.4)
    odo.reset(np.zeros(4))
    # radius 1 m: left arc (1 - 0.2), right arc (1 + 0.2) per radian of heading
    for k in range(1, 101):
        turned = k * (math.pi / 100)  # half a circle
        left, right = 0.8 * turned / 0.1, 1.2 * turned / 0.1
        x, y, yaw = odo.update([left, left, right, right])
    assert (x, y) == pytest.approx((0.0, 2.0), abs=1e-3)
    assert abs(abs(yaw) - math.pi) < 1e-9


def test_odometry_refuses_bad_angles():
    odo = WheelOdometry(0.1, 0.4)
    with pytest.raises(ValueError, match="4 finite angles"):
        odo.reset([0, 0, 0])
    with pytest.raises(ValueError, match="positive"):
        WheelOdometry(0.0, 0.4)
