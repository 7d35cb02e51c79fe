"""Figures of navigation: paths over the arena map, and a goal's cost landscape."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from numpy.typing import ArrayLike, NDArray  # noqa: E402
from scipy import ndimage  # noqa: E402

__all__ = ["cost_landscape", "paths"]


def _figure(fig: Any, ax: Any, size: tuple[float, float]) -> tuple[Any, Any]:
    if ax is None:
        fig, ax = plt.subplots(figsize=size) if fig is None else (fig, fig.add_subplot())
    return ax.figure, ax


def _occupancy_image(ax: Any, occupancy: Any) -> None:
    """Grey where the rover's centre cannot go."""
    xmin, xmax, ymin, ymax = occupancy.bounds
    ax.imshow(
        ~occupancy.free,
        origin="lower",
        extent=(xmin, xmax, ymin, ymax),
        cmap="Greys",
        vmin=0,
        vmax=2.5,
        interpolation="nearest",
    )
    ax.set_xlim(xmin, xmax)
    ax.set_ylim(ymin, ymax)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")


def paths(
    episodes: Sequence[Mapping[str, Any]],
    occupancy: Any,
    title: str = "",
    fig: Any = None,
    ax: Any = None,
) -> tuple[Any, Any]:
    """Driven paths over the occupancy map: green for successes, red for failures; a circle marks
    each start and a cross each goal."""
    fig, ax = _figure(fig, ax, (5.5, 5.5))
    _occupancy_image(ax, occupancy)
    for e in episodes:
        colour = "tab:green" if e["success"] else "tab:red"
        path = np.asarray(e["path"])
        ax.plot(path[:, 0], path[:, 1], color=colour, lw=0.8, alpha=0.7)
        ax.plot(*e["start"][:2], "o", color=colour, ms=3)
        ax.plot(*e["goal"][:2], "x", color="k", ms=4)
    n = len(episodes)
    ok = sum(bool(e["success"]) for e in episodes)
    ax.set_title(f"{title} {ok}/{n} reached".strip())
    return fig, ax


def cost_landscape(
    positions: ArrayLike,
    cost: ArrayLike,
    goal: Sequence[float],
    occupancy: Any = None,
    title: str = "",
    fig: Any = None,
    ax: Any = None,
) -> tuple[Any, Any]:
    """The cost ``(n,)`` of reaching ``goal`` at grid ``positions (n, 2)``, coloured by its square
    root (the cost grows like the squared distance, so its root reads like a distance; a log
    scale would make the far arena look flat),
    with its local minima marked: gradient following ends in any of them."""
    fig, ax = _figure(fig, ax, (6.0, 5.0))
    p = np.asarray(positions, dtype=np.float64)
    c = np.asarray(cost, dtype=np.float64)
    xs, ys = np.unique(p[:, 0]), np.unique(p[:, 1])
    grid = np.full((len(ys), len(xs)), np.nan)
    grid[np.searchsorted(ys, p[:, 1]), np.searchsorted(xs, p[:, 0])] = c
    image = ax.imshow(
        np.sqrt(np.maximum(grid, 0.0)),
        origin="lower",
        extent=(xs[0], xs[-1], ys[0], ys[-1]),
        cmap="viridis",
    )
    fig.colorbar(image, ax=ax, label="sqrt(cost)")
    minima = _local_minima(grid)
    ax.plot(xs[minima[1]], ys[minima[0]], "w^", ms=5, label="local minima")
    ax.plot(goal[0], goal[1], "r*", ms=12, label="goal")
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.legend(loc="upper right", fontsize=7)
    ax.set_title(title)
    return fig, ax


def _local_minima(grid: NDArray[np.float64]) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """Row and column indices of cells lower than all 8 neighbours (NaN counts as high).

    Strictly lower: the filter's footprint leaves the centre out, so a plateau of equal cells
    marks none of them; cells off the grid count as high (``cval=inf``), so a border cell is a
    minimum when it is lower than the neighbours it has.
    """
    ring = np.ones((3, 3), dtype=bool)
    ring[1, 1] = False
    cells = np.nan_to_num(grid, nan=np.inf)
    lowest_neighbour = ndimage.minimum_filter(cells, footprint=ring, mode="constant", cval=np.inf)
    return np.nonzero(np.isfinite(cells) & (cells < lowest_neighbour))
