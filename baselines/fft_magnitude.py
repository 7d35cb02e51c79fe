"""Magnitude of the Fourier transform along the panorama's width, per row band and channel.

The rows of a view are split into ``n_bands`` horizontal bands; each band is averaged over its
rows into one periodic colour profile per channel (``W`` values), and the magnitudes of its lowest
``n_frequencies`` discrete Fourier coefficients (the constant term first, divided by ``W``, in
``[0, 1]`` units) are the features: ``n_bands * n_frequencies * 3`` numbers. A simulated rotation
is a circular shift of the columns, which changes only the phases of the coefficients, so the
features are rotation invariant (up to floating-point rounding, ~1e-15 relative). Unlike row-band
means they also see how the colour varies around the rover. Nothing is learned; ``fit`` only
records the input shape and checks the arguments against it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from sklearn.base import BaseEstimator, TransformerMixin
from sklearn.exceptions import NotFittedError

from sfa_gym.plugins import Capabilities, check_views, iter_chunks


@dataclass(frozen=True)
class Args:
    n_bands: int = 8
    """number of horizontal bands the rows are split into (at most the view height)"""
    n_frequencies: int = 6
    """lowest DFT frequencies kept per band and channel, the constant term included
    (at most W // 2 + 1)"""
    regressor: str = "linear"
    """regression these features are paired with (sfa_gym.localization.regression name)"""
    chunk: int = 512
    """views processed at once"""


def _check_args(height: int, width: int, n_bands: int, n_frequencies: int) -> None:
    if isinstance(n_bands, bool) or not isinstance(n_bands, int) or not 1 <= n_bands <= height:
        raise ValueError(
            f"n_bands must be an int in [1, {height}] (the view height), got {n_bands!r}"
        )
    top = width // 2 + 1
    if (
        isinstance(n_frequencies, bool)
        or not isinstance(n_frequencies, int)
        or not 1 <= n_frequencies <= top
    ):
        raise ValueError(
            f"n_frequencies must be an int in [1, {top}] (W // 2 + 1 for width {width}), "
            f"got {n_frequencies!r}"
        )


def fft_magnitude(
    views: NDArray[np.uint8], n_bands: int = 8, n_frequencies: int = 6, chunk: int = 512
) -> NDArray[np.float64]:
    """``views (N, H, W, 3)`` uint8 -> ``(N, n_bands * n_frequencies * 3)`` float64.

    Ordered band by band, then frequency, then channel.
    """
    views = check_views(views)
    n, height, width, _ = views.shape
    _check_args(height, width, n_bands, n_frequencies)
    starts = np.array([rows[0] for rows in np.array_split(np.arange(height), n_bands)])
    rows_per_band = np.diff(np.append(starts, height))
    out = np.empty((n, n_bands, n_frequencies, 3), dtype=np.float64)
    for part in iter_chunks(n, chunk):
        # Integer band sums are exactly shift-equivariant; only the FFT below rounds.
        band_sums = np.add.reduceat(views[part], starts, axis=1, dtype=np.int32)  # (n,B,W,3)
        profiles = band_sums / (255.0 * rows_per_band[None, :, None, None])
        spectrum = np.fft.rfft(profiles, axis=2)[:, :, :n_frequencies]
        out[part] = np.abs(spectrum) / width
    return out.reshape(n, -1)


class FFTMagnitude(TransformerMixin, BaseEstimator):
    """Feature method: :func:`fft_magnitude` of each view; the parameters are the fields of
    :class:`Args` (their defaults too)."""

    name = "fft_magnitude"

    def __init__(
        self,
        n_bands: int = Args.n_bands,
        n_frequencies: int = Args.n_frequencies,
        regressor: str = Args.regressor,
        chunk: int = Args.chunk,
    ) -> None:
        self.n_bands = n_bands
        self.n_frequencies = n_frequencies
        self.regressor = regressor
        self.chunk = chunk

    @property
    def capabilities(self) -> Capabilities:
        # a full-width rotated view (a circular shift of the columns) has the panorama's features
        return Capabilities(
            rotation_invariant=True, regressor=self.regressor, extra_regressors=("map",)
        )

    def fit(self, views: NDArray[np.uint8], sequence_ids: NDArray | None = None) -> FFTMagnitude:
        """Record ``input_shape_`` (nothing to learn); ``views (N, H, W, 3)`` uint8."""
        views = check_views(views)
        _check_args(views.shape[1], views.shape[2], self.n_bands, self.n_frequencies)
        self.input_shape_ = tuple(views.shape[1:])
        return self

    def transform(self, views: NDArray[np.uint8]) -> NDArray[np.float64]:
        """``(N, H, W, 3)`` uint8 -> ``(N, n_bands * n_frequencies * 3)`` float64."""
        if not hasattr(self, "input_shape_"):
            raise NotFittedError("FFTMagnitude is not fitted yet; call fit(views) first")
        return fft_magnitude(views, self.n_bands, self.n_frequencies, self.chunk)


METHOD = FFTMagnitude
