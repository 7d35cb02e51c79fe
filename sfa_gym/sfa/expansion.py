"""Quadratic expansion: all monomials of degree 1 and 2.

For ``x`` of dimension ``d`` the expansion is ``[x_0 .. x_{d-1}, x_i * x_j for i <= j]`` with the
pairs in row-major upper-triangle order ``(0,0), (0,1), .., (0,d-1), (1,1), ..`` (the order of
``np.triu_indices(d)`` and of MDP's ``QuadraticExpansionNode``): ``d + d(d+1)/2`` outputs.

Memory: the output is preallocated and filled row-block by row-block of pairs (``x_i * x[i:]``
written in place), so no temporary is larger than the output itself; gathering columns with
``x[:, iu] * x[:, ju]`` would create two more output-sized temporaries. The hierarchical network
never materialises more than one chunk of expanded data: it accumulates the covariance of each
chunk and drops it.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray
from sklearn.base import BaseEstimator, TransformerMixin
from sklearn.utils import Tags
from sklearn.utils.validation import check_is_fitted, validate_data

__all__ = ["QuadraticExpansion", "n_quadratic_features", "quadratic_expand"]


def n_quadratic_features(d: int) -> int:
    """Output dimension of the quadratic expansion of ``d`` inputs: ``d + d(d+1)/2``."""
    return d + d * (d + 1) // 2


def quadratic_expand(
    x: NDArray[np.floating], out: NDArray[np.floating] | None = None, axis: int = -1
) -> NDArray[np.floating]:
    """Quadratic expansion of ``x`` along its feature axis, same float dtype.

    Args:
        x: float array with the ``d`` features on ``axis`` (``-1``: ``(..., d)``; ``0``:
            ``(d, ...)``, the faster layout: every product is then one long contiguous row).
        out: optional preallocated output, the feature axis of length ``d + d(d+1)/2``.
        axis: ``-1`` or ``0``.

    Returns:
        ``(..., D)`` for ``axis=-1``, ``(D, ...)`` for ``axis=0``.
    """
    if axis not in (0, -1):
        raise ValueError(f"axis must be 0 or -1, got {axis}")
    if axis == 0:
        d = x.shape[0]
        shape = (n_quadratic_features(d), *x.shape[1:])
    else:
        d = x.shape[-1]
        shape = (*x.shape[:-1], n_quadratic_features(d))
    if out is None:
        out = np.empty(shape, dtype=x.dtype)
    elif out.shape != shape:
        raise ValueError(f"out has shape {out.shape}, expected {shape}")
    offset = d
    if axis == 0:
        out[:d] = x
        for i in range(d):
            np.multiply(x[i], x[i:], out=out[offset : offset + d - i])
            offset += d - i
        return out
    out[..., :d] = x
    for i in range(d):
        width = d - i
        np.multiply(x[..., i : i + 1], x[..., i:], out=out[..., offset : offset + width])
        offset += width
    return out


class QuadraticExpansion(TransformerMixin, BaseEstimator):
    """Quadratic expansion as a (stateless) scikit-learn transformer.

    float32 input stays float32, anything else becomes float64.

    Attributes (after ``fit``): ``n_features_in_`` (d), ``n_output_features_``.

    Example:
        >>> QuadraticExpansion().fit_transform(np.array([[1.0, 2.0]])).tolist()
        [[1.0, 2.0, 1.0, 2.0, 4.0]]
    """

    def __init__(self) -> None:
        pass

    def fit(self, X: Any, y: Any = None) -> QuadraticExpansion:
        """Record the input dimension of ``X`` ``(n, d)``; ``y`` is ignored."""
        del y
        validate_data(self, X, dtype=[np.float64, np.float32])
        self.n_output_features_ = n_quadratic_features(self.n_features_in_)
        return self

    def transform(self, X: Any) -> NDArray[np.floating]:
        """Expand ``X`` ``(n, d)`` -> ``(n, d + d(d+1)/2)``."""
        check_is_fitted(self, "n_output_features_")
        arr = validate_data(self, X, reset=False, dtype=[np.float64, np.float32])
        return quadratic_expand(arr)

    def __sklearn_tags__(self) -> Tags:
        tags = super().__sklearn_tags__()
        tags.transformer_tags.preserves_dtype = ["float64", "float32"]
        return tags
