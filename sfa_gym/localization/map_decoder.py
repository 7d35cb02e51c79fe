"""The map decoder: position by inverting a smooth map of each feature over the plane (see
:class:`MapDecoder`), one of the regressions of :mod:`sfa_gym.localization.regression`."""

from __future__ import annotations

import numbers
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sfa_gym._checks import check_int_in
from sfa_gym.localization._estimator import _Base

__all__ = ["MapDecoder"]


def _cosine_basis(
    positions: NDArray[np.float64],
    low: NDArray[np.float64],
    high: NDArray[np.float64],
    degree: int,
) -> NDArray[np.float64]:
    """``cos(i pi u) cos(j pi v)`` for ``i + j <= degree`` (``cos(i pi u)``, ``i <= degree``, on
    a line), ``(u, v)`` = ``positions (N, m)`` scaled to ``[0, 1]`` over the box ``low..high``:
    the smooth functions of a rectangle (the slowest features of a uniform random walk in a box
    are the first of them). Column 0 is the constant."""
    u = (positions - low) / (high - low)
    cu = np.cos(np.pi * np.arange(degree + 1)[None, :] * u[:, :1])
    if positions.shape[1] == 1:
        return cu
    cv = np.cos(np.pi * np.arange(degree + 1)[None, :] * u[:, 1:2])
    return np.stack(
        [cu[:, i] * cv[:, j] for i in range(degree + 1) for j in range(degree + 1 - i)], axis=1
    )


def _bending(degree: int, dims: int) -> NDArray[np.float64]:
    """``(i^2 + j^2)^2`` for each function of :func:`_cosine_basis` (``i^4`` on a line): its
    squared Laplacian integrated over the box, up to a factor common to all of them."""
    i = np.arange(degree + 1, dtype=np.float64)
    if dims == 1:
        return i**4
    return np.array([(a * a + b * b) ** 2 for a in i for b in i[: degree + 1 - int(a)]])


def _penalised_map(
    gram: NDArray[np.float64],
    cross: NDArray[np.float64],
    bending: NDArray[np.float64],
    smoothness: float,
) -> NDArray[np.float64]:
    """Coefficients ``(n_basis, k)`` minimising the mean squared residual plus the bending
    penalty, from the mean products ``gram = B'B / n`` and ``cross = B'X / n``."""
    # A tiny ridge keeps the fit defined where the positions do not pin down every basis
    # function (few positions, or positions along a few lines); the constant stays free.
    penalty = smoothness * bending + 1e-8 * (bending > 0)
    return np.linalg.solve(gram + np.diag(penalty), cross)


def _blocks(
    y: NDArray[np.float64], low: NDArray[np.float64], high: NDArray[np.float64], blocks: int
) -> NDArray[np.intp]:
    """The cross-validation block of each position: the box cut into ``blocks`` per axis."""
    cell = np.minimum(((y - low) / (high - low) * blocks).astype(np.intp), blocks - 1)
    return np.ravel_multi_index(tuple(cell.T), (blocks,) * y.shape[1])


@dataclass(frozen=True)
class _Sums:
    """The sums of products of some samples' basis ``B`` and features ``X``: a least-squares
    map and its residuals come from them alone, and the sums of all blocks but one are the
    total minus that block's."""

    n: int
    gram: NDArray[np.float64]  # B'B
    cross: NDArray[np.float64]  # B'X
    squares: NDArray[np.float64]  # X'X per feature

    @classmethod
    def of(cls, basis: NDArray[np.float64], x: NDArray[np.float64]) -> _Sums:
        return cls(len(x), basis.T @ basis, basis.T @ x, (x * x).sum(axis=0))

    def __sub__(self, other: _Sums) -> _Sums:
        return _Sums(
            self.n - other.n,
            self.gram - other.gram,
            self.cross - other.cross,
            self.squares - other.squares,
        )

    def fit(self, bending: NDArray[np.float64], smoothness: float) -> tuple[NDArray, NDArray]:
        """The penalised map's coefficients ``(n_basis, k)`` and its residual variances."""
        coef = _penalised_map(self.gram / self.n, self.cross / self.n, bending, smoothness)
        residual = self.squares - 2 * (coef * self.cross).sum(axis=0)
        residual += (coef * (self.gram @ coef)).sum(axis=0)
        return coef, np.maximum(residual, 0.0) / self.n


def _grid(axes: list[NDArray[np.float64]]) -> NDArray[np.float64]:
    """All points ``(prod of lengths, m)`` of the grid spanned by ``m`` axes."""
    return np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, len(axes))


class MapDecoder(_Base):
    """Position by inverting a smooth map of each feature over the plane.

    Instead of regressing position on the features, ``fit`` learns the forward map: each
    feature as a smooth function of position (a least-squares fit of the cosine basis
    ``cos(i pi u) cos(j pi v)``, ``i + j <= degree``, over the bounding box of the training
    positions), and the variance of each feature around its map. ``predict`` returns the
    position whose mapped features are nearest to the observed ones (squared distance weighted
    by the inverse variances: the maximum-likelihood position under independent Gaussian
    noise), searched on a coarse grid over the box and refined on a fine grid around the best
    cell. Slow features of a box-shaped arena look like the basis functions themselves
    (cosines along the axes and their products), whose inverse no low-order regression of
    position on features represents well near the walls; the forward map has few parameters
    per feature, so it needs few labelled positions.

    *Smoothness*: the fit penalises ``smoothness * sum (i^2 + j^2)^2 c_ij^2`` (per unit of mean
    squared residual), which is, up to a constant factor, the integral of the squared Laplacian
    of the map over the box: a bending energy. Where training positions pin the map down it
    changes little; where none lie (a region the training run never visited, the gaps between
    the lanes of a path) the map becomes the least bent surface that joins its surroundings,
    instead of whatever the highest cosines happen to do there. ``"auto"`` chooses the penalty
    by spatial block cross-validation: the box is cut into ``cv_blocks`` x ``cv_blocks`` blocks,
    each block is held out in turn, and the penalty of :attr:`SMOOTHNESS_GRID` whose maps,
    fitted on the other blocks, decode the held-out positions best (mean absolute error on the
    coarse search grid, over at most :attr:`CV_SAMPLES` held-out samples) wins. Holding out
    whole blocks, not scattered samples, asks how well the map reaches into places it has not
    seen; scoring decoded positions, not feature residuals, keeps a block that no map fits well
    (a corner by the walls) from ruling the choice.

    Estimates lie inside the box of the training positions. Targets are 2-D positions
    ``(N, 2)``, or positions on a line (``(N, 1)`` or ``(N,)``, basis ``cos(i pi u)``).

    Args:
        degree: highest total degree ``i + j`` of the cosine basis (``(degree+1)(degree+2)/2``
            coefficients per feature in the plane).
        grid: coarse search grid points per axis; the fine search divides one coarse cell into
            4 steps each way around the best point.
        smoothness: the bending penalty (a number >= 0; 0: plain least squares), or ``"auto"``
            to choose it by spatial block cross-validation.
        cv_blocks: blocks per axis of the cross-validation (``"auto"`` only).

    Attributes:
        coef_: (n_basis - 1, k) float64, intercept_: (k,) float64. The map from the non-constant
            basis functions to the features.
        weights_: (k,) float64. Inverse variance of each feature around its map.
        low_, high_: (m,) float64. The box of the training positions, metres.
        smoothness_: float. The penalty used (the chosen one with ``"auto"``).
        cv_errors_: dict[float, float]. With ``"auto"``: for each penalty tried, the mean
            absolute error, m, of the held-out blocks' positions decoded on the coarse grid.
        n_features_in_: int.
    """

    SMOOTHNESS_GRID = (0.0, 1e-6, 1e-5, 1e-4, 3e-4, 1e-3, 3e-3, 1e-2, 1e-1)
    """The penalties ``"auto"`` chooses from: none, then from one that bends the maps of a
    densely sampled arena by less than the feature noise to one that leaves little more than the
    lowest cosines."""

    CV_SAMPLES = 600
    """held-out samples decoded per penalty, spread evenly over all blocks (enough to rank the
    penalties; it bounds the cost on long runs)"""

    def __init__(
        self,
        degree: int = 6,
        grid: int = 61,
        smoothness: float | Literal["auto"] = "auto",
        cv_blocks: int = 3,
    ) -> None:
        self.degree = degree
        self.grid = grid
        self.smoothness = smoothness
        self.cv_blocks = cv_blocks

    def fit(self, X: ArrayLike, y: ArrayLike) -> MapDecoder:
        """Fit on features ``X (N, k)`` and positions ``y (N, 2)`` (or ``(N, 1)``, ``(N,)``)."""
        for name, low in (("degree", 1), ("grid", 5), ("cv_blocks", 2)):
            check_int_in(name, getattr(self, name), low)
        smoothness = self.smoothness
        if smoothness != "auto" and (
            isinstance(smoothness, bool)
            or not isinstance(smoothness, numbers.Real)
            or not np.isfinite(smoothness)
            or smoothness < 0
        ):
            raise ValueError(f"smoothness must be a number >= 0 or 'auto', got {smoothness!r}")
        x, y = self._validate_fit(X, y)
        y = y.reshape(len(y), -1)
        if y.shape[1] > 2:
            raise ValueError(
                f"MapDecoder decodes 2-D positions (or positions on a line), got targets of shape "
                f"{y.shape}"
            )
        if len(y) < 2:
            raise ValueError(f"MapDecoder needs positions spread over an area, got {len(y)} sample")
        low, high = y.min(axis=0), y.max(axis=0)
        if np.any(high <= low):
            raise ValueError(
                f"the training positions span no area (range {high - low} m); MapDecoder needs "
                "positions spread over every axis"
            )
        self.low_, self.high_ = low, high
        basis = _cosine_basis(y, low, high, self.degree)
        bending = _bending(self.degree, y.shape[1])
        # the floor keeps a perfectly explained feature from dominating through round-off
        floor = 1e-6 * x.var(axis=0).max() + 1e-300
        total = _Sums.of(basis, x)
        if smoothness == "auto":
            self.cv_errors_ = self._block_cv(basis, x, y, total, bending, floor)
            smoothness = min(self.cv_errors_, key=self.cv_errors_.__getitem__)
        self.smoothness_ = float(smoothness)
        self._set_map(*total.fit(bending, self.smoothness_), floor)
        return self

    def _set_map(self, coef: NDArray, variance: NDArray, floor: float) -> None:
        # Features that the map explains worse count less.
        self.coef_, self.intercept_ = coef[1:], coef[0]
        self.weights_ = 1.0 / np.maximum(variance, floor)

    def _block_cv(
        self,
        basis: NDArray[np.float64],
        x: NDArray[np.float64],
        y: NDArray[np.float64],
        total: _Sums,
        bending: NDArray[np.float64],
        floor: float,
    ) -> dict[float, float]:
        """Mean absolute error, m, of the held-out blocks' positions decoded on the coarse
        grid, for each penalty of :attr:`SMOOTHNESS_GRID`; ``total``: the sums of all samples."""
        fold = _blocks(y, self.low_, self.high_, self.cv_blocks)
        every = max(1, -(-len(x) // self.CV_SAMPLES))
        blocks = {f: _Sums.of(basis[fold == f], x[fold == f]) for f in np.unique(fold)}
        errors = dict.fromkeys(map(float, self.SMOOTHNESS_GRID), 0.0)
        held_out = MapDecoder(self.degree, self.grid)
        held_out.low_, held_out.high_ = self.low_, self.high_
        coarse = self._coarse_grid()  # the same box for every fold: its basis is computed once
        scored = 0
        for f, block in blocks.items():
            if block.n == total.n:
                continue  # the positions fill one block: nothing to fit the others on
            rows = np.flatnonzero(fold == f)[::every]
            for smoothness in errors:
                held_out._set_map(*(total - block).fit(bending, smoothness), floor)
                decoded = held_out._decode(x[rows], refine=False, coarse=coarse)
                errors[smoothness] += float(np.abs(decoded - y[rows]).sum())
            scored += rows.size * y.shape[1]
        return {s: e / max(scored, 1) for s, e in errors.items()}

    def _mapped(self, positions: NDArray[np.float64]) -> NDArray[np.float64]:
        return self._map_basis(_cosine_basis(positions, self.low_, self.high_, self.degree))

    def _map_basis(self, basis: NDArray[np.float64]) -> NDArray[np.float64]:
        """The mapped features at points whose cosine basis (constant included) is ``basis``."""
        return basis[:, 1:] @ self.coef_ + self.intercept_

    def _coarse_grid(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The coarse search grid over the box, ``(grid^m, m)``, and its cosine basis."""
        box = zip(self.low_, self.high_, strict=True)
        points = _grid([np.linspace(lo, hi, self.grid) for lo, hi in box])
        return points, _cosine_basis(points, self.low_, self.high_, self.degree)

    def predict(self, X: ArrayLike) -> NDArray[np.float64]:
        """Positions ``(N, m)`` (``(N,)`` if fitted on 1-D targets) for features ``X (N, k)``."""
        return self._as_targets(self._decode(self._validate_predict(X)))

    def _decode(
        self,
        x: NDArray[np.float64],
        refine: bool = True,
        coarse: tuple[NDArray[np.float64], NDArray[np.float64]] | None = None,
    ) -> NDArray[np.float64]:
        """The best-matching positions ``(N, m)`` for validated features ``x (N, k)``, on the
        coarse grid only unless ``refine``; ``coarse``: :meth:`_coarse_grid`, if already at
        hand."""
        w = np.sqrt(self.weights_)
        m = len(self.low_)
        coarse, coarse_basis = self._coarse_grid() if coarse is None else coarse
        # The coarse grid's features, mapped once: every row is scored against all of them
        # with one matrix product (the squared norm of a row does not change its argmin).
        coarse_mapped = self._map_basis(coarse_basis) * w
        coarse_norms = (coarse_mapped**2).sum(axis=1)
        cell = (self.high_ - self.low_) / (self.grid - 1)
        fine = _grid([np.linspace(-1.0, 1.0, 2 * 4 + 1)] * m)
        out = np.empty((len(x), m))
        for i0 in range(0, len(x), 1024):  # bounds the (rows x candidates) score matrix
            part = x[i0 : i0 + 1024]
            score = coarse_norms[None, :] - 2.0 * (part * w) @ coarse_mapped.T
            best = coarse[score.argmin(axis=1)]
            if not refine:
                out[i0 : i0 + 1024] = best
                continue
            local = np.clip(best[:, None, :] + fine[None] * cell, self.low_, self.high_)
            n, c, _ = local.shape
            mapped = self._mapped(local.reshape(n * c, m)).reshape(n, c, -1)
            nearest = (((mapped - part[:, None, :]) * w) ** 2).sum(axis=2).argmin(axis=1)
            out[i0 : i0 + 1024] = local[np.arange(n), nearest]
        return out
