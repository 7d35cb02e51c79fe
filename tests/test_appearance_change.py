"""The appearance-change study's measures (eval/studies/appearance_change.py)."""

from __future__ import annotations

import numpy as np

from eval.studies.appearance_change import aligned_change, partner


def test_a_turned_copy_of_a_panorama_has_no_change_once_aligned():
    rng = np.random.default_rng(0)
    image = rng.uniform(0, 255, size=(6, 40)).astype(np.float32)
    # turning the rover by +2*pi*s/W shifts the content by -s columns
    turned = np.roll(image, -10, axis=1)
    assert aligned_change(image, 0.0, turned, 2 * np.pi * 10 / 40) == 0.0
    assert aligned_change(image, 0.0, turned, 0.0) > 10.0
    assert aligned_change(image, 0.0, image + 3.0, 0.0) == 3.0


def test_the_partner_is_the_nearest_frame_in_time_far_enough_away():
    xy = np.column_stack([np.arange(10) * 0.1, np.zeros(10)])
    assert partner(xy, 0, 0.25) == 3
    assert partner(xy, 9, 0.25) == 6
    assert partner(xy, 5, 0.25) in (2, 8)
    assert partner(xy[:2], 0, 0.25) is None
