"""Plots write PNGs and draw the data they are given."""

from __future__ import annotations

import numpy as np
import pytest
from matplotlib.collections import LineCollection, PathCollection, QuadMesh
from matplotlib.figure import Figure

from sfa_gym.localization.plots import error_map, estimate_vs_truth, firing_maps, trajectory


def _grid(n: int = 12) -> np.ndarray:
    xs, ys = np.meshgrid(np.linspace(-3, 3, n), np.linspace(-2, 2, n))
    return np.column_stack([xs.ravel(), ys.ravel()])


def _outputs(positions: np.ndarray, n_views: int = 8) -> np.ndarray:
    phis = 2 * np.pi * np.arange(n_views) / n_views
    x, y = positions[:, 0:1], positions[:, 1:2]
    return np.stack(
        [x + 0 * phis, y + 0 * phis, x * y + 0.3 * np.cos(phis), np.sin(3 * x) + 0 * phis],
        axis=2,
    )  # (P, K, 4); output 3 depends on orientation


def _saved(fig: Figure, path) -> int:
    fig.savefig(path, dpi=60)
    return path.stat().st_size


def test_firing_maps_on_a_grid_draw_the_selected_orientation(tmp_path):
    positions = _grid()
    outputs = _outputs(positions)
    fig, axes = firing_maps(outputs, positions, orientations=(0, 90, 180, 270), n_outputs=3)
    assert axes.shape == (3, 4)
    # The 90 degree panel of output 3 shows view 2 of 8, as an image over the 12 x 12 grid.
    (mesh,) = [c for c in axes[2, 1].collections if isinstance(c, QuadMesh)]
    image = np.asarray(mesh.get_array()).reshape(12, 12)
    np.testing.assert_allclose(image, outputs[:, 2, 2].reshape(12, 12))
    assert axes[2, 1].get_title() == "f3, 90°"
    # One colour scale per output, shared by the orientations.
    limits = {c.get_clim() for a in axes[2] for c in a.collections if isinstance(c, QuadMesh)}
    assert len(limits) == 1
    assert _saved(fig, tmp_path / "firing_maps.png") > 5_000


def test_firing_maps_scatter_off_grid_and_nearest_orientation(tmp_path):
    rng = np.random.default_rng(0)
    positions = rng.uniform(-3, 3, size=(50, 2))
    outputs = _outputs(positions, n_views=6)  # views at 0, 60, 120, ... degrees
    fig, axes = firing_maps(outputs, positions, orientations=(100,), n_outputs=4)
    assert axes.shape == (4, 1)
    (points,) = [c for c in axes[2, 0].collections if isinstance(c, PathCollection)]
    np.testing.assert_allclose(points.get_array(), outputs[:, 2, 2])  # 120 is nearest to 100
    assert axes[2, 0].get_title() == "f3, 120°"
    assert _saved(fig, tmp_path / "scatter.png") > 2_000


def test_firing_maps_refuses_bad_input():
    positions = _grid(4)
    with pytest.raises(ValueError, match="n_positions, n_orientations, n_outputs"):
        firing_maps(np.zeros((16, 4)), positions)
    with pytest.raises(ValueError, match="n_outputs must lie in"):
        firing_maps(np.zeros((16, 4, 2)), positions, n_outputs=4)
    with pytest.raises(ValueError, match="16 positions but positions has 15"):
        firing_maps(np.zeros((16, 4, 2)), positions[:15], n_outputs=2)


def test_estimate_vs_truth_draws_one_error_line_per_location(tmp_path):
    true = _grid(8)
    pred = true + np.random.default_rng(1).normal(scale=0.1, size=true.shape)
    fig, ax = estimate_vs_truth(pred, true)
    (lines,) = [c for c in ax.collections if isinstance(c, LineCollection)]
    segments = np.asarray(lines.get_segments())
    np.testing.assert_allclose(segments[:, 0], true)
    np.testing.assert_allclose(segments[:, 1], pred)
    assert _saved(fig, tmp_path / "estimates.png") > 5_000


def test_error_map_and_trajectory_into_given_axes(tmp_path):
    true = _grid(10)
    pred = true + np.column_stack([0.05 * true[:, 0], np.zeros(len(true))])
    fig = Figure(figsize=(9, 4), layout="constrained")
    left, right = fig.subplots(1, 2)
    out_fig, ax = error_map(pred, true, axis="x", fig=fig, ax=left)
    assert out_fig is fig and ax is left
    (mesh,) = [c for c in ax.collections if isinstance(c, QuadMesh)]
    np.testing.assert_allclose(np.asarray(mesh.get_array()).ravel(), 0.05 * np.abs(true[:, 0]))
    t = np.linspace(0, 2 * np.pi, 200)
    poses = np.column_stack([2 * np.cos(t), 2 * np.sin(t), t + np.pi / 2])
    _, ax2 = trajectory(poses, bounds=(-3, 3, -3, 3), fig=fig, ax=right)
    assert ax2 is right
    np.testing.assert_allclose(ax2.lines[1].get_xydata(), poses[:, :2])  # lines[0]: the bounds
    assert _saved(fig, tmp_path / "error_and_trajectory.png") > 5_000
    with pytest.raises(ValueError, match="axis must be"):
        error_map(pred, true, axis="z")
    with pytest.raises(ValueError, match=r"\(T, 3\)"):
        trajectory(np.zeros((5, 4)))
