"""Array aliases shared across the package (shapes are in the docstrings that use them), and the
one check of a stack of views (and of panoramas for a fitted model) that every consumer uses."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

Panorama = NDArray[np.uint8]
"""One panorama, ``(H, W, 3)`` uint8 RGB; column 0 looks along the heading."""

Panoramas = NDArray[np.uint8]
"""A stack of panoramas, ``(N, H, W, 3)`` uint8."""

FloatArray = NDArray[np.floating]
Pose = tuple[float, float, float]
"""Ground-plane pose ``(x, y, yaw)`` in metres and radians, MuJoCo world frame."""


def check_views(views: Any, name: str = "views", *, min_views: int = 1) -> NDArray[np.uint8]:
    """``views`` as an array after checking that it is a stack ``(N, H, W, 3)`` of uint8 RGB
    images with ``N >= min_views`` and ``H, W >= 1``.

    A single ``(H, W, 3)`` view is refused (say ``view[None]``) rather than guessed at.

    Raises:
        TypeError: not uint8 (float images in 0..255: ``np.clip(x, 0, 255).astype(np.uint8)``).
        ValueError: another shape; the message gives the shape found.
    """
    if hasattr(views, "tocsr"):  # scipy.sparse: images are dense
        raise TypeError(f"{name}: sparse input is not supported; pass a dense uint8 array")
    array = np.asarray(views)
    if array.dtype != np.uint8:
        raise TypeError(
            f"{name} must be uint8 RGB images (N, H, W, 3), got dtype {array.dtype}; convert "
            "with np.clip(x, 0, 255).astype(np.uint8) if they are float images in 0..255"
        )
    if array.ndim == 3 and array.shape[-1] == 3:
        raise ValueError(
            f"{name} must be a stack (N, H, W, 3), got one view of shape {array.shape}; "
            "pass view[None]"
        )
    if array.ndim != 4 or array.shape[-1] != 3 or 0 in array.shape[1:] or len(array) < min_views:
        raise ValueError(
            f"{name} must have shape (N, H, W, 3) with N >= {min_views} and H, W >= 1, "
            f"got {array.shape}"
        )
    return array


def check_panoramas(panoramas: Any, input_shape: tuple[int, ...], who: str) -> NDArray[np.uint8]:
    """``panoramas (L, H, W, 3)`` uint8 (:func:`check_views`, ``L = 0`` allowed) after checking
    that they give the views of a model ``who`` fitted on ``input_shape (H, W_view, 3)``: the
    same height and at least ``W_view`` columns.

    Raises:
        TypeError, ValueError: as :func:`check_views`; ValueError also for panoramas of another
            height or narrower than the views (the message gives both shapes).
    """
    array = check_views(panoramas, "panoramas", min_views=0)
    height, window = input_shape[:2]
    if array.shape[1] != height or array.shape[2] < window:
        raise ValueError(
            f"{who} was fitted on views of shape {tuple(input_shape)}; panoramas of shape "
            f"{tuple(array.shape[1:])} do not give such views (need height {height} and at "
            f"least {window} columns)"
        )
    return array
