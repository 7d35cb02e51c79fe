"""Slow features of a training walk's graph, read at new inputs from the training places most
like them.

SFA finds the functions of its input that change least from one time step to the next, within
the functions its network can represent. Over a training run that revisits places, the slowest
functions of all are those of the run's *graph*: one node per place, an edge between places
visited one after the other. They solve ``(D - A) v = lambda D v`` (``A`` the transition counts,
``D`` their row sums): the Laplacian eigenmaps of the walk, SFA without a restricted function
class (the delta value of component ``i`` along the walk is ``2 lambda_i``). A walk that never
crosses a wall gives functions whose level lines bend around it, as a confined random walk's
would; a hierarchical network fitted on the same run sees the wall only in its images, and its
slowest outputs barely change across it.

:class:`WalkGraphEmbedding` computes these functions on the training places and extends them to a
new input by a Gaussian-weighted, locally linear fit over its nearest training places in the
space of the input features (say, the network's rotation-averaged slow features): the network
recognises the place, the graph says where it lies on the walk. :func:`laplacian_eigenmaps`
solves the eigenproblem of any such graph (also a grid of free cells, for the slow features of a
random walk confined to them). Numpy and scipy only.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import scipy.linalg
from numpy.typing import ArrayLike, NDArray
from scipy.sparse import coo_matrix, diags, issparse
from scipy.sparse.linalg import eigsh
from scipy.spatial import cKDTree
from sklearn.base import BaseEstimator, TransformerMixin
from sklearn.utils.validation import check_is_fitted

from sfa_gym._checks import check_positive, check_positive_int

__all__ = ["WalkGraphEmbedding", "laplacian_eigenmaps"]


def laplacian_eigenmaps(adjacency: Any, n_components: int) -> tuple[NDArray, NDArray]:
    """The ``n_components`` slowest non-constant solutions of ``(D - A) v = lambda D v`` of a
    connected graph with symmetric, non-negative edge weights ``A`` (``D`` their row sums).

    Args:
        adjacency: ``(n, n)`` ``A``, a dense array (solved exactly, for a few thousand nodes at
            most) or a scipy sparse matrix (solved by shift-invert Lanczos with a fixed start
            vector, so the same graph gives the same vectors: a grid of tens of thousands of
            cells).
        n_components: eigenvectors kept, after the constant one.

    Returns:
        ``(vectors (n, n_components), eigenvalues (n_components,))``, ascending, each vector
        scaled to ``v^T D v = 1`` and signed so that its largest entry is positive.
    """
    n = adjacency.shape[0]
    if n < n_components + 2:
        raise ValueError(
            f"the graph has {n} nodes; n_components={n_components} needs at least "
            f"{n_components + 2}"
        )
    if issparse(adjacency):
        a = adjacency.tocsc()
        degree = diags(np.asarray(a.sum(axis=1)).ravel()).tocsc()
        # shift-invert just below 0 finds the smallest; a fixed start vector keeps it
        # deterministic
        values, vectors = eigsh(
            degree - a, k=n_components + 1, M=degree, sigma=-1e-6, which="LM", v0=np.ones(n)
        )
        order = np.argsort(values)[1:]
        values, vectors = values[order], vectors[:, order]
    else:
        degree = np.asarray(adjacency).sum(axis=1)
        values, vectors = scipy.linalg.eigh(
            np.diag(degree) - adjacency, np.diag(degree), subset_by_index=[1, n_components]
        )
    # eigenvectors have no sign: make each one's largest entry positive (same fit, same features)
    vectors *= np.sign(vectors[np.abs(vectors).argmax(axis=0), np.arange(vectors.shape[1])])
    return vectors, values


class WalkGraphEmbedding(TransformerMixin, BaseEstimator):
    """The slowest functions of a training walk's graph, extended to new inputs by locally
    linear regression over the nearest training places (module docstring).

    A new input's value is the intercept of a weighted linear fit of the functions against the
    input features of its ``n_neighbors`` nearest training places (Gaussian weights): unlike a
    weighted mean, the fit follows the functions' slope between the places, so they do not
    step from one training place to the next (steps that a controller reading their gradient
    would take for minima).

    Args:
        n_components: functions kept (the slowest, after the constant one).
        n_neighbors: training places in the fit at a new input.
        bandwidth: width of the Gaussian weight, in units of the median distance between a
            training place and its nearest other place (standardised input features): small
            enough that places across a wall, alike in their features, do not blend.
        ridge: pull of the local slope towards zero, relative to the Gaussian's width squared
            (keeps the fit determined where the neighbours span few directions).

    Attributes (after ``fit``):
        embedding_: ``(L, n_components)`` the functions on the training places.
        eigenvalues_: ``(n_components,)`` ascending ``lambda_i``.
        mean_, scale_: standardisation of the input features.
        kernel_width_: the Gaussian's width in standardised units.

    Example:
        >>> x = np.arange(10.0)[:, None]  # ten places on a line, walked there and back
        >>> emb = WalkGraphEmbedding(n_components=1).fit(x, [*range(10), *range(8, -1, -1)])
        >>> f = emb.embedding_[:, 0]  # half a cosine along the line: monotonic
        >>> bool(np.all(np.diff(f) > 0) or np.all(np.diff(f) < 0))
        True
        >>> between = emb.transform([[4.5]])[0, 0]  # read between two places
        >>> bool(min(f[4], f[5]) < between < max(f[4], f[5]))
        True
    """

    def __init__(
        self,
        n_components: int = 8,
        n_neighbors: int = 30,
        bandwidth: float = 1.0,
        ridge: float = 0.02,
    ) -> None:
        self.n_components = n_components
        self.n_neighbors = n_neighbors
        self.bandwidth = bandwidth
        self.ridge = ridge

    def fit(self, X: ArrayLike, visits: ArrayLike) -> WalkGraphEmbedding:
        """Fit on the features ``X`` ``(L, d)`` of the ``L`` distinct training places and the
        walk ``visits`` ``(T,)``: indices into ``X`` in time order (a place visited again
        appears again)."""
        for name in ("n_components", "n_neighbors"):
            check_positive_int(name, getattr(self, name))
        for name in ("bandwidth", "ridge"):
            check_positive(name, getattr(self, name))
        x = np.asarray(X, dtype=np.float64)
        if x.ndim != 2 or not np.all(np.isfinite(x)):
            raise ValueError(f"X must be a finite (L, d) array, got shape {x.shape}")
        n = len(x)
        if n < self.n_components + 2:
            raise ValueError(
                f"X holds {n} places; n_components={self.n_components} needs at least "
                f"{self.n_components + 2}"
            )
        v = np.asarray(visits)
        if v.ndim != 1 or not np.issubdtype(v.dtype, np.integer) or len(v) < 2:
            raise ValueError(f"visits must be a 1-d integer array of length >= 2, got {v.shape}")
        if v.min() < 0 or v.max() >= n:
            raise ValueError(
                f"visits must index the {n} places of X, got values {v.min()}..{v.max()}"
            )
        moves = v[:-1] != v[1:]
        a = coo_matrix((np.ones(int(moves.sum())), (v[:-1][moves], v[1:][moves])), shape=(n, n))
        a = (a + a.T).toarray()  # transition counts, both ways
        degree = a.sum(axis=1)
        if np.any(degree == 0):
            # a walk connects every place it moves through; a place it never moves to or from
            # would make the graph fall apart
            missing = np.flatnonzero(degree == 0)
            raise ValueError(
                f"the walk never moves to or from {len(missing)} of the {n} places of X "
                f"(place {missing[0]} first): every place must be on the walk"
            )
        vectors, values = laplacian_eigenmaps(a, self.n_components)
        self.eigenvalues_ = values
        # unit variance over the visits: v^T D v = 1 counts every place as often as it is left
        self.embedding_ = vectors * np.sqrt(degree.sum())
        self.mean_ = x.mean(axis=0)
        scale = x.std(axis=0)
        self.scale_ = np.where(scale > 0, scale, 1.0)
        self._places = cKDTree((x - self.mean_) / self.scale_)
        nearest, _ = self._places.query(self._places.data, k=2)
        self.kernel_width_ = float(self.bandwidth * max(np.median(nearest[:, 1]), 1e-12))
        self.n_features_in_ = x.shape[1]
        return self

    def transform(self, X: ArrayLike) -> NDArray[np.float64]:
        """``(n, n_components)`` the functions at inputs ``X`` ``(n, d)``."""
        check_is_fitted(self, "embedding_")
        x = np.asarray(X, dtype=np.float64)
        if x.ndim != 2 or x.shape[1] != self.n_features_in_:
            raise ValueError(
                f"X must have shape (n, {self.n_features_in_}) like the training places, "
                f"got {x.shape}"
            )
        k = min(self.n_neighbors, len(self.embedding_))
        z = (x - self.mean_) / self.scale_
        distance, index = self._places.query(z, k=k)
        distance, index = distance.reshape(len(x), k), index.reshape(len(x), k)
        # relative to the nearest place: an input far from every place still gets a fit, not 0/0
        weight = np.exp(-0.5 * ((distance**2 - distance[:, :1] ** 2) / self.kernel_width_**2))
        # per input: minimise sum_j w_j |e_j - a - B (z_j - z)|^2 + ridge |B|^2; a is the value
        offsets = self._places.data[index] - z[:, None, :]  # (n, k, d)
        design = np.concatenate([np.ones((len(x), k, 1)), offsets], axis=2)
        normal = np.einsum("nk,nki,nkj->nij", weight, design, design)
        penalty = self.ridge * self.kernel_width_**2 * weight.sum(axis=1)
        d = design.shape[2]
        normal[:, np.arange(1, d), np.arange(1, d)] += penalty[:, None]
        rhs = np.einsum("nk,nki,nkj->nij", weight, design, self.embedding_[index])
        return np.linalg.solve(normal, rhs)[:, 0, :]
