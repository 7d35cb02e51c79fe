"""sfa_gym.shrink: every rotated view shrunk by area averaging from a few shrunk copies of the
panorama gives the same bytes as shrinking each view."""

from __future__ import annotations

import numpy as np
import pytest

from sfa_gym.rotation import rotated_views
from sfa_gym.shrink import area_shrink, shrunk_rotations


@pytest.mark.parametrize(
    ("size", "step", "window", "shrunk"),
    [
        ((40, 350), 1, None, (8, 70)),  # every column: five phases
        ((60, 600), 5, None, (12, 120)),  # one phase
        ((40, 350), 10, None, (7, 70)),  # rows not a whole factor
        ((40, 350), 1, 175, (8, 35)),  # a narrower view
        ((16, 160), 5, 80, (16, 80)),  # columns kept as they are
        ((60, 600), 5, None, (4, 35)),  # 600 / 35 is no whole factor: each view shrunk
    ],
)
def test_shrunk_rotations_equal_each_view_shrunk(size, step, window, shrunk):
    panoramas = np.random.default_rng(0).integers(0, 256, (3, *size, 3), dtype=np.uint8)
    fast = shrunk_rotations(panoramas, step, window, *shrunk)
    views = rotated_views(panoramas, step=step, window=window)[0]
    slow = area_shrink(views.reshape(-1, *views.shape[2:]), *shrunk)
    assert fast.shape == (3, size[1] // step, *shrunk, 3)
    assert np.array_equal(fast, slow.reshape(fast.shape))
    # some rotations only, repeated and out of order: the same bytes as picking them
    picked = np.array([fast.shape[1] - 1, 2, 2, 0])
    found = shrunk_rotations(panoramas, step, window, *shrunk, picked)
    assert np.array_equal(found, fast[:, picked])


def test_shrunk_rotations_refuse_a_larger_size():
    panoramas = np.zeros((1, 10, 40, 3), dtype=np.uint8)
    with pytest.raises(ValueError, match=r"cannot shrink 10 x 20 views to 11 x 5"):
        shrunk_rotations(panoramas, 5, 20, 11, 5)
    with pytest.raises(ValueError, match="step"):
        shrunk_rotations(panoramas, 3, None, 5, 5)
