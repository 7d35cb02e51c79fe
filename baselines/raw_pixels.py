"""Raw pixels of a strongly down-sampled view.

Each view is shrunk by area averaging (OpenCV ``INTER_AREA``) to ``height x width`` pixels, 4 x 35
by default (420 numbers in ``[0, 1]``, 10 x 10 px blocks of a 40 x 350 panorama). The features
are not rotation invariant: a nearest-neighbour regression over the rotated views of every
training location (the default pairing) looks the position up by appearance. Nothing is learned;
``fit`` only records the input shape.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import ArrayLike, NDArray
from sklearn.base import BaseEstimator, TransformerMixin
from sklearn.exceptions import NotFittedError

from sfa_gym.plugins import Capabilities, check_panoramas, check_views
from sfa_gym.shrink import shrunk_rotations


@dataclass(frozen=True)
class Args:
    height: int = 4
    """rows of the down-sampled view (at most the view height)"""
    width: int = 35
    """columns of the down-sampled view (at most the view width)"""
    regressor: str = "knn"
    """regression these features are paired with (sfa_gym.localization.regression name)"""


def _check_size(view_shape: tuple[int, ...], height: int, width: int) -> None:
    for name, value, top in (("height", height, view_shape[0]), ("width", width, view_shape[1])):
        if isinstance(value, bool) or not isinstance(value, int) or not 1 <= value <= top:
            raise ValueError(
                f"{name} must be an int in [1, {top}] (the view {name}), got {value!r}; "
                "raw_pixels only shrinks"
            )


def raw_pixels(views: NDArray[np.uint8], height: int = 4, width: int = 35) -> NDArray[np.float64]:
    """``views (N, H, W, 3)`` uint8 -> ``(N, height * width * 3)`` float64 in ``[0, 1]``.

    Row-major over the shrunk image, ``(r, g, b)`` innermost.
    """
    views = check_views(views)
    _check_size(views.shape[1:3], height, width)
    out = np.empty((len(views), height, width, 3), dtype=np.float64)
    for i, view in enumerate(views):
        out[i] = cv2.resize(view, (width, height), interpolation=cv2.INTER_AREA)
    return out.reshape(len(views), -1) / 255.0


class RawPixels(TransformerMixin, BaseEstimator):
    """Feature method: :func:`raw_pixels` of each view; the parameters are the fields of
    :class:`Args` (their defaults too)."""

    name = "raw_pixels"

    def __init__(
        self, height: int = Args.height, width: int = Args.width, regressor: str = Args.regressor
    ) -> None:
        self.height = height
        self.width = width
        self.regressor = regressor

    @property
    def capabilities(self) -> Capabilities:
        return Capabilities(regressor=self.regressor)

    def fit(self, views: NDArray[np.uint8], sequence_ids: NDArray | None = None) -> RawPixels:
        """Record ``input_shape_`` (nothing to learn); ``views (N, H, W, 3)`` uint8."""
        views = check_views(views)
        _check_size(views.shape[1:3], self.height, self.width)
        self.input_shape_ = tuple(views.shape[1:])
        return self

    def transform(self, views: NDArray[np.uint8]) -> NDArray[np.float64]:
        """``(N, H, W, 3)`` uint8 -> ``(N, height * width * 3)`` float64."""
        if not hasattr(self, "input_shape_"):
            raise NotFittedError("RawPixels is not fitted yet; call fit(views) first")
        return raw_pixels(views, self.height, self.width)

    def transform_rotations(
        self, panoramas: NDArray[np.uint8], step: int, indices: ArrayLike | None = None
    ) -> NDArray[np.float64]:
        """Features of the ``step``-column rotated views ``indices`` (all by default) of each
        panorama ``(L, H, W, 3)`` uint8, views as wide as the fitted ones: ``(L, K', height *
        width * 3)``, the same values as ``transform`` of each view; the fast path of
        :mod:`sfa_gym.features` (:func:`sfa_gym.shrink.shrunk_rotations`: no view is built)."""
        if not hasattr(self, "input_shape_"):
            raise NotFittedError("RawPixels is not fitted yet; call fit(views) first")
        panoramas = check_panoramas(panoramas, self.input_shape_, "RawPixels")
        window = self.input_shape_[1]
        shrunk = shrunk_rotations(panoramas, step, window, self.height, self.width, indices)
        return shrunk.reshape(*shrunk.shape[:2], -1) / 255.0


METHOD = RawPixels
