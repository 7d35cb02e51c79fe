"""Simulated rotation: rotated views of a panorama by circular column shifts.

The one place that computes rotated columns and their orientations; numpy only.

A panorama is periodic in its width, and column ``c`` looks at azimuth
``heading + 2*pi*c/W`` (counter-clockwise). Turning the rover by ``+2*pi*s/W`` therefore
shifts the content by ``-s`` columns, so every rotation that is a whole number of columns
can be simulated without moving the rover. View ``k`` of a panorama is::

    np.roll(panorama, -k * step, axis=1)[:, :window]

with relative orientation ``phi_k = 2*pi*k*step/W``, for ``k = 0 .. W // step - 1``. The set of
views is periodic only if ``step`` divides ``W``, which is therefore required.

:class:`Rotation` holds ``step`` and ``window`` once, so that the views a model is trained on
and the views it is evaluated on cannot silently disagree; the functions take them explicitly.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.lib.stride_tricks import as_strided
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "Rotation",
    "check_indices",
    "check_step",
    "check_window",
    "count_places",
    "n_rotations",
    "rotation_angles",
    "rotation_columns",
    "rotation_sequence",
    "rotated_views",
    "spread_indices",
    "quarter_indices",
]


def _is_int(value: object) -> bool:
    return not isinstance(value, bool) and isinstance(value, int | np.integer)


def check_step(width: int, step: int) -> int:
    """``step`` as an int after checking that it lies in ``[1, width]`` and divides ``width``.

    Raises:
        TypeError: ``step`` is not an int.
        ValueError: ``step`` is out of range or does not divide ``width``.
    """
    if not _is_int(step):
        raise TypeError(f"step must be an int (columns), got {step!r}")
    if not 1 <= step <= width:
        raise ValueError(f"step must lie in [1, {width}] (the panorama width), got {step}")
    if width % step != 0:
        raise ValueError(
            f"the panorama width {width} is not a multiple of step {step}: the rotated views "
            f"would not be periodic; choose a step that divides {width}"
        )
    return int(step)


def check_window(width: int, window: int | None) -> int:
    """The window width in columns (``width`` for ``None``) after checking ``[1, width]``."""
    if window is None:
        return int(width)
    if not _is_int(window):
        raise TypeError(f"window must be an int (columns) or None, got {window!r}")
    if not 1 <= window <= width:
        raise ValueError(f"window must lie in [1, {width}] (the panorama width), got {window}")
    return int(window)


def n_rotations(width: int, step: int = 5) -> int:
    """Number ``K = width // step`` of rotated views of a panorama ``width`` columns wide.

    Raises:
        ValueError: if ``step`` is outside ``[1, width]`` or does not divide ``width``.
    """
    if not _is_int(width) or width < 1:
        raise ValueError(f"width must be a positive int (columns), got {width!r}")
    return int(width) // check_step(int(width), step)


def check_indices(width: int, step: int, indices: ArrayLike | None) -> NDArray[np.intp]:
    """Rotation indices ``indices`` (all ``K = width // step`` for None) as ``intp`` after
    checking that they are a 1-d integer array in ``[0, K)``.

    Raises:
        ValueError: another shape or type, or an index out of range; the message names both.
    """
    n = n_rotations(width, step)
    if indices is None:
        return np.arange(n, dtype=np.intp)
    k = np.asarray(indices)
    if k.ndim != 1 or not np.issubdtype(k.dtype, np.integer) or np.any((k < 0) | (k >= n)):
        raise ValueError(
            f"indices must be a 1-d array of view indices in [0, {n}) (K = {width} // {step}), "
            f"got {indices!r}"
        )
    return k.astype(np.intp)


def rotation_sequence(
    n_rot: int, appearances: int = 1
) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """The order in which the views of one place are trained on: ``(k, a)``, each ``(n_rot *
    appearances,)``, rotation ``k`` of the place's panorama under appearance ``a``.

    With one appearance the rotations come in order, ``k = 0 .. n_rot - 1``. With several
    (the same place recorded at other times), every rotation is seen under each appearance
    before the next rotation, the appearances in a snake (forward at even ``k``, backward at
    odd ``k``): consecutive views differ either in appearance alone or in rotation alone, and
    the appearance changes faster than the rotation, so that slowness learns to ignore both.
    """
    if not _is_int(n_rot) or n_rot < 1:
        raise ValueError(f"n_rot must be a positive int, got {n_rot!r}")
    _check_appearances(appearances)
    k = np.repeat(np.arange(n_rot, dtype=np.intp), appearances)
    forward = np.tile(np.arange(appearances, dtype=np.intp), n_rot)
    a = np.where(k % 2 == 0, forward, appearances - 1 - forward)
    return k, a


def count_places(n_panoramas: int, appearances: int) -> int:
    """How many places ``n_panoramas`` consecutive panoramas show when each place is a run of
    ``appearances`` of them (see :func:`rotation_sequence`).

    Raises:
        ValueError: ``appearances`` is not a positive int, or the panoramas are not whole
            places.
    """
    _check_appearances(appearances)
    if n_panoramas % appearances:
        raise ValueError(
            f"{n_panoramas} panoramas are not whole locations of {appearances} appearances each"
        )
    return n_panoramas // appearances


def _check_appearances(appearances: int) -> None:
    if not _is_int(appearances) or appearances < 1:
        raise ValueError(f"appearances must be a positive int, got {appearances!r}")


def rotation_angles(
    width: int, step: int = 5, indices: ArrayLike | None = None
) -> NDArray[np.float64]:
    """Relative orientations ``phi_k = 2*pi*k*step/width`` (radians) of views ``indices``
    (all ``K`` by default), ``(len(indices),)``."""
    k = check_indices(width, step, indices).astype(np.float64)
    return 2.0 * np.pi * k * step / width


def rotation_columns(
    width: int, step: int = 5, window: int | None = None, indices: ArrayLike | None = None
) -> NDArray[np.intp]:
    """Panorama columns of each view: ``(len(indices), window)``, row ``i`` holds
    ``(k_i * step + arange(window)) % width`` for ``k_i = indices[i]`` (all ``K`` views by
    default)."""
    k = check_indices(width, step, indices)
    window = check_window(width, window)
    return (k[:, None] * step + np.arange(window)[None, :]) % width


def rotated_views(
    panoramas: NDArray[Any],
    step: int = 5,
    window: int | None = None,
    indices: ArrayLike | None = None,
) -> tuple[NDArray[Any], NDArray[np.float64]]:
    """Simulated rotations of one panorama or of a batch.

    Args:
        panoramas: ``(H, W, C)`` image or ``(N, H, W, C)`` batch (uint8 RGB for the env's
            panoramas), periodic in ``W``.
        step: shift between consecutive views, in columns; must divide ``W``.
        window: keep only the first ``window`` columns of each view (a field of view of
            ``360 * window / W`` degrees); ``None`` keeps the full width.
        indices: which views ``k`` to return (default all ``K = W // step``).

    Returns:
        ``views``: fresh C-contiguous array of the input's dtype, ``(K, H, window, C)`` for one
        panorama and ``(N, K, H, window, C)`` for a batch, where
        ``views[..., i, :, :, :] == np.roll(panorama, -k_i * step, axis=1)[:, :window]``;
        ``phis``: ``(K,)`` float64, ``phis[i] = 2*pi*k_i*step/W`` radians.

    Example:
        >>> pano = np.arange(10, dtype=np.uint8).reshape(1, 10, 1)
        >>> views, phis = rotated_views(pano, step=5, window=3)
        >>> views[:, 0, :, 0].tolist(), np.degrees(phis).tolist()
        ([[0, 1, 2], [5, 6, 7]], [0.0, 180.0])
        >>> rotated_views(np.stack([pano, pano]), step=5)[0].shape
        (2, 2, 1, 10, 1)
    """
    panoramas = np.asarray(panoramas)
    if panoramas.ndim not in (3, 4):
        raise ValueError(
            f"panoramas must have shape (H, W, C) or (N, H, W, C), got shape {panoramas.shape}"
        )
    width = panoramas.shape[-2]
    k = check_indices(width, step, indices)
    window = check_window(width, window)
    batch = panoramas if panoramas.ndim == 4 else panoramas[None]
    # Append the first window-1 columns, so that view k is the plain slice of columns
    # k*step .. k*step+window-1 of the extended panoramas (the columns rotation_columns gives);
    # all views are then one strided view, copied once into a fresh C-contiguous array.
    extended = np.concatenate([batch, batch[:, :, : window - 1]], axis=2)
    n, height, _, channels = batch.shape
    s_n, s_row, s_col, s_chan = extended.strides
    strided = as_strided(
        extended,
        shape=(n, width // step, height, window, channels),
        strides=(s_n, step * s_col, s_row, s_col, s_chan),
        writeable=False,
    )
    if panoramas.ndim == 3:
        strided = strided[0]
    phis = rotation_angles(width, step, indices)
    if indices is None:
        return strided.copy(), phis
    shape = (*strided.shape[:-4], len(k), *strided.shape[-3:])
    out = np.empty(shape, dtype=panoramas.dtype)
    for i, view in enumerate(k):  # a strided slice each: one pass over the output
        out[..., i, :, :, :] = strided[..., view, :, :, :]
    return out, phis


def spread_indices(n_views: int, count: int | None) -> NDArray[np.intp]:
    """Indices of ``count`` evenly spaced views out of ``n_views`` (all for ``None`` or
    ``count >= n_views``), starting with view 0."""
    if not _is_int(n_views) or n_views < 1:
        raise ValueError(f"n_views must be a positive int, got {n_views!r}")
    if count is None or count >= n_views:
        return np.arange(n_views, dtype=np.intp)
    if not _is_int(count) or count < 1:
        raise ValueError(f"count must be a positive int or None, got {count!r}")
    return np.unique((np.arange(count) * n_views) // count).astype(np.intp)


def quarter_indices(n_views: int) -> NDArray[np.intp]:
    """The views nearest 0, 90, 180 and 270 degrees (sorted, without repeats), as firing maps
    show them."""
    return np.array(sorted({round(q * n_views / 4) % n_views for q in range(4)}), dtype=np.intp)


@dataclass(frozen=True)
class Rotation:
    """How a panorama is turned into rotated views: given once, used everywhere.

    Args:
        step: shift between consecutive views, in columns (the paper: 5 px); must divide the
            panorama width.
        window: width of each view in columns (``None``: the full 360 degrees).
    """

    step: int = 5
    window: int | None = None

    def __post_init__(self) -> None:
        if not _is_int(self.step) or self.step < 1:
            raise ValueError(f"Rotation step must be a positive int (columns), got {self.step!r}")
        if self.window is not None and (not _is_int(self.window) or self.window < 1):
            raise ValueError(
                f"Rotation window must be a positive int (columns) or None, got {self.window!r}"
            )

    def n_views(self, width: int) -> int:
        """``K = width // step``; raises if ``step`` does not divide ``width``."""
        check_window(width, self.window)
        return n_rotations(width, self.step)

    def view_width(self, width: int) -> int:
        """Columns of each view of a panorama ``width`` columns wide."""
        return check_window(width, self.window)

    def angles(self, width: int, indices: ArrayLike | None = None) -> NDArray[np.float64]:
        """See :func:`rotation_angles`."""
        return rotation_angles(width, self.step, indices)

    def columns(self, width: int, indices: ArrayLike | None = None) -> NDArray[np.intp]:
        """See :func:`rotation_columns`."""
        return rotation_columns(width, self.step, self.window, indices)

    def views(
        self, panoramas: NDArray[Any], indices: ArrayLike | None = None
    ) -> tuple[NDArray[Any], NDArray[np.float64]]:
        """See :func:`rotated_views`."""
        return rotated_views(panoramas, self.step, self.window, indices)
