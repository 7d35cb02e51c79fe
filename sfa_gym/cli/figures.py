"""Figures of the localization protocols: firing maps, estimates, error maps, trajectories.

Written with matplotlib's object-oriented interface (no global state); every function writes PNG
files into a folder and returns nothing.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from sfa_gym.geometry import in_rectangle
from sfa_gym.rotation import Rotation, quarter_indices

__all__ = ["FIGURE_REGRESSOR", "grid_figures", "quarter_outputs", "trajectory_figures"]

DPI = 110

FIGURE_REGRESSOR = "map"
"""The regression whose SFA estimates the estimate and error-map figures show."""


def quarter_outputs(
    model: Any, panoramas: NDArray[np.uint8], rotation: Rotation
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The model's outputs at the views nearest 0, 90, 180 and 270 degrees, as firing maps show
    them: outputs ``(L, Q, k)`` of ``panoramas (L, H, W, 3)`` and the views' angles ``(Q,)``
    (radians), ``Q <= 4``."""
    width = panoramas.shape[2]
    ks = quarter_indices(rotation.n_views(width))
    # one view index at a time: each call sees a contiguous (L, H, W', 3) stack
    outputs = np.stack(
        [model.transform(rotation.views(panoramas, [k])[0][:, 0]) for k in ks], axis=1
    )
    return outputs, rotation.angles(width, ks)


def grid_figures(out: Path, scores: Any) -> None:
    """``firing_maps.png`` over every grid position, ``estimates.png`` and ``error_map.png`` of
    the SFA estimates at the test positions, from the grid protocol's ``Scores`` of SFA."""
    from matplotlib.figure import Figure

    from sfa_gym.localization import plots

    data = scores.data
    estimates = scores.regressions[FIGURE_REGRESSOR].estimates
    test_xy = data.positions[data.test]
    outputs, phis = quarter_outputs(scores.method.model_, data.panoramas, scores.config.rotation)
    fig: Figure
    fig, _ = plots.firing_maps(outputs, data.positions[:, :2], phis=phis, n_outputs=4)
    fig.savefig(out / "firing_maps.png", dpi=DPI, bbox_inches="tight")
    fig, _ = plots.estimate_vs_truth(estimates, test_xy)
    fig.savefig(out / "estimates.png", dpi=DPI, bbox_inches="tight")
    fig, _ = plots.error_map(estimates, test_xy)
    fig.savefig(out / "error_map.png", dpi=DPI, bbox_inches="tight")


def _exclude_patch(rect: Sequence[float]) -> Any:
    from matplotlib.patches import Rectangle

    x0, x1, y0, y1 = rect
    return Rectangle(
        (x0, y0),
        x1 - x0,
        y1 - y0,
        facecolor="tab:red",
        alpha=0.15,
        edgecolor="tab:red",
        hatch="//",
        label="not visited in training",
    )


def trajectory_figures(
    out: Path,
    *,
    exclude: Sequence[float] | None,
    model: Any,
    rotation: Rotation,
    train_run: Any,
    test_run: Any,
    train_pan: NDArray[np.uint8],
    train_xy: NDArray[np.float64],
    test_xy: NDArray[np.float64],
    test_time: NDArray[np.float64],
    estimates: NDArray[np.float64],
) -> None:
    """``trajectories.png`` (both runs), ``estimates.png`` (over the plane and over time),
    ``error_map.png`` of the test run and ``firing_maps.png`` over the training locations.

    ``train_xy (L, 2)`` are the training locations of ``train_pan (L, H, W, 3)``; ``test_xy``,
    ``test_time`` and ``estimates`` are ``(M, 2)``, ``(M,)`` (s) and ``(M, 2)``; ``exclude`` is
    the rectangle the training run never entered, drawn hatched.
    """
    from matplotlib.figure import Figure

    from sfa_gym.localization import plots

    bounds = train_run.metadata.get("arena_bounds")
    bounds = tuple(bounds) if bounds else None

    fig = Figure(figsize=(10.0, 5.0), layout="constrained")
    axes = fig.subplots(1, 2)
    for ax, run, title in ((axes[0], train_run, "training run"), (axes[1], test_run, "test run")):
        plots.trajectory(run.poses, bounds=bounds, fig=fig, ax=ax)
        if exclude is not None:
            ax.add_patch(_exclude_patch(exclude))
            ax.legend(loc="upper right", fontsize=8)
        ax.set_title(f"{title}: {len(run)} frames")
    fig.savefig(out / "trajectories.png", dpi=DPI)

    fig = Figure(figsize=(11.0, 5.0), layout="constrained")
    grid = fig.add_gridspec(2, 2, width_ratios=(1.0, 1.3))
    ax = fig.add_subplot(grid[:, 0])
    if exclude is not None:
        ax.add_patch(_exclude_patch(exclude))
    ax.plot(test_xy[:, 0], test_xy[:, 1], color="black", lw=1.0, label="ground truth")
    ax.plot(estimates[:, 0], estimates[:, 1], ".", color="tab:blue", ms=2.5, label="estimate")
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(f"test run, SFA + {FIGURE_REGRESSOR} regression")
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.12), ncol=3, fontsize=8)
    inside = in_rectangle(test_xy, exclude)
    for row, axis in enumerate("xy"):
        a = fig.add_subplot(grid[row, 1])
        a.plot(test_time, test_xy[:, row], color="black", lw=1.0, label="ground truth")
        a.plot(test_time, estimates[:, row], color="tab:blue", lw=0.8, label="estimate")
        if inside.any():
            a.fill_between(
                test_time,
                0,
                1,
                where=inside,
                color="tab:red",
                alpha=0.15,
                transform=a.get_xaxis_transform(),
                label="in the region not visited in training",
            )
        a.set_ylabel(f"{axis} (m)")
        if row == 1:
            a.set_xlabel("time (s)")
        else:
            a.legend(loc="upper right", fontsize=7)
    # the legend sits below the plane plot: "tight" keeps it and the title in the image
    fig.savefig(out / "estimates.png", dpi=DPI, bbox_inches="tight")

    fig, ax = plots.error_map(estimates, test_xy)
    if exclude is not None:
        patch = _exclude_patch(exclude)
        patch.set_facecolor("none")
        ax.add_patch(patch)
    ax.set_title(f"test run: absolute error, SFA + {FIGURE_REGRESSOR} regression")
    fig.savefig(out / "error_map.png", dpi=DPI)

    outputs, phis = quarter_outputs(model, train_pan, rotation)
    fig, axes = plots.firing_maps(outputs, train_xy, phis=phis, n_outputs=min(4, outputs.shape[2]))
    if bounds is not None:
        for a in axes.flat:
            a.set_xlim(bounds[0], bounds[1])
            a.set_ylim(bounds[2], bounds[3])
    fig.savefig(out / "firing_maps.png", dpi=DPI)
