"""The slowest functions of a training walk's graph (WalkGraphEmbedding), the features built on
them (EmbeddedFeatures), and the navigation protocol's walk order end to end."""

from __future__ import annotations

import json
import warnings

import numpy as np
import pytest

from sfa_gym.features import EmbeddedFeatures, rotation_averaged_features
from sfa_gym.recording.ordering import edge_walk
from sfa_gym.sfa.graph import WalkGraphEmbedding


def _room_with_a_wall(n: int = 12, wall: int = 9):
    """Cells of an n x n room with a wall from the bottom up ``wall`` cells, between the
    columns n/2 - 1 and n/2 (removed cells: the wall's column), and the edge walk over them."""
    i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    cells = np.stack([i.ravel(), j.ravel()], axis=1)
    cells = cells[~((cells[:, 1] == n // 2) & (cells[:, 0] < wall))]
    return cells, edge_walk(cells)


def _biharmonic(emb, features, a, b):
    w = emb.eigenvalues_**-2.0
    return float(np.sqrt(np.sum(w * (features[a] - features[b]) ** 2)))


def test_the_walks_slowest_functions_go_around_a_wall():
    # input features = the cells' coordinates: recognition is perfect, the graph is the point
    cells, walk = _room_with_a_wall()
    x = cells.astype(float)
    emb = WalkGraphEmbedding(n_components=6).fit(x, walk)
    f = emb.embedding_
    index = {tuple(c): k for k, c in enumerate(cells.tolist())}
    # two cells two columns apart across the wall (near its foot, far from its end), and two
    # cells two columns apart on the same side
    across = _biharmonic(emb, f, index[(1, 5)], index[(1, 7)])
    along = _biharmonic(emb, f, index[(1, 2)], index[(1, 4)])
    assert across > 3 * along
    # the Euclidean-like embedding a Hilbert order would give: without the wall in the graph
    # (a walk over the full room), the two distances are about equal
    i, j = np.meshgrid(np.arange(12), np.arange(12), indexing="ij")
    full = np.stack([i.ravel(), j.ravel()], axis=1)
    open_emb = WalkGraphEmbedding(n_components=6).fit(full.astype(float), edge_walk(full))
    g = open_emb.embedding_
    at = {tuple(c): k for k, c in enumerate(full.tolist())}
    ratio = _biharmonic(open_emb, g, at[(1, 5)], at[(1, 7)]) / _biharmonic(
        open_emb, g, at[(1, 2)], at[(1, 4)]
    )
    assert 0.5 < ratio < 2


def test_embedding_is_normalised_ordered_deterministic_and_reads_between_places():
    cells, walk = _room_with_a_wall()
    x = cells.astype(float)
    emb = WalkGraphEmbedding(n_components=4).fit(x, walk)
    again = WalkGraphEmbedding(n_components=4).fit(x, walk)
    np.testing.assert_array_equal(emb.embedding_, again.embedding_)
    assert np.all(np.diff(emb.eigenvalues_) >= 0) and emb.eigenvalues_[0] > 0
    along_walk = emb.embedding_[walk]
    # (the walk visits each place as often as it has neighbours, its start once more)
    np.testing.assert_allclose(along_walk.mean(axis=0), 0, atol=0.01)
    np.testing.assert_allclose(along_walk.var(axis=0), 1, rtol=0.01)
    # delta value along the walk (mean squared difference) is 2 lambda
    delta = np.mean(np.diff(along_walk, axis=0) ** 2, axis=0)
    np.testing.assert_allclose(delta, 2 * emb.eigenvalues_, rtol=1e-6)
    # at the training places the locally linear read-out follows the functions (smoothed over
    # its neighbours, and by the wall blending in places across it, alike in these features);
    # half way between two neighbouring places it lies between their values
    read = emb.transform(x)
    for k in range(4):
        assert np.corrcoef(read[:, k], emb.embedding_[:, k])[0, 1] > 0.99
    a, b = (0, 0), (0, 1)
    k = [int(np.flatnonzero((cells == c).all(axis=1))[0]) for c in (a, b)]
    middle = emb.transform([[0.0, 0.5]])[0]
    lo = np.minimum(emb.embedding_[k[0]], emb.embedding_[k[1]])
    hi = np.maximum(emb.embedding_[k[0]], emb.embedding_[k[1]])
    assert np.all((middle > lo - 1e-6) & (middle < hi + 1e-6))


@pytest.mark.parametrize(
    ("kwargs", "visits", "message"),
    [
        ({"n_components": 0}, None, "n_components must be a positive int, got 0"),
        ({"bandwidth": -1.0}, None, "bandwidth must be a positive number, got -1.0"),
        ({"ridge": 0}, None, "ridge must be a positive number, got 0"),
        ({}, [0, 1, 2, 99], "visits must index the 5 places of X, got values 0..99"),
        ({}, [0.0, 1.0], "visits must be a 1-d integer array"),
        ({}, [0, 1, 2, 1, 0], r"never moves to or from 2 of the 5 places of X \(place 3 first\)"),
        ({}, [0, 1, 0, 2, 3, 4, 3], None),
    ],
)
def test_embedding_refuses_bad_input(kwargs, visits, message):
    x = np.arange(10.0).reshape(5, 2)
    emb = WalkGraphEmbedding(**{"n_components": 2, **kwargs})
    visits = [0, 1, 2, 3, 4, 3, 2, 1, 0] if visits is None else visits
    if message is None:
        emb.fit(x, visits)  # a tree-shaped walk is fine
        with pytest.raises(ValueError, match=r"X must have shape \(n, 2\)"):
            emb.transform(np.zeros((1, 3)))
        return
    with pytest.raises(ValueError, match=message):
        emb.fit(x, visits)


class _MeanColour:
    input_shape_ = (4, 8, 3)

    def transform(self, views):
        return views.reshape(len(views), -1, 3).mean(axis=1)


def test_embedded_features_embed_the_base_models_rotation_averages():
    rng = np.random.default_rng(0)
    panoramas = rng.integers(0, 256, size=(12, 4, 8, 3), dtype=np.uint8)
    base = _MeanColour()
    averages = rotation_averaged_features(base, panoramas, step=2)
    walk = np.array([*range(12), *range(10, -1, -1)])
    emb = WalkGraphEmbedding(n_components=2, n_neighbors=5).fit(averages, walk)
    model = EmbeddedFeatures(base, emb, "colour_graph")
    assert model.input_shape_ == (4, 8, 3)
    got = rotation_averaged_features(model, panoramas, step=2)
    np.testing.assert_array_equal(got, emb.transform(averages))
    views = panoramas[:3]
    np.testing.assert_array_equal(model.transform(views), emb.transform(base.transform(views)))


def test_navigate_with_a_walk_runs_the_graph_features_beside_sfa(tmp_path):
    # the maze at a tiny size: a 10 x 10 training grid walked without crossing the walls
    from sfa_gym.cli.navigate import NavigationExperiment, run_navigation_experiment
    from sfa_gym.protocols.settings import SFASettings

    config = NavigationExperiment(
        env_id="sfa_gym/OmniRoverNavMaze-v0",
        train_grid=10,
        train_order="walk",
        field_spacing=0.5,
        episodes=2,
        controllers=("gradient",),
        sfa=SFASettings(node_dim=8, n_outputs=4),
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # rank deficiency of the small network
        results = run_navigation_experiment(config, tmp_path, progress=False)
    assert set(results["controllers"]) == {"gradient/sfa", "gradient/sfa_graph"}
    assert results["training_visits"] > 3 * results["training_positions"]
    saved = json.loads((tmp_path / "results.json").read_text())
    assert saved["settings"]["train_order"] == "walk"
    for name in ("sfa", "sfa_graph"):
        assert (tmp_path / f"field_{name}.npz").exists()
        assert (tmp_path / f"paths_gradient_{name}.png").exists()
    with pytest.raises(ValueError, match="train_order must be one of"):
        NavigationExperiment(train_order="spiral").validate()
