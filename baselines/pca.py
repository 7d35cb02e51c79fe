"""Principal component analysis of down-sampled panoramas.

The linear, unsupervised counterpart of SFA: each view is shrunk by area averaging (OpenCV
``INTER_AREA``) by ``shrink`` in both directions (40 x 350 -> 8 x 70 by default, so that one
5 px rotation step is one column), and projected on the ``n_components`` directions of largest
variance of the training views (8, as many as the SFA outputs). With ``whiten`` the outputs have
unit variance over the training views, like SFA's. PCA ignores the temporal order of the views
that SFA learns from. The covariance is accumulated over chunks of views, so training on all
rotated views of a run does not hold them in memory as floats.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
import scipy.linalg
import scipy.sparse.linalg
from numpy.typing import NDArray
from tqdm.auto import tqdm

from sfa_gym.localization.methods import check_views, iter_chunks


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
    """views processed at once when accumulating the covariance"""
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


def _top_eigenpairs(
    matrix: NDArray[np.float64], k: int
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The ``k`` largest eigenvalues ``(k,)`` and eigenvectors ``(D, k)`` of a symmetric matrix."""
    dim = len(matrix)
    if k < dim // 4:
        # Lanczos needs only products with the matrix: for a few components of a D ~ 2000
        # covariance it takes a fraction of a second where a full decomposition takes seconds.
        # A fixed start vector keeps it deterministic.
        try:
            return scipy.sparse.linalg.eigsh(matrix, k=k, which="LA", v0=np.ones(dim), tol=0.0)
        except scipy.sparse.linalg.ArpackError:
            pass  # e.g. a zero matrix (identical views): the full decomposition copes
    return scipy.linalg.eigh(matrix, subset_by_index=(dim - k, dim - 1))


class PCA:
    """Feature method: projection of shrunk views on their principal components.

    Attributes (after ``fit``):
        input_shape_: (H, W, 3).
        mean_: (D,) float64, mean shrunk view.
        components_: (n_components, D) float64, unit-norm directions, largest variance first.
        explained_variance_: (n_components,) float64, variance along each component.
    """

    name = "pca"
    extra_regressors = ("map",)
    """regressions reported besides ``linear`` and ``regressor``"""

    def __init__(self, args: Args = Args()) -> None:
        self.args = args
        self.regressor = args.regressor

    def fit(self, views: NDArray[np.uint8], sequence_ids: NDArray | None = None) -> PCA:
        """Fit on training ``views (N, H, W, 3)`` uint8 (their order is irrelevant to PCA)."""
        views = check_views(views)
        a = self.args
        n = len(views)
        dim = shrink_views(views[:1], a.shrink).shape[1]
        if isinstance(a.n_components, bool) or not isinstance(a.n_components, int):
            raise TypeError(f"n_components must be an int, got {a.n_components!r}")
        if not 1 <= a.n_components <= min(n - 1, dim):
            raise ValueError(
                f"n_components must lie in [1, {min(n - 1, dim)}] for {n} views of {dim} "
                f"values each (N - 1 and D bound the rank), got {a.n_components}"
            )
        # Accumulating around the first chunk's mean avoids the cancellation of E[x x^T] - m m^T.
        shift = shrink_views(views[: min(n, a.chunk)], a.shrink).mean(axis=0)
        total = np.zeros(dim)
        scatter = np.zeros((dim, dim))
        for part in tqdm(
            list(iter_chunks(n, a.chunk)), desc="PCA covariance", disable=not a.progress
        ):
            x = shrink_views(views[part], a.shrink) - shift
            total += x.sum(axis=0)
            scatter += x.T @ x
        centred_mean = total / n
        covariance = (scatter - n * np.outer(centred_mean, centred_mean)) / (n - 1)
        values, vectors = _top_eigenpairs(covariance, a.n_components)
        order = np.argsort(values)[::-1]
        components = vectors[:, order].T
        # An eigenvector's sign is arbitrary; fix it so the same data give the same features.
        signs = np.sign(components[np.arange(len(components)), np.abs(components).argmax(axis=1)])
        self.components_ = components * signs[:, None]
        self.explained_variance_ = np.maximum(values[order], 0.0)
        if a.whiten and np.any(self.explained_variance_ <= 0):
            raise ValueError(
                "the training views vary along fewer than n_components directions, so whitening "
                "would divide by zero; use fewer components, more varied views or whiten=False"
            )
        self.mean_ = shift + centred_mean
        self.input_shape_ = tuple(views.shape[1:])
        return self

    def transform(self, views: NDArray[np.uint8]) -> NDArray[np.float64]:
        """``(N, H, W, 3)`` uint8 (the fitted shape) -> ``(N, n_components)`` float64."""
        if not hasattr(self, "components_"):
            raise ValueError("PCA is not fitted yet; call fit(views) first")
        views = check_views(views)
        if tuple(views.shape[1:]) != self.input_shape_:
            raise ValueError(
                f"PCA was fitted on views of shape {self.input_shape_}, "
                f"got {tuple(views.shape[1:])}"
            )
        out = np.empty((len(views), len(self.components_)))
        for part in iter_chunks(len(views), self.args.chunk):
            out[part] = (
                shrink_views(views[part], self.args.shrink) - self.mean_
            ) @ self.components_.T
        if self.args.whiten:
            out /= np.sqrt(self.explained_variance_)
        return out


def make_method(**kwargs) -> PCA:
    """A :class:`PCA` with ``Args(**kwargs)``."""
    return PCA(Args(**kwargs))
