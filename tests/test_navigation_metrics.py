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


@pytest.mark.parametrize("key", ["success", "spl"])
def test_confidence_interval_brackets_the_mean_and_shrinks_with_more_episodes(key):
    rng = np.random.default_rng(1)
    few, many = rng.random(20) < 0.7, rng.random(2000) < 0.7
    lo, hi = confidence_interval(few, key)
    assert lo < few.mean() < hi
    lo2, hi2 = confidence_interval(many, key)
    assert hi2 - lo2 < (hi - lo) / 3
    assert confidence_interval(few, key) == (lo, hi)  # deterministic


def test_success_interval_is_wilsons():
    # Wilson's score interval of 7 successes in 10 trials, 95 %: (0.3968, 0.8922)
    lo, hi = confidence_interval([1] * 7 + [0] * 3, "success")
    assert (lo, hi) == pytest.approx((0.39678, 0.89221), abs=1e-5)
    # and the closed form: (p + z^2/2n +- z sqrt(p(1-p)/n + z^2/4n^2)) / (1 + z^2/n)
    z, n, p = 1.959963984540054, 10, 0.7
    centre, half = p + z**2 / (2 * n), z * math.sqrt(p * (1 - p) / n + z**2 / (4 * n**2))
    assert lo == pytest.approx((centre - half) / (1 + z**2 / n), rel=1e-9)
    assert hi == pytest.approx((centre + half) / (1 + z**2 / n), rel=1e-9)


@pytest.mark.parametrize("successes", [[1] * 12, [0] * 12, [1], [0]])
def test_success_interval_stays_in_0_1_and_keeps_a_width_at_the_ends(successes):
    lo, hi = confidence_interval(successes, "success")
    assert 0.0 <= lo < hi <= 1.0
    assert lo == 0.0 or hi == 1.0  # all one way: the interval reaches that end
    assert (lo == 0.0) == (successes[0] == 0)


def test_other_quantities_stay_within_their_values():
    values = [0.0, 0.0, 0.9, 0.95, 1.0]
    lo, hi = confidence_interval(values, "spl")
    assert 0.0 <= lo < np.mean(values) < hi <= 1.0
    assert confidence_interval([3.0], "steps") == (3.0, 3.0)


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
