"""Area-shrunk rotated views, without materialising every view.

Methods that shrink each view by area averaging (OpenCV ``INTER_AREA``) before anything else
(the PCA and raw-pixel baselines) can give every rotated view of a panorama from a few shrunk
copies of it: when each output column averages ``f`` whole input columns (the view's width is
``f`` times the output's), a view rotated by ``s = q * f + p`` columns (``p < f``) shrinks to
the panorama rotated by ``p``, shrunk to ``W / f`` columns, rotated by ``q`` output columns and
cut to the view's width. An output pixel depends only on its own block of input pixels, so
both give the same bytes (tested against shrinking each view): ``f`` shrinks per panorama
instead of one per view, and no view is built. Other sizes fall back to shrinking each view.
"""

from __future__ import annotations

import cv2
import numpy as np
from numpy.typing import ArrayLike, NDArray

from sfa_gym.rotation import check_indices, check_step, check_window, rotated_views

__all__ = ["area_shrink", "shrunk_rotations"]


def area_shrink(views: NDArray[np.uint8], rows: int, cols: int) -> NDArray[np.uint8]:
    """``(N, H, W, 3)`` uint8 -> ``(N, rows, cols, 3)`` uint8, each view by ``INTER_AREA``."""
    out = np.empty((len(views), rows, cols, 3), dtype=np.uint8)
    for i, view in enumerate(views):
        out[i] = cv2.resize(view, (cols, rows), interpolation=cv2.INTER_AREA)
    return out


def shrunk_rotations(
    panoramas: NDArray[np.uint8],
    step: int,
    window: int | None,
    rows: int,
    cols: int,
    indices: ArrayLike | None = None,
) -> NDArray[np.uint8]:
    """The ``step``-column rotated views ``indices`` (all by default) of each panorama,
    ``window`` columns wide (None: the full width), shrunk to ``rows x cols`` by area averaging
    (module docstring).

    Args:
        panoramas: ``(L, H, W, 3)`` uint8.
        step: columns between rotations (divides ``W``).
        window: the views' width (None: ``W``).
        rows, cols: the shrunk size (at most the view's).
        indices: which rotations ``k`` (1-d ints in ``[0, W // step)``; None: every one).

    Returns:
        ``(L, K', rows, cols, 3)`` uint8, view ``i`` rotated by ``indices[i] * step`` columns
        (as :func:`sfa_gym.rotation.rotated_views`); the same bytes as picking ``indices``
        from all views, without shrinking the others.
    """
    n, height, width, _ = panoramas.shape
    step = check_step(width, step)
    window = check_window(width, window)
    picked = check_indices(width, step, indices)
    if not (1 <= rows <= height and 1 <= cols <= window):
        raise ValueError(f"cannot shrink {height} x {window} views to {rows} x {cols}")
    k = len(picked)
    factor = window // cols
    if window % cols or width % factor:
        views = rotated_views(panoramas, step=step, window=window, indices=picked)[0]
        return area_shrink(views.reshape(-1, height, window, 3), rows, cols).reshape(
            n, k, rows, cols, 3
        )
    offsets = picked * step
    out = np.empty((n, k, rows, cols, 3), dtype=np.uint8)
    for phase in np.unique(offsets % factor):
        views = np.flatnonzero(offsets % factor == phase)
        # output columns of each of these views in the shrunk panorama rotated by ``phase``
        columns = ((offsets[views] - phase) // factor)[:, None] + np.arange(cols)
        columns %= width // factor
        rotated = np.roll(panoramas, -int(phase), axis=2)
        shrunk = area_shrink(rotated, rows, width // factor)  # (L, rows, W / f, 3)
        out[:, views] = shrunk[:, :, columns].transpose(0, 2, 1, 3, 4)
    return out
