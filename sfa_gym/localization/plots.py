"""Plots of localization results: spatial firing maps, estimates vs. ground truth, error maps,
trajectories.

Every function takes ``fig=None, ax=None`` and returns ``(fig, ax)`` (or ``(fig, axes)`` for a
grid of panels). Without a figure one is created with :class:`matplotlib.figure.Figure`, which
renders through Agg without touching pyplot's global state; save it with ``fig.savefig(path)``.
Positions are metres in the world frame: x to the right, y up, equal aspect.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from matplotlib.axes import Axes
from matplotlib.collections import LineCollection
from matplotlib.figure import Figure
from numpy.typing import ArrayLike, NDArray

from sfa_gym.rotation import rotation_angles

__all__ = ["error_map", "estimate_vs_truth", "firing_maps", "trajectory"]


def _positions(positions: ArrayLike, name: str = "positions") -> NDArray[np.float64]:
    p = np.asarray(positions, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 2 or p.shape[0] == 0:
        raise ValueError(f"{name} must have shape (P, 2) (x, y metres), got {p.shape}")
    return p


def _grid(positions: NDArray[np.float64]) -> tuple[NDArray, NDArray, NDArray] | None:
    """If the positions lie on a lattice (a full or partly filled grid), return its unique x
    ``(nx,)``, unique y ``(ny,)`` and each position's flat cell index ``(P,)``; else None."""
    # Rounding absorbs float noise in grid coordinates computed as start + i * spacing.
    rounded = np.round(positions, 6)
    xs, ix = np.unique(rounded[:, 0], return_inverse=True)
    ys, iy = np.unique(rounded[:, 1], return_inverse=True)
    n_cells = len(xs) * len(ys)
    # A lattice at least half filled is drawn as an image; scattered positions are not a lattice.
    if len(xs) < 2 or len(ys) < 2 or n_cells > 2 * len(positions):
        return None
    return xs, ys, iy * len(xs) + ix


def _draw_field(
    ax: Axes,
    positions: NDArray[np.float64],
    values: NDArray[np.float64],
    cmap: str,
    vmin: float | None,
    vmax: float | None,
):
    """Colour-code ``values (P,)`` over ``positions (P, 2)``: an image on a grid, else a scatter."""
    grid = _grid(positions)
    if grid is None:
        artist = ax.scatter(
            positions[:, 0], positions[:, 1], c=values, cmap=cmap, vmin=vmin, vmax=vmax, s=20
        )
    else:
        xs, ys, cell = grid
        # Repeated positions are averaged; empty cells stay blank (NaN is drawn transparent).
        total = np.bincount(cell, weights=values, minlength=len(xs) * len(ys))
        count = np.bincount(cell, minlength=len(xs) * len(ys))
        image = np.full(len(xs) * len(ys), np.nan)
        np.divide(total, count, out=image, where=count > 0)
        artist = ax.pcolormesh(
            xs,
            ys,
            image.reshape(len(ys), len(xs)),
            shading="nearest",
            cmap=cmap,
            vmin=vmin,
            vmax=vmax,
        )
    ax.set_aspect("equal")
    return artist


def _figure_and_axes(fig: Figure | None, ax, nrows: int, ncols: int, size: tuple[float, float]):
    if ax is not None:
        axes = np.asarray(ax, dtype=object).reshape(nrows, ncols)
        return axes.flat[0].figure if fig is None else fig, axes
    if fig is None:
        fig = Figure(figsize=size, layout="constrained")
    axes = np.asarray(fig.subplots(nrows, ncols, squeeze=False), dtype=object)
    return fig, axes


def firing_maps(
    outputs: ArrayLike,
    positions: ArrayLike,
    orientations: Sequence[float] = (0, 90, 180, 270),
    n_outputs: int = 4,
    phis: ArrayLike | None = None,
    cmap: str = "viridis",
    fig: Figure | None = None,
    ax=None,
) -> tuple[Figure, NDArray[np.object_]]:
    """Spatial firing maps (the paper's Fig. 3a): output ``j`` colour-coded over position, one row
    per output and one column per relative orientation.

    Args:
        outputs: ``(P, K, n)``: the features of view ``k`` (relative orientation ``phis[k]``) at
            position ``p``; e.g. the outputs for all rotated views of every grid position.
        positions: ``(P, 2)`` metres. On a lattice the map is an image; otherwise a scatter plot.
        orientations: Orientations to show, degrees; each panel shows the view nearest to it.
        n_outputs: Number of outputs (rows) to show, the first ones (the slowest for SFA).
        phis: ``(K,)`` radians of the views; default ``2 pi k / K`` (the full set of rotated views).
        cmap: Colour map; each row shares one colour scale so orientation changes are visible.
        fig: Figure to draw in.
        ax (numpy.ndarray | None): An array of ``n_outputs x len(orientations)`` axes to draw in.

    Returns:
        ``(fig, axes)`` with ``axes`` of shape ``(n_outputs, len(orientations))``.
    """
    f = np.asarray(outputs, dtype=np.float64)
    if f.ndim != 3:
        raise ValueError(
            f"outputs must have shape (n_positions, n_orientations, n_outputs), got {f.shape}"
        )
    p = _positions(positions)
    if len(p) != f.shape[0]:
        raise ValueError(f"outputs has {f.shape[0]} positions but positions has {len(p)}")
    if not 1 <= n_outputs <= f.shape[2]:
        raise ValueError(f"n_outputs must lie in [1, {f.shape[2]}], got {n_outputs}")
    if len(orientations) == 0:
        raise ValueError("orientations must name at least one angle (degrees)")
    k_views = f.shape[1]
    # without phis, the K views are taken to be every rotation of one turn, in order
    phi = rotation_angles(k_views, step=1) if phis is None else np.asarray(phis, float)
    if phi.shape != (k_views,):
        raise ValueError(f"phis must have shape ({k_views},) like outputs' axis 1, got {phi.shape}")
    wanted = np.deg2rad(np.asarray(orientations, dtype=np.float64))
    # Nearest view on the circle for each requested orientation.
    gap = np.angle(np.exp(1j * (wanted[:, None] - phi[None, :])))
    view_index = np.abs(gap).argmin(axis=1)

    fig, axes = _figure_and_axes(
        fig, ax, n_outputs, len(orientations), (2.2 * len(orientations) + 0.8, 2.0 * n_outputs)
    )
    for j in range(n_outputs):
        lo, hi = f[:, :, j].min(), f[:, :, j].max()
        for c, k in enumerate(view_index):
            a = axes[j, c]
            artist = _draw_field(a, p, f[:, k, j], cmap, lo, hi)
            a.set_title(f"f{j + 1}, {np.rad2deg(phi[k]) % 360:.0f}°", fontsize=9)
            a.tick_params(labelsize=7)
            if c > 0:
                a.set_yticklabels([])
            if j < n_outputs - 1:
                a.set_xticklabels([])
        fig.colorbar(artist, ax=list(axes[j]), shrink=0.9)
    axes[-1, 0].set_xlabel("x (m)")
    axes[-1, 0].set_ylabel("y (m)")
    return fig, axes


def estimate_vs_truth(
    pred: ArrayLike,
    true: ArrayLike,
    fig: Figure | None = None,
    ax: Axes | None = None,
) -> tuple[Figure, Axes]:
    """Ground-truth positions and their estimates joined by error lines (the paper's Fig. 3b).

    ``pred`` and ``true`` are ``(P, 2)`` metres.
    """
    e = _positions(pred, "pred")
    t = _positions(true, "true")
    if e.shape != t.shape:
        raise ValueError(f"pred and true must have the same shape, got {e.shape} and {t.shape}")
    fig, axes = _figure_and_axes(fig, ax, 1, 1, (5.0, 5.0))
    a = axes[0, 0]
    a.add_collection(
        LineCollection(np.stack([t, e], axis=1), colors="tab:red", linewidths=0.7, alpha=0.7)
    )
    a.scatter(t[:, 0], t[:, 1], s=10, c="black", marker="x", linewidths=0.8, label="ground truth")
    a.scatter(e[:, 0], e[:, 1], s=8, c="tab:blue", label="estimate")
    a.set_aspect("equal")
    a.autoscale_view()
    a.set_xlabel("x (m)")
    a.set_ylabel("y (m)")
    a.legend(loc="upper left", bbox_to_anchor=(1.0, 1.0), fontsize=8)
    return fig, a


def error_map(
    pred: ArrayLike,
    true: ArrayLike,
    axis: str = "both",
    cmap: str = "magma",
    fig: Figure | None = None,
    ax: Axes | None = None,
) -> tuple[Figure, Axes]:
    """Absolute localization error colour-coded over the true position.

    ``pred``, ``true``: ``(P, 2)`` metres. ``axis``: ``"both"`` (Euclidean error), ``"x"`` or
    ``"y"`` (absolute error on that axis), metres.
    """
    e = _positions(pred, "pred")
    t = _positions(true, "true")
    if e.shape != t.shape:
        raise ValueError(f"pred and true must have the same shape, got {e.shape} and {t.shape}")
    if axis == "both":
        error = np.linalg.norm(e - t, axis=1)
    elif axis in ("x", "y"):
        error = np.abs(e - t)[:, "xy".index(axis)]
    else:
        raise ValueError(f"axis must be 'both', 'x' or 'y', got {axis!r}")
    fig, axes = _figure_and_axes(fig, ax, 1, 1, (5.5, 4.5))
    a = axes[0, 0]
    artist = _draw_field(a, t, error, cmap, 0.0, None)
    fig.colorbar(artist, ax=a, label=f"absolute error{'' if axis == 'both' else ' ' + axis} (m)")
    a.set_xlabel("x (m)")
    a.set_ylabel("y (m)")
    return fig, a


def trajectory(
    poses: ArrayLike,
    bounds: tuple[float, float, float, float] | None = None,
    n_headings: int = 20,
    fig: Figure | None = None,
    ax: Axes | None = None,
) -> tuple[Figure, Axes]:
    """A run's path: ``poses`` ``(T, 3)`` (x, y metres, yaw radians) or ``(T, 2)``.

    Draws the path, its start (circle) and end (square), ``n_headings`` heading arrows spread over
    the run (when yaw is given), and the rectangle ``bounds = (xmin, xmax, ymin, ymax)`` if given.
    """
    q = np.asarray(poses, dtype=np.float64)
    if q.ndim != 2 or q.shape[1] not in (2, 3) or len(q) == 0:
        raise ValueError(f"poses must have shape (T, 3) (x, y, yaw) or (T, 2), got {q.shape}")
    fig, axes = _figure_and_axes(fig, ax, 1, 1, (5.0, 5.0))
    a = axes[0, 0]
    if bounds is not None:
        xmin, xmax, ymin, ymax = bounds
        a.plot([xmin, xmax, xmax, xmin, xmin], [ymin, ymin, ymax, ymax, ymin], color="0.5", lw=1)
    a.plot(q[:, 0], q[:, 1], color="tab:blue", lw=1.0)
    a.plot(*q[0, :2], "o", color="tab:green", label="start")
    a.plot(*q[-1, :2], "s", color="tab:red", label="end")
    if q.shape[1] == 3 and n_headings > 0:
        idx = np.unique(np.linspace(0, len(q) - 1, n_headings).round().astype(int))
        # Arrows 6 % of the drawn extent long, whatever the arena size.
        extent = (
            np.ptp(q[:, :2], axis=0).max()
            if bounds is None
            else max(bounds[1] - bounds[0], bounds[3] - bounds[2])
        )
        length = 0.06 * (extent if extent > 0 else 1.0)
        a.quiver(
            q[idx, 0],
            q[idx, 1],
            length * np.cos(q[idx, 2]),
            length * np.sin(q[idx, 2]),
            angles="xy",
            scale_units="xy",
            scale=1.0,
            color="tab:blue",
            width=0.005,
            alpha=0.8,
        )
    a.set_aspect("equal")
    a.set_xlabel("x (m)")
    a.set_ylabel("y (m)")
    a.legend(loc="upper right", fontsize=8)
    return fig, a
