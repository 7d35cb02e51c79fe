"""Row-band colour means: the mean RGB colour of each of ``n_bands`` horizontal bands.

A panorama's rows are split into ``n_bands`` bands of (nearly) equal height; each band gives its
mean red, green and blue over all its pixels, scaled to ``[0, 1]``: ``3 * n_bands`` numbers per
view (24 by default). A simulated rotation is a circular shift of the columns, which leaves every
column statistic unchanged, so these features are exactly rotation invariant (sums are taken in
integers: not even rounding differs). On a static simulated arena they reach the paper's
localization error with a quadratic regression, which is why every localization table carries
them. Nothing is learned; ``fit`` only records the input shape.
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
    regressor: str = "quadratic"
    """regression these features are paired with (sfa_gym.localization.regression name)"""
    chunk: int = 1024
    """views processed at once (bounds the memory of the integer sums)"""


def band_edges(height: int, n_bands: int) -> NDArray[np.intp]:
    """First row of each band, ``(n_bands,)``; bands differ in height by at most one row."""
    if isinstance(n_bands, bool) or not isinstance(n_bands, int) or not 1 <= n_bands <= height:
        raise ValueError(
            f"n_bands must be an int in [1, {height}] (the view height), got {n_bands!r}"
        )
    return np.array([rows[0] for rows in np.array_split(np.arange(height), n_bands)])


def band_means(
    views: NDArray[np.uint8], n_bands: int = 8, chunk: int = 1024
) -> NDArray[np.float64]:
    """``views (N, H, W, 3)`` uint8 -> ``(N, 3 * n_bands)`` mean colours in ``[0, 1]``.

    Ordered band by band (top band first), ``(r, g, b)`` within a band.
    """
    views = check_views(views)
    n, height, width, _ = views.shape
    starts = band_edges(height, n_bands)
    rows_per_band = np.diff(np.append(starts, height))
    out = np.empty((n, n_bands, 3), dtype=np.float64)
    for part in iter_chunks(n, chunk):
        row_sums = views[part].sum(axis=2, dtype=np.int64)  # (n, H, 3), exact
        band_sums = np.add.reduceat(row_sums, starts, axis=1)  # (n, n_bands, 3), exact
        out[part] = band_sums / (255.0 * width * rows_per_band[None, :, None])
    return out.reshape(n, 3 * n_bands)


class BandMeans(TransformerMixin, BaseEstimator):
    """Feature method: :func:`band_means` of each view; the parameters are the fields of
    :class:`Args` (their defaults too)."""

    name = "band_means"

    def __init__(
        self, n_bands: int = Args.n_bands, regressor: str = Args.regressor, chunk: int = Args.chunk
    ) -> None:
        self.n_bands = n_bands
        self.regressor = regressor
        self.chunk = chunk

    @property
    def capabilities(self) -> Capabilities:
        # a full-width rotated view (a circular shift of the columns) has the panorama's features
        return Capabilities(
            rotation_invariant=True, regressor=self.regressor, extra_regressors=("map",)
        )

    def fit(self, views: NDArray[np.uint8], sequence_ids: NDArray | None = None) -> BandMeans:
        """Record ``input_shape_`` (nothing to learn); ``views (N, H, W, 3)`` uint8."""
        views = check_views(views)
        band_edges(views.shape[1], self.n_bands)
        self.input_shape_ = tuple(views.shape[1:])
        return self

    def transform(self, views: NDArray[np.uint8]) -> NDArray[np.float64]:
        """``(N, H, W, 3)`` uint8 -> ``(N, 3 * n_bands)`` float64."""
        if not hasattr(self, "input_shape_"):
            raise NotFittedError("BandMeans is not fitted yet; call fit(views) first")
        return band_means(views, self.n_bands, self.chunk)


METHOD = BandMeans
