"""Features formed in the layout the statistics read (the rotation shortcut's group order):
no copy before the products, and the same model to the bit as with the copies."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from test_sfa_heap import assert_same_layers

import sfa_gym.sfa._sources as sources
from eval.benchmarks.bench_sfa_layouts import previous_layouts
from eval.synthetic import synthetic_panoramas
from sfa_gym.sfa import HierarchicalSFA, RankDeficiencyWarning, presets
from sfa_gym.sfa._layers import Affine, layer_patches


def _fit(panoramas: np.ndarray, sharing: str) -> HierarchicalSFA:
    # batches of 5 locations: several chunks, so the differences across chunks are exercised
    model = HierarchicalSFA(
        presets.tiny(height=12, width=40), n_outputs=4, weight_sharing=sharing,
        progress=False, n_jobs=1, batch_size=5,
    )  # fmt: skip
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RankDeficiencyWarning)
        return model.fit_rotations(panoramas, step=2)


@pytest.mark.parametrize("sharing", ["layer", "rows"])
def test_group_order_changes_no_bit_of_the_model(sharing):
    panoramas = synthetic_panoramas(17, 12, 40, seed=3, n_keyframes=5)
    ordered = _fit(panoramas, sharing)

    # the code before: the features in their natural layout, groups() copying them before
    # every product, each row's node inputs copied twice
    with previous_layouts():
        plain = _fit(panoramas, sharing)
    assert_same_layers(ordered, plain)


@pytest.mark.parametrize("sharing", ["layer", "rows"])
def test_features_in_group_order_are_grouped_without_a_copy(sharing):
    rng = np.random.default_rng(0)
    inputs = rng.standard_normal((6, 3, 20, 8)).astype(np.float32)  # (n, R, C, F)
    identity = Affine(np.eye(8), np.zeros(8), np.zeros(8))
    expanded = sources.reduce_and_expand(identity, inputs, sharing)
    grouped = sources.groups(expanded, sharing)
    assert np.shares_memory(grouped, expanded), "groups() copied the expansion"
    assert grouped.flags.c_contiguous
    features = sources.features_first(inputs, sharing)
    assert np.shares_memory(sources.groups(features, sharing), features)
    # the values are those of the plain layout
    np.testing.assert_array_equal(
        sources.features_first(inputs, sharing), np.moveaxis(inputs, -1, 0)
    )


def test_a_view_that_groups_in_place_is_left_as_it_is():
    # one node per layer: the feature-major view of node inputs merges its sample axes in
    # place, and the products read it as it is (another layout would change their round-off)
    inputs = np.zeros((6, 3, 20, 8), dtype=np.float32)
    features = sources.features_first(inputs, "layer")
    assert np.shares_memory(features, inputs)
    assert not sources.groups_copy(features, "layer")
    assert sources.groups_copy(np.moveaxis(inputs, -1, 0), "rows")


def test_a_row_shared_layer_reads_each_row_of_the_patch_view_as_its_node_inputs():
    panoramas = synthetic_panoramas(17, 12, 40, seed=3, n_keyframes=5)
    model = _fit(panoramas, "rows")
    a = panoramas[:4].astype(np.float32)
    for p in model.layer_params_:
        assert p.reduce.row_shared
        # every node's output from the layer's materialised node inputs, and from the view
        whole = p.nodes(layer_patches(p.spec, p.grid, a), clip=None)
        np.testing.assert_array_equal(p.forward(a, clip=None), whole)
        a = whole
