"""Exact k-nearest-neighbour search (Euclidean) that skips most distances by lower bounds.

Brute force compares every query with every training sample over all features: for raw pixels
on the outdoor appearance track (141,600 training views, 336,000 test views, 420 features) that
is most of a task's time. Here each sample gets a short code: its coordinates on the training
set's first principal axes and, as one more coordinate, the length of what those axes leave out
(the residual). The distance between two codes is at most the distance between the samples (a
projection shrinks distances, and two residuals differ by at least the difference of their
lengths). The codes are grouped (k-means), and each group keeps its centre and radius, so

    |q - x| >= |code(q) - code(x)| >= |code(q) - centre| - radius

bounds the distance to every member of a group at once. A query first takes the exact distances
to the members of its nearest group, whose ``n_neighbors``-th is an upper bound ``U`` of its
``n_neighbors``-th nearest distance; then only groups whose bound is at most ``U``, and in them
only members whose code distance is at most ``U``, get an exact distance.

Where the groups would leave more than a tenth of the distances (few training samples, queries
far from all of them), scikit-learn's brute force finds a few more neighbours than asked by the
dot-product expansion, and the same rule picks among those within its round-off.

The result is that of an exhaustive search with each distance summed directly over the
differences (not by the dot-product expansion, which loses digits between close samples),
sorted by distance, then by index. The grouping only decides how much is skipped: no sample whose
distance could rank is skipped (every bound is loosened by more than its round-off), so the
neighbours do not depend on the grouping, the block size or the thread count.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from sklearn.neighbors import NearestNeighbors

__all__ = ["BoundedNeighbors"]

# Principal axes in a code: enough that codes of close samples are nearly as far apart as the
# samples, few enough that the bound products stay cheap.
CODE_AXES = 48

# Training samples per group on average (at most MAX_GROUPS groups): groups much larger than the
# neighbourhoods asked for bound loosely; many more cost more bound products per query.
SAMPLES_PER_GROUP = 128
MAX_GROUPS = 1024
# The groups are placed by k-means on every few samples only (this many per group), then every
# sample joins its nearest centre: good enough for bounds, and a fraction of the cost.
KMEANS_SAMPLES_PER_GROUP = 16
KMEANS_ITERATIONS = 8
# Members of a query's nearest group whose exact distances give its upper bound: those with the
# smallest code distances, this many per neighbour asked.
UPPER_CANDIDATES = 4

# Below this many training samples every distance is computed (scikit-learn's brute force, see
# below): a few seconds at most, less than placing the groups.
MIN_SAMPLES_FOR_BOUNDS = 20_000

# Queries handled together: bounds to every group centre for a block stay a few MB.
QUERY_BLOCK = 1024

# When the groups leave more than this share of a block's (query, sample) pairs, bounds do not
# pay (few training samples, or queries far from all of them): scikit-learn's brute force then
# computes every distance of the block by the dot-product expansion, which is exact to a known
# round-off, and only the samples within that round-off of each query's n_neighbors-th get a
# distance summed directly.
BOUNDS_PAY_BELOW = 0.1
# Neighbours asked of scikit-learn beyond n_neighbors in that case: enough that a query's
# n_neighbors-th is almost always clear of the last by more than the round-off.
EXTRA_NEIGHBOURS = 8

# Loosening of every squared bound, relative to the squared code lengths involved. A code's last
# coordinate is the square root of a difference of two sums of a few hundred terms, which can be
# off by ~3e-7 of the code's length when the residual is small; this covers that with a margin,
# so round-off can add a candidate, never drop one.
_SLACK = 1e-5
# Relative loosening of the upper bound, an exact distance summed like every other.
_UPPER_SLACK = 1e-12


def _squared_distances(a: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.float64]:
    """``|a_i - b_j|^2`` by the dot-product expansion ``(len(a), len(b))``, for bounds only."""
    out = a @ b.T
    out *= -2.0
    out += np.einsum("ij,ij->i", a, a)[:, None]
    out += np.einsum("ij,ij->i", b, b)[None, :]
    return out


class BoundedNeighbors:
    """Exact ``n_neighbors`` nearest training samples of each query (see the module docstring).

    Args:
        train: training samples ``(N, k)``.
        n_neighbors: how many neighbours (``1 <= n_neighbors <= N``).
    """

    def __init__(self, train: NDArray[np.float64], n_neighbors: int) -> None:
        train = np.ascontiguousarray(train, dtype=np.float64)
        if train.ndim != 2 or not 1 <= n_neighbors <= len(train):
            raise ValueError(
                f"need training samples (N, k) with N >= n_neighbors = {n_neighbors}, got shape "
                f"{train.shape}"
            )
        self.train, self.n_neighbors = train, n_neighbors
        self._longest_train = float(np.max(np.einsum("ij,ij->i", train, train)))
        self._brute = None
        self.grouped = len(train) >= MIN_SAMPLES_FOR_BOUNDS
        if self.grouped:
            self._group(train)

    def _group(self, train: NDArray[np.float64]) -> None:
        """Codes, groups, centres and radii (module docstring)."""
        self.center = train.mean(axis=0)
        centred = train - self.center
        _, vectors = np.linalg.eigh(centred.T @ centred)  # ascending: take the last columns
        self.axes = np.ascontiguousarray(vectors[:, ::-1][:, :CODE_AXES])
        codes = self._codes(centred)
        n_groups = int(np.clip(len(train) // SAMPLES_PER_GROUP, 1, MAX_GROUPS))
        labels, centres = _kmeans(codes, n_groups)
        # members stored group by group, so a group's samples are one slice
        self.order = np.argsort(labels, kind="stable")
        self.bounds = np.searchsorted(labels[self.order], np.arange(n_groups + 1))
        self.codes = codes[self.order]
        self.centres = centres
        spread = np.sqrt(np.sum((codes - centres[labels]) ** 2, axis=1))
        self.radii = np.full(n_groups, -np.inf)
        np.maximum.at(self.radii, labels, spread)
        self.code_scale = float(np.max(np.sum(codes**2, axis=1)))

    def _codes(self, centred: NDArray[np.float64]) -> NDArray[np.float64]:
        """Coordinates on the axes, then the residual's length: ``(n, axes + 1)``."""
        coordinates = centred @ self.axes
        residual = np.einsum("ij,ij->i", centred, centred) - np.einsum(
            "ij,ij->i", coordinates, coordinates
        )
        return np.column_stack([coordinates, np.sqrt(np.maximum(residual, 0.0))])

    def kneighbors(
        self, queries: NDArray[np.float64]
    ) -> tuple[NDArray[np.float64], NDArray[np.intp]]:
        """Distances ``(M, n_neighbors)`` (ascending) and training indices of each query's
        nearest samples; ties in distance go to the lower index."""
        queries = np.ascontiguousarray(queries, dtype=np.float64)
        if queries.ndim != 2 or queries.shape[1] != self.train.shape[1]:
            raise ValueError(
                f"queries must have shape (M, {self.train.shape[1]}), got {queries.shape}"
            )
        k = self.n_neighbors
        distances = np.empty((len(queries), k))
        indices = np.empty((len(queries), k), dtype=np.intp)
        for start in range(0, len(queries), QUERY_BLOCK):
            rows = slice(start, start + QUERY_BLOCK)
            distances[rows], indices[rows] = self._block(queries[rows])
        return distances, indices

    def _block(self, queries: NDArray[np.float64]) -> tuple[NDArray, NDArray]:
        if not self.grouped:
            return self._finish(queries, *self._expanded_candidates(queries))
        codes = self._codes(queries - self.center)
        slack = _SLACK * (np.sum(codes**2, axis=1) + self.code_scale)
        to_centres = np.sqrt(np.maximum(_squared_distances(codes, self.centres), 0.0))
        # sqrt(x + e) differs from sqrt(x) by at most sqrt(|e|)
        to_centres -= np.sqrt(slack)[:, None]
        picked, estimate = self._pick(codes, to_centres.argmin(axis=1))
        # whether bounds pay, by the code distances (cheap; below the exact ones)
        sizes = np.diff(self.bounds)
        share = ((to_centres - self.radii <= estimate[:, None]) @ sizes).sum()
        if share > BOUNDS_PAY_BELOW * len(queries) * len(self.train):
            return self._finish(queries, *self._expanded_candidates(queries))
        # an upper bound of each query's n_neighbors-th distance: the n_neighbors-th exact
        # distance to its picked samples (distinct, and at least n_neighbors of them)
        rows = np.repeat(np.arange(len(queries)), picked.shape[1])
        exact = self._exact(queries, rows, picked.ravel())
        exact = exact.reshape(picked.shape)
        upper = np.sqrt(np.partition(exact, self.n_neighbors - 1, axis=1)[:, self.n_neighbors - 1])
        reach = upper * (1 + _UPPER_SLACK)
        passing = to_centres - self.radii <= reach[:, None]
        query_parts, sample_parts = [], []
        for group in np.flatnonzero(passing.any(axis=0)):
            asking = np.flatnonzero(passing[:, group])
            members = slice(self.bounds[group], self.bounds[group + 1])
            bound = _squared_distances(codes[asking], self.codes[members])
            bound -= slack[asking][:, None]
            near_query, near_member = np.nonzero(bound <= (reach[asking] ** 2)[:, None])
            query_parts.append(asking[near_query])
            sample_parts.append(self.order[members][near_member])
        return self._finish(queries, np.concatenate(query_parts), np.concatenate(sample_parts))

    def _expanded_candidates(self, queries: NDArray[np.float64]) -> tuple[NDArray, NDArray]:
        """The pairs whose distance by the dot-product expansion is within its round-off of the
        query's ``n_neighbors``-th: scikit-learn's brute-force search for a few more
        neighbours, and every distance of the queries whose last one is still that close."""
        k, n_train = self.n_neighbors, len(self.train)
        asked = min(n_train, k + EXTRA_NEIGHBOURS)
        if self._brute is None:
            self._brute = NearestNeighbors(n_neighbors=asked, algorithm="brute").fit(self.train)
        distances, found = self._brute.kneighbors(queries, asked)
        squared = distances**2
        lengths = np.einsum("ij,ij->i", queries, queries) + self._longest_train
        # the expansion's round-off is below (features + 2) units of round-off of the lengths;
        # the slack is a thousand times that, so round-off can add a candidate, never drop one
        slack = 1e3 * (self.train.shape[1] + 2) * np.finfo(np.float64).eps * lengths
        # a query is settled if all it was not given are farther than its k-th by the slack
        settled = (asked == n_train) | (squared[:, -1] > squared[:, k - 1] + 2 * slack)
        within = squared <= (squared[:, k - 1] + 2 * slack)[:, None]
        query, column = np.nonzero(within & settled[:, None])
        query_parts, sample_parts = [query], [found[query, column]]
        for q in np.flatnonzero(~settled):  # ties beyond the extra neighbours: rare
            expanded = _squared_distances(queries[q : q + 1], self.train)[0]
            near = np.flatnonzero(expanded <= squared[q, k - 1] + 3 * slack[q])
            query_parts.append(np.full(len(near), q))
            sample_parts.append(near)
        return np.concatenate(query_parts), np.concatenate(sample_parts)

    def _finish(
        self, queries: NDArray[np.float64], query: NDArray[np.intp], sample: NDArray[np.intp]
    ) -> tuple[NDArray, NDArray]:
        """The ``n_neighbors`` nearest of each query among its candidate pairs (which include
        them), by the distances summed directly, ties to the lower index."""
        exact = self._exact(queries, query, sample)
        order = np.lexsort((sample, exact, query))  # per query, by distance, then index
        query, sample, exact = query[order], sample[order], exact[order]
        take = np.searchsorted(query, np.arange(len(queries)))[:, None] + np.arange(
            self.n_neighbors
        )
        return np.sqrt(exact[take]), sample[take]

    def _pick(
        self, codes: NDArray[np.float64], nearest: NDArray[np.intp]
    ) -> tuple[NDArray[np.intp], NDArray[np.float64]]:
        """Per query, distinct samples ``(M, m)`` whose exact distances give its upper bound:
        the members of its nearest group with the smallest code distances (and other samples
        when the group is smaller), and the ``n_neighbors``-th of those code distances."""
        k = self.n_neighbors
        m = min(UPPER_CANDIDATES * k, len(self.train))
        picked = np.empty((len(codes), m), dtype=np.intp)
        estimate = np.zeros(len(codes))
        for group in np.unique(nearest):
            asking = np.flatnonzero(nearest == group)
            members = slice(self.bounds[group], self.bounds[group + 1])
            samples = self.order[members]
            if len(samples) >= m:
                close = _squared_distances(codes[asking], self.codes[members])
                chosen = np.argpartition(close, m - 1, axis=1)[:, :m]
                picked[asking] = samples[chosen]
                close = np.take_along_axis(close, chosen, axis=1)
                estimate[asking] = np.sqrt(np.maximum(np.sort(close, axis=1)[:, k - 1], 0.0))
            else:  # the whole group and other samples
                spare = np.setdiff1d(np.arange(len(samples) + m), samples)
                picked[asking] = np.concatenate([samples, spare[: m - len(samples)]])
        return picked, estimate

    def _exact(
        self, queries: NDArray[np.float64], query: NDArray[np.intp], sample: NDArray[np.intp]
    ) -> NDArray[np.float64]:
        """Squared distances of the pairs ``(queries[query[i]], train[sample[i]])``, each summed
        along its row (the same value for a pair whatever else is computed with it)."""
        out = np.empty(len(query))
        step = max(1, 2**23 // self.train.shape[1])
        for start in range(0, len(query), step):
            part = slice(start, start + step)
            difference = self.train[sample[part]] - queries[query[part]]
            out[part] = np.sum(difference * difference, axis=1)
        return out


def _kmeans(codes: NDArray[np.float64], n_groups: int) -> tuple[NDArray[np.intp], NDArray]:
    """Labels of every code and centres: a few Lloyd iterations on evenly spaced codes, from
    evenly spaced centres (a group that loses all its members keeps its centre)."""
    picked = np.linspace(0, len(codes) - 1, min(len(codes), KMEANS_SAMPLES_PER_GROUP * n_groups))
    sample = codes[picked.astype(np.intp)]
    centres = sample[np.linspace(0, len(sample) - 1, n_groups).astype(np.intp)].copy()
    for _ in range(KMEANS_ITERATIONS):
        labels = _nearest_centre(sample, centres)
        counts = np.bincount(labels, minlength=n_groups)
        filled = counts > 0
        for column in range(codes.shape[1]):
            sums = np.bincount(labels, weights=sample[:, column], minlength=n_groups)
            centres[filled, column] = sums[filled] / counts[filled]
    return _nearest_centre(codes, centres), centres


def _nearest_centre(codes: NDArray[np.float64], centres: NDArray[np.float64]) -> NDArray:
    labels = np.empty(len(codes), dtype=np.intp)
    for start in range(0, len(codes), 2**14):
        part = slice(start, start + 2**14)
        labels[part] = _squared_distances(codes[part], centres).argmin(axis=1)
    return labels
