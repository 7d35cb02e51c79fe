"""Navigation figures: the local minima marked on a goal's cost landscape."""

from __future__ import annotations

import numpy as np

from sfa_gym.navigation.plots import _local_minima, cost_landscape


def test_local_minima_are_strict_count_nan_as_high_and_include_the_border():
    nan = np.nan
    grid = np.array(
        [
            [0.0, 1.0, 1.0, 5.0, 5.0],
            [1.0, 2.0, 1.0, 5.0, 5.0],
            [3.0, 3.0, 3.0, 5.0, 5.0],
            [3.0, nan, 3.0, 2.0, 4.0],
            [3.0, 3.0, 3.0, 4.0, 4.0],
        ]
    )
    rows, cols = _local_minima(grid)
    # the corner 0 (border cells have no neighbour off the grid) and the 2 beside a NaN; the
    # plateaus of 5s, 3s and 4s are no minima, nor is the NaN
    assert list(zip(rows.tolist(), cols.tolist(), strict=True)) == [(0, 0), (3, 3)]
    assert _local_minima(np.full((3, 3), 7.0))[0].size == 0
    assert _local_minima(np.array([[1.0]]))[0].tolist() == [0]


def test_cost_landscape_marks_the_minima_of_a_bowl():
    xs, ys = np.meshgrid(np.linspace(-1, 1, 9), np.linspace(-1, 1, 7))
    positions = np.stack([xs.ravel(), ys.ravel()], axis=1)
    cost = np.sum((positions - [0.25, 0.0]) ** 2, axis=1)
    fig, ax = cost_landscape(positions, cost, goal=[0.25, 0.0])
    marked = next(line for line in ax.get_lines() if line.get_label() == "local minima")
    assert marked.get_xdata().tolist() == [0.25] and marked.get_ydata().tolist() == [0.0]
