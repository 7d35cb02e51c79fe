"""Principal component analysis of down-sampled panoramas.

The linear, unsupervised counterpart of SFA: each view is shrunk by area averaging (OpenCV
``INTER_AREA``) by ``shrink`` in both directions (40 x 350 -> 8 x 70 by default, so that one
5 px rotation step is one column), and projected on the ``n_components`` directions of largest
variance of the training views (8, as many as the SFA outputs), by scikit-learn's ``PCA`` (the
covariance's eigenvectors, ``svd_solver="covariance_eigh"``: the ``D x D`` covariance is small
next to the ``N x D`` data). With ``whiten`` the outputs have unit variance over the training
views, like SFA's. PCA ignores the temporal order of the views that SFA learns from. Views are
shrunk a chunk at a time; the shrunk training views are held as float64 (``N * D * 8`` bytes:
0.6 GB for the 43 680 rotated views of the paper's 624 training locations).
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
import sklearn.decomposition
from numpy.typing import ArrayLike, NDArray
from sklearn.base import BaseEstimator, TransformerMixin
from sklearn.exceptions import NotFittedError
from tqdm.auto import tqdm

from sfa_gym.plugins import Capabilities, check_panoramas, check_views, iter_chunks
from sfa_gym.shrink import shrunk_rotations


@dataclass(frozen=True)
class Args:
    n_components: int = 8
    """number of principal components kept (as many as SFA outputs by default)"""
    shrink: int = 5
    """down-sampling factor in both directions before PCA (1 = full resolution)"""
    whiten: bool = True
    """scale each component to unit variance over the training views"""
    regressor: str = "quadratic"
    """regression these features are paired with (sfa_gym.localization.regression name)"""
    chunk: int = 2048
    """views shrunk at once"""
    progress: bool = False
    """show a progress bar while fitting"""


def shrink_views(views: NDArray[np.uint8], shrink: int) -> NDArray[np.float64]:
    """``(N, H, W, 3)`` uint8 -> ``(N, (H // shrink) * (W // shrink) * 3)`` float64 in [0, 1]."""
    n, height, width, _ = views.shape
    if (
        isinstance(shrink, bool)
        or not isinstance(shrink, int)
        or not 1 <= shrink <= min(height, width)
    ):
        raise ValueError(
            f"shrink must be an int in [1, {min(height, width)}] for views of {height} x {width}, "
            f"got {shrink!r}"
        )
    size = (width // shrink, height // shrink)  # OpenCV wants (columns, rows)
    if shrink == 1:
        small = views
    else:
        small = np.stack([cv2.resize(v, size, interpolation=cv2.INTER_AREA) for v in views])
    return small.reshape(n, -1) / 255.0


def _round_off(data: NDArray[np.float64], mean: NDArray[np.float64]) -> float:
    """Size of the round-off in the covariance of ``data (N, D)``: the covariance is computed as
    ``X^T X / (N - 1) - mean mean^T``, whose cancellation leaves ~eps * |mean|^2 per entry."""
    return float(data.shape[1] * np.finfo(np.float64).eps * max(1.0, float(mean @ mean)))


class PCA(TransformerMixin, BaseEstimator):
    """Feature method: projection of shrunk views on their principal components; the parameters
    are the fields of :class:`Args` (their defaults too).

    Attributes (after ``fit``):
        pca_: the fitted ``sklearn.decomposition.PCA``.
        input_shape_: (H, W, 3).
        mean_: (D,) float64, mean shrunk view.
        components_: (n_components, D) float64, unit-norm directions, largest variance first.
        explained_variance_: (n_components,) float64, variance along each component.
    """

    name = "pca"

    def __init__(
        self,
        n_components: int = Args.n_components,
        shrink: int = Args.shrink,
        whiten: bool = Args.whiten,
        regressor: str = Args.regressor,
        chunk: int = Args.chunk,
        progress: bool = Args.progress,
    ) -> None:
        self.n_components = n_components
        self.shrink = shrink
        self.whiten = whiten
        self.regressor = regressor
        self.chunk = chunk
        self.progress = progress

    @property
    def capabilities(self) -> Capabilities:
        return Capabilities(regressor=self.regressor, extra_regressors=("map",))

    def fit(self, views: NDArray[np.uint8], sequence_ids: NDArray | None = None) -> PCA:
        """Fit on training ``views (N, H, W, 3)`` uint8 (their order is irrelevant to PCA)."""
        views = check_views(views)
        n = len(views)
        dim = shrink_views(views[:1], self.shrink).shape[1]
        n_components = self.n_components
        if isinstance(n_components, bool) or not isinstance(n_components, int):
            raise TypeError(f"n_components must be an int, got {n_components!r}")
        if not 1 <= n_components <= min(n - 1, dim):
            raise ValueError(
                f"n_components must lie in [1, {min(n - 1, dim)}] for {n} views of {dim} "
                f"values each (N - 1 and D bound the rank), got {n_components}"
            )
        shrunk = np.empty((n, dim))
        parts = list(iter_chunks(n, self.chunk))
        for part in tqdm(parts, desc="PCA", disable=not self.progress):
            shrunk[part] = shrink_views(views[part], self.shrink)
        # svd_flip makes the largest entry of each component positive: the same data give the
        # same features.
        self.pca_ = sklearn.decomposition.PCA(
            n_components, whiten=self.whiten, svd_solver="covariance_eigh"
        ).fit(shrunk)
        self.components_ = self.pca_.components_
        self.explained_variance_ = self.pca_.explained_variance_
        self.mean_ = self.pca_.mean_
        # Eigenvalues of a covariance with fewer directions than components are round-off.
        if self.whiten and np.any(self.explained_variance_ <= _round_off(shrunk, self.mean_)):
            raise ValueError(
                "the training views vary along fewer than n_components directions, so whitening "
                "would divide by zero; use fewer components, more varied views or whiten=False"
            )
        self.input_shape_ = tuple(views.shape[1:])
        return self

    def transform(self, views: NDArray[np.uint8]) -> NDArray[np.float64]:
        """``(N, H, W, 3)`` uint8 (the fitted shape) -> ``(N, n_components)`` float64."""
        if not hasattr(self, "pca_"):
            raise NotFittedError("PCA is not fitted yet; call fit(views) first")
        views = check_views(views)
        if tuple(views.shape[1:]) != self.input_shape_:
            raise ValueError(
                f"PCA was fitted on views of shape {self.input_shape_}, "
                f"got {tuple(views.shape[1:])}"
            )
        out = np.empty((len(views), len(self.components_)))
        for part in iter_chunks(len(views), self.chunk):
            out[part] = self.pca_.transform(shrink_views(views[part], self.shrink))
        return out

    def transform_rotations(
        self, panoramas: NDArray[np.uint8], step: int, indices: ArrayLike | None = None
    ) -> NDArray[np.float64]:
        """Features of the ``step``-column rotated views ``indices`` (all by default) of each
        panorama ``(L, H, W, 3)`` uint8, views as wide as the fitted ones: ``(L, K',
        n_components)``; the fast path of :mod:`sfa_gym.features`. The shrunk views come from a
        few shrunk copies of each panorama (:func:`sfa_gym.shrink.shrunk_rotations`, the same
        bytes as shrinking each view), so no view is built; each panorama's views are projected
        together, as ``transform`` does when given them, and ``indices`` picked from them (a
        BLAS product's last bits can depend on its row count, so projecting only some views
        could move the features)."""
        if not hasattr(self, "pca_"):
            raise NotFittedError("PCA is not fitted yet; call fit(views) first")
        panoramas = check_panoramas(panoramas, self.input_shape_, "PCA")
        height, window = self.input_shape_[:2]
        rows, cols = height // self.shrink, window // self.shrink
        shrunk = shrunk_rotations(panoramas, step, window, rows, cols)
        n, k = shrunk.shape[:2]
        out = np.empty((n, k, len(self.components_)))
        for i, views in enumerate(shrunk):
            flat = views.reshape(k, -1) / 255.0
            for part in iter_chunks(k, self.chunk):
                out[i, part] = self.pca_.transform(flat[part])
        return out if indices is None else out[:, indices]


METHOD = PCA
