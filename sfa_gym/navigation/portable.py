"""Arithmetic that gives the same bits on every x86-64 CPU, for what runs at every step of a
navigation episode (the gradient controller's local fit, the field's look-up, the range sensor's
rays).

A navigation episode that touches a wall turns a difference in the last bit into decimetres of
path within seconds, so the controller's numbers must not depend on the CPU. Two things in numpy
do: its float64 ``exp``, ``arctan2`` and ``power`` take other kernels where it dispatches to
AVX-512, and matrix products, solves and eigenvalues call OpenBLAS, whose kernels (chosen per
CPU: SkylakeX, Haswell, ...) sum in other orders. IEEE arithmetic (``+ - * /``, ``sqrt``) rounds
the same everywhere, whatever the vector width, and so do numpy's element-wise ufuncs on it,
its ``sum`` and its own (non-BLAS) ``einsum`` loops. This module builds the few operations the
controller needs from those alone; ``tests/test_portable.py`` checks them against numpy and
against another CPU's kernels.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["exp", "gram", "norm2", "smallest_eigenvalue", "solve"]

_LN2_HI = 6.93147180369123816490e-01  # ln 2 to 32 bits: k * _LN2_HI is exact for |k| < 2**20
_LN2_LO = 1.90821492927058770002e-10  # the rest of ln 2
_EXP_TERMS = 14  # Taylor terms: the 14th is below 1e-17 of the result for |r| <= ln(2) / 2


def exp(x: ArrayLike) -> NDArray[np.float64]:
    """``exp(x)`` element-wise, within 2 ulp of the exact value: ``2**k * exp(r)`` with
    ``|r| <= ln(2) / 2`` and ``exp(r)`` from its Taylor series."""
    x = np.asarray(x, dtype=np.float64)
    k = np.rint(x / math.log(2.0))
    r = (x - k * _LN2_HI) - k * _LN2_LO
    series = np.ones_like(r)
    for n in range(_EXP_TERMS, 0, -1):  # Horner: 1 + r (1 + r/2 (1 + r/3 (...)))
        series = 1.0 + series * r / n
    return np.ldexp(series, np.clip(k, -1100, 1100).astype(np.int64))


def norm2(v: ArrayLike) -> float:
    """The Euclidean length of a 2-vector."""
    x, y = (float(c) for c in np.asarray(v, dtype=np.float64))
    return math.sqrt(x * x + y * y)


def gram(a: ArrayLike, b: ArrayLike, weights: ArrayLike | None = None) -> NDArray[np.float64]:
    """``a.T @ diag(weights) @ b`` for ``a (n, i)``, ``b (n, j)`` (``weights (n,)``, default
    ones), summed by numpy's own loops instead of BLAS."""
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    if weights is None:
        return np.einsum("ni,nj->ij", a, b)
    return np.einsum("ni,n,nj->ij", a, np.asarray(weights, dtype=np.float64), b)


def smallest_eigenvalue(m: ArrayLike) -> float:
    """The smaller eigenvalue of a symmetric 2 x 2 matrix (closed form)."""
    (a, b), (_, c) = np.asarray(m, dtype=np.float64).tolist()
    half_gap = math.sqrt(((a - c) / 2) ** 2 + b * b)
    return (a + c) / 2 - half_gap


def solve(m: ArrayLike, rhs: ArrayLike) -> NDArray[np.float64]:
    """``m^-1 rhs`` for a 2 x 2 or 3 x 3 matrix ``m`` and ``rhs (n,)`` or ``(n, k)``, by the
    adjugate (the matrices here are small, symmetric positive definite and regularised).

    Raises:
        numpy.linalg.LinAlgError: ``m`` is singular.
    """
    m = np.asarray(m, dtype=np.float64)
    rhs = np.asarray(rhs, dtype=np.float64)
    if m.shape == (2, 2):
        (a, b), (c, d) = m.tolist()
        adjugate = np.array([[d, -b], [-c, a]])
        det = a * d - b * c
    elif m.shape == (3, 3):
        (a, b, c), (d, e, f), (g, h, i) = m.tolist()
        adjugate = np.array(
            [
                [e * i - f * h, c * h - b * i, b * f - c * e],
                [f * g - d * i, a * i - c * g, c * d - a * f],
                [d * h - e * g, b * g - a * h, a * e - b * d],
            ]
        )
        det = a * adjugate[0, 0] + b * adjugate[1, 0] + c * adjugate[2, 0]
    else:
        raise ValueError(f"m must be 2 x 2 or 3 x 3, got shape {m.shape}")
    if det == 0.0 or not math.isfinite(det):
        raise np.linalg.LinAlgError(f"singular matrix (determinant {det})")
    if rhs.ndim == 1:
        return np.einsum("ij,j->i", adjugate, rhs) / det
    return np.einsum("ij,jk->ik", adjugate, rhs) / det
