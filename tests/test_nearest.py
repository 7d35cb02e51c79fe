"""The bounded nearest-neighbour search returns what an exhaustive search returns."""

from __future__ import annotations

import numpy as np
import pytest

from sfa_gym.localization import nearest
from sfa_gym.localization.nearest import BoundedNeighbors


def _exhaustive(train, queries, k):
    """Every distance summed directly; by distance, then index."""
    squared = np.array([np.sum((train - q) ** 2, axis=1) for q in queries])
    order = np.array([np.lexsort((np.arange(len(train)), row))[:k] for row in squared])
    return np.sqrt(np.take_along_axis(squared, order, axis=1)), order


def _clustered(n, k, rng, n_clusters=30):
    """Samples around a few centres in k dimensions: near neighbours are close, as for views."""
    centres = rng.normal(size=(n_clusters, k)) * 3
    return centres[rng.integers(n_clusters, size=n)] + 0.3 * rng.normal(size=(n, k))


@pytest.fixture(params=["bounds", "brute force"])
def search(request, monkeypatch):
    """Both ways of the search: groups and bounds (made to pay at these small sizes), and
    scikit-learn's brute force with the exact rule on top."""
    if request.param == "bounds":
        monkeypatch.setattr(nearest, "MIN_SAMPLES_FOR_BOUNDS", 0)
        monkeypatch.setattr(nearest, "BOUNDS_PAY_BELOW", 1.0)
    return request.param


@pytest.mark.parametrize(("n", "k", "n_neighbors"), [(3000, 120, 3), (700, 60, 5), (40, 8, 1)])
def test_bounded_search_equals_the_exhaustive_one(search, n, k, n_neighbors):
    rng = np.random.default_rng(n)
    train = _clustered(n, k, rng)
    queries = np.concatenate([_clustered(200, k, rng), rng.normal(size=(20, k)) * 10])
    distances, indices = BoundedNeighbors(train, n_neighbors).kneighbors(queries)
    want_distances, want_indices = _exhaustive(train, queries, n_neighbors)
    np.testing.assert_array_equal(indices, want_indices)
    np.testing.assert_array_equal(distances, want_distances)


def test_ties_go_to_the_lower_index_and_every_sample_can_be_asked_for(search):
    rng = np.random.default_rng(1)
    base = _clustered(300, 50, rng)
    train = np.concatenate([base, base[::-1]])  # every sample twice
    queries = base[:40] + 1e-3 * rng.normal(size=(40, 50))
    _, indices = BoundedNeighbors(train, 4).kneighbors(queries)
    np.testing.assert_array_equal(indices, _exhaustive(train, queries, 4)[1])
    # the copies are equally near: the lower index of each pair comes first
    assert (indices[:, 0] < indices[:, 1]).all()
    np.testing.assert_array_equal(train[indices[:, 0]], train[indices[:, 1]])
    # as many neighbours as samples: all of them, in order of distance
    everything = BoundedNeighbors(train[:25], 25).kneighbors(queries)[1]
    np.testing.assert_array_equal(everything, _exhaustive(train[:25], queries, 25)[1])


def test_the_grouping_changes_nothing(monkeypatch):
    """Groups decide only how much is skipped: one group (a search through every sample), many
    small groups and no groups at all (every distance expanded) find the same neighbours."""
    rng = np.random.default_rng(2)
    train, queries = _clustered(2000, 90, rng), _clustered(300, 90, rng)
    default = BoundedNeighbors(train, 3).kneighbors(queries)
    monkeypatch.setattr(nearest, "MIN_SAMPLES_FOR_BOUNDS", 0)
    # the last: every block by brute force, as when bounds do not pay
    for per_group, axes, share in ((len(train), 2, 1.0), (8, 90, 1.0), (40, 1, 1.0), (40, 8, 0)):
        monkeypatch.setattr(nearest, "SAMPLES_PER_GROUP", per_group)
        monkeypatch.setattr(nearest, "CODE_AXES", axes)
        monkeypatch.setattr(nearest, "QUERY_BLOCK", 37)
        monkeypatch.setattr(nearest, "BOUNDS_PAY_BELOW", share)
        other = BoundedNeighbors(train, 3).kneighbors(queries)
        np.testing.assert_array_equal(other[1], default[1])
        np.testing.assert_array_equal(other[0], default[0])


def test_bad_shapes_are_named():
    with pytest.raises(ValueError, match="n_neighbors = 5"):
        BoundedNeighbors(np.zeros((3, 4)), 5)
    search = BoundedNeighbors(np.random.default_rng(0).normal(size=(20, 4)), 2)
    with pytest.raises(ValueError, match=r"shape \(M, 4\)"):
        search.kneighbors(np.zeros((2, 5)))
