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
from sklearn.exceptions import NotFittedError

from sfa_gym.localization.methods import check_views, iter_chunks


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


class FFTMagnitude:
    """Feature method: :func:`fft_magnitude` of each view."""

    name = "fft_magnitude"
    extra_regressors = ("map",)
    """regressions reported besides ``linear`` and ``regressor``"""
    rotation_invariant = True
    """a full-width rotated view (a circular shift of the columns) has the panorama's features"""

    def __init__(self, args: Args = Args()) -> None:
        self.args = args
        self.regressor = args.regressor

    def fit(self, views: NDArray[np.uint8], sequence_ids: NDArray | None = None) -> FFTMagnitude:
        """Record ``input_shape_`` (nothing to learn); ``views (N, H, W, 3)`` uint8."""
        views = check_views(views)
        _check_args(views.shape[1], views.shape[2], self.args.n_bands, self.args.n_frequencies)
        self.input_shape_ = tuple(views.shape[1:])
        return self

    def transform(self, views: NDArray[np.uint8]) -> NDArray[np.float64]:
        """``(N, H, W, 3)`` uint8 -> ``(N, n_bands * n_frequencies * 3)`` float64."""
        if not hasattr(self, "input_shape_"):
            raise NotFittedError("FFTMagnitude is not fitted yet; call fit(views) first")
        a = self.args
        return fft_magnitude(views, a.n_bands, a.n_frequencies, a.chunk)


def make_method(**kwargs) -> FFTMagnitude:
    """An :class:`FFTMagnitude` with ``Args(**kwargs)``."""
    return FFTMagnitude(Args(**kwargs))
