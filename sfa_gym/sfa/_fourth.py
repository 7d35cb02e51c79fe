"""Second moments of a quadratic expansion from its distinct fourth moments.

When the samples are the quadratic expansion ``q = [y, y_i y_j (i <= j)]`` of
``k``-dimensional data (``Moments(quadratic=k)``), the ``(k + k(k+1)/2)^2`` second moments of
``q`` contain only ``C(k+3, 4)`` distinct fourth moments ``<y_i y_j y_l y_m>``: 52 360 instead
of the 157 080 entries of the upper triangle for ``k = 32``. :class:`QuadraticGram` computes each
distinct fourth moment once (up to grouping, about half of the products of the symmetric rank-k
update) and assembles the full matrix at the end; whether that pays off depends on the BLAS
kernels (:func:`fourth_moments_pay_off`). The time differences of ``q`` have no such symmetry;
their moments are computed directly.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

__all__ = ["QuadraticGram", "fourth_moments_pay_off", "pair_groups", "quadratic_gram"]


def pair_groups(k: int) -> list[tuple[int, int]]:
    """Ranges ``[j1, j2)`` of the second index ``j`` of the pairs ``(i, j)`` in one product.

    Group ``[j1, j2)`` multiplies the pairs ``(i, j)``, ``j1 <= j < j2``, ``i <= j`` (M rows)
    with the pairs ``(l, m)``, ``j1 <= l <= m`` (N rows). Wider groups mean fewer, larger
    products but more redundant entries; the split minimises ``(M + 24) * (N + 32)`` summed over
    groups, a cost model of small matrix products fitted to timings here (for ``k = 32``:
    ``0, 9, 15, 20, 24, 28, 32``).
    """

    def tail(j: int) -> int:
        return (k - j) * (k - j + 1) // 2

    cost = [0.0] + [np.inf] * k
    prev = [0] * (k + 1)
    for j2 in range(1, k + 1):
        for j1 in range(j2):
            m = (j2 * (j2 + 1) - j1 * (j1 + 1)) // 2
            c = cost[j1] + (m + 24) * (tail(j1) + 32)
            if c < cost[j2]:
                cost[j2], prev[j2] = c, j1
    bounds = [k]
    while bounds[-1] > 0:
        bounds.append(prev[bounds[-1]])
    bounds.reverse()
    return list(zip(bounds[:-1], bounds[1:], strict=True))


class QuadraticGram:
    """Second moments of a quadratic expansion from its distinct fourth moments.

    The expansion ``q`` (``E = k + k(k+1)/2`` rows, see :mod:`sfa_gym.sfa.expansion` for the
    order) is given feature-major, ``(E, n)``. :meth:`products` returns float32 partial products
    (their sum over chunks is accumulated by the caller, in float64); :meth:`assemble` turns the
    summed products into the full ``(E, E)`` matrix ``sum_n w_n q_n q_n^T``.

    Products: ``y q^T`` (the rows of the linear terms), and per group of :func:`pair_groups`
    the pairs ``(i, j)`` of the group times the pairs ``(l, m)``, ``l >= j1`` (a contiguous tail
    of ``q``). Entry ``(a, b), (c, d)`` of the result is the fourth moment of the sorted indices
    ``w <= x <= y <= z``, found in the group of ``x`` at row ``(w, x)`` and column ``(y, z)``.
    """

    def __init__(self, k: int) -> None:
        self.k = k = int(k)
        e = k + k * (k + 1) // 2  # the expansion's dimension (expansion.n_quadratic_features)
        self.n_features = e
        start = np.zeros(k + 1, dtype=np.intp)  # row of pair (i, i) is k + start[i]
        for i in range(k):
            start[i + 1] = start[i] + k - i

        def row(i: int, j: int) -> int:
            return k + int(start[i]) + j - i

        self.groups: list[tuple[NDArray[np.intp], int]] = []
        sizes = [k * e]
        # for the pair (w, x) of the first two sorted indices: its product's flat offset, its
        # row there, and the first column (pair row) of that product
        base = np.zeros((k, k), dtype=np.intp)
        first_col = np.zeros((k, k), dtype=np.intp)
        offset = k * e
        for j1, j2 in pair_groups(k):
            pairs = [(i, j) for j in range(j1, j2) for i in range(j + 1)]
            tail = row(j1, j1)
            self.groups.append((np.array([row(i, j) for i, j in pairs], dtype=np.intp), tail))
            n_cols = e - tail
            for r, (i, j) in enumerate(pairs):
                base[i, j] = offset + r * n_cols
                first_col[i, j] = tail
            sizes.append(len(pairs) * n_cols)
            offset += sizes[-1]
        self.sizes = sizes
        # flat index of every entry of the (E, E) result in the concatenated products
        index = np.empty((e, e), dtype=np.intp)
        index[:k] = np.arange(k * e).reshape(k, e)
        index[:, :k] = index[:k].T
        iu, ju = np.triu_indices(k)
        quad = np.sort(
            np.stack(np.broadcast_arrays(iu[:, None], ju[:, None], iu[None], ju[None]), -1), -1
        )
        w, x, y, z = (quad[..., c] for c in range(4))
        pair_row = k + start[y] + z - y
        index[k:, k:] = base[w, x] + pair_row - first_col[w, x]
        self.index = index

    def products(
        self, q: NDArray[np.floating], w: NDArray[np.floating] | None = None
    ) -> list[NDArray[np.floating]]:
        """Partial products of ``q`` ``(E, n)`` with sample weights ``w`` ``(n,)`` (or None)."""
        k = self.k
        y = q[:k] if w is None else q[:k] * w
        out = [y @ q.T]
        for rows, tail in self.groups:
            a = np.take(q, rows, axis=0)
            if w is not None:
                a *= w
            out.append(a @ q[tail:].T)
        return out

    def zeros(self) -> list[NDArray[np.float64]]:
        """Float64 accumulators matching :meth:`products`."""
        return [np.zeros(size) for size in self.sizes]

    def assemble(self, sums: list[NDArray[np.float64]]) -> NDArray[np.float64]:
        """The ``(E, E)`` moment matrix from the summed products."""
        return np.concatenate([s.ravel() for s in sums])[self.index]


_AVX512_CORES = ("skylakex", "cooperlake", "sapphirerapids")


def fourth_moments_pay_off() -> bool:
    """Whether :class:`QuadraticGram` is faster than a symmetric rank-k update on this BLAS.

    Its smaller products run at a lower rate than one large ``syrk``. Measured here on the
    expanded pass of a 32-dimensional node (one core): with OpenBLAS's AVX2 kernels (``Haswell``,
    also chosen on AVX2-only CPUs) the fourth moments are 15 % faster; with its AVX-512 kernels
    the ``syrk`` is 4 % faster. Unknown BLAS libraries get the ``syrk``.
    """
    from sfa_gym.sfa._parallel import blas_corename

    name = blas_corename()
    return name is not None and name.lower() not in _AVX512_CORES


_QUADRATIC_GRAMS: dict[int, QuadraticGram] = {}


def quadratic_gram(k: int) -> QuadraticGram:
    """The (cached) :class:`QuadraticGram` for ``k``-dimensional data."""
    got = _QUADRATIC_GRAMS.get(k)
    if got is None:
        got = _QUADRATIC_GRAMS[k] = QuadraticGram(k)
    return got
