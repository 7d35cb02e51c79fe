"""Hierarchical SFA: geometry, rotation shortcut vs brute force, invariants, errors."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from sklearn.exceptions import NotFittedError

from eval.synthetic import synthetic_panoramas
from sfa_gym.rotation import rotated_views
from sfa_gym.sfa import (
    HierarchicalSFA,
    LayerSpec,
    RankDeficiencyWarning,
    describe,
    layer_grids,
    load_model,
    presets,
    save_model,
    shortcut_applies,
)
from sfa_gym.sfa._layers import Affine, LayerParams

H, W = 10, 40


@pytest.fixture(autouse=True)
def _quiet_rank_warnings():
    # tiny networks on little data drop degenerate expanded directions; that is expected here
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RankDeficiencyWarning)
        yield


@pytest.fixture(scope="module")
def panoramas() -> np.ndarray:
    return synthetic_panoramas(12, H, W, seed=7, n_keyframes=5)


def _views(panoramas: np.ndarray, step: int, window: int | None = None) -> np.ndarray:
    """Every rotated view of every panorama, location by location (the paper's order)."""
    views = rotated_views(panoramas, step, window)[0]
    return views.reshape(-1, *views.shape[2:])


def _net(layers=None, **kw) -> HierarchicalSFA:
    kw.setdefault("n_outputs", 4)
    kw.setdefault("dtype", "float64")
    return HierarchicalSFA(presets.tiny() if layers is None else layers, progress=False, **kw)


def test_preset_grids_are_as_documented():
    assert layer_grids(presets.paper_sim(), 40, 350) == [(7, 70), (3, 14), (1, 7), (1, 1)]
    assert layer_grids(presets.paper_outdoor(), 60, 600) == [(11, 120), (5, 40), (2, 10), (1, 1)]
    assert layer_grids(presets.tiny(), H, W) == [(4, 20), (2, 5), (1, 1)]
    table = describe(presets.paper_sim(), (40, 350, 3))
    assert "layer 1: 7 x 70 nodes" in table and "300 -> 32 -> 560 -> 32" in table


@pytest.mark.parametrize(("step", "batch"), [(2, 5), (4, 1), (2, None)])
def test_rotation_shortcut_gives_the_same_model_as_brute_force(panoramas, step, batch):
    fast = _net(batch_size=batch).fit_rotations(panoramas, step=step, method="shortcut")
    # the brute-force model recomputes the lower layers instead of caching their outputs
    slow = _net(batch_size=7, cache_mb=0).fit_rotations(panoramas, step=step, method="brute-force")
    assert fast.fit_method_ == "rotations-shortcut"
    assert slow.fit_method_ == "rotations-brute-force"
    views = _views(panoramas, step)
    np.testing.assert_allclose(fast.transform(views), slow.transform(views), atol=1e-7)
    np.testing.assert_allclose(fast.delta_values_, slow.delta_values_, rtol=1e-7)
    for a, b in zip(fast.layer_params_, slow.layer_params_, strict=True):
        np.testing.assert_allclose(a.expand.weight, b.expand.weight, rtol=1e-6, atol=1e-8)


def test_rotation_shortcut_with_a_cropped_window_and_a_non_wrapping_network(panoramas):
    l1 = LayerSpec(field=(4, 4), stride=(2, 2), reduce_dim=6, out_dim=8, wrap=False)
    l2 = LayerSpec(field=(2, 4), stride=(2, 3), reduce_dim=6, out_dim=8, wrap=False)
    grid = layer_grids([l1, l2], H, 24)[-1]
    layers = [l1, l2, LayerSpec(field=grid, stride=grid, reduce_dim=6, out_dim=8, wrap=False)]
    assert shortcut_applies(layers, W, step=2, window=24)
    assert not shortcut_applies(presets.tiny(), W, step=2, window=24)  # tiny wraps
    fast = _net(layers, batch_size=4).fit_rotations(panoramas, step=2, window=24)
    slow = _net(layers).fit_rotations(panoramas, step=2, window=24, method="brute-force")
    assert fast.fit_method_ == "rotations-shortcut" and fast.input_shape_ == (H, 24, 3)
    views = _views(panoramas, 2, 24)
    np.testing.assert_allclose(fast.transform(views), slow.transform(views), atol=1e-7)
    y = fast.transform_rotations(panoramas, step=2).reshape(-1, 4)
    np.testing.assert_allclose(y, fast.transform(views), atol=1e-9)


# step 1 is finer than layer 1's column stride (2): the shortcut runs once per phase
@pytest.mark.parametrize("step", [1, 2, 8])
def test_transform_rotations_equals_transform_of_every_view(panoramas, step):
    model = _net().fit_rotations(panoramas, step=4)
    y = model.transform_rotations(panoramas, step=step)
    assert y.shape == (len(panoramas), W // step, 4)
    np.testing.assert_allclose(
        y.reshape(-1, 4), model.transform(_views(panoramas, step)), atol=1e-9
    )
    single = _net(weight_sharing="none").fit(_views(panoramas[:4], 4))  # no shortcut: view by view
    np.testing.assert_allclose(
        single.transform_rotations(panoramas[:2], step=step).reshape(-1, 4),
        single.transform(_views(panoramas[:2], step)),
        atol=1e-12,
    )


def test_features_averaged_over_every_column_ignore_whole_column_turns(panoramas):
    """The mean over all one-column rotations is the same for a panorama turned by any number
    of columns (here not multiples of layer 1's stride); over the stride's rotations it is not."""
    model = _net().fit_rotations(panoramas, step=2)
    mean = model.transform_rotations(panoramas[:3], step=1).mean(axis=1)
    for k in (1, 3, 7):
        turned = np.roll(panoramas[:3], -k, axis=2)
        np.testing.assert_allclose(
            model.transform_rotations(turned, step=1).mean(axis=1), mean, atol=1e-9
        )
    coarse = model.transform_rotations(panoramas[:3], step=2).mean(axis=1)
    turned = model.transform_rotations(np.roll(panoramas[:3], -1, axis=2), step=2).mean(axis=1)
    assert np.abs(turned - coarse).max() > 1e-3


def test_fit_on_materialised_views_equals_brute_force_rotations(panoramas):
    views = _views(panoramas, 4)
    a = _net(batch_size=9).fit(views)
    b = _net().fit_rotations(panoramas, step=4, method="brute-force")
    np.testing.assert_allclose(a.transform(views), b.transform(views), atol=1e-9)
    assert a.fit_method_ == "views" and a.n_training_views_ == len(views)


def test_training_outputs_are_centred_white_and_ordered(panoramas):
    views = _views(panoramas, 4)
    model = _net().fit(views)
    y = model.transform(views)
    assert y.shape == (len(views), 4) and y.dtype == np.float64
    np.testing.assert_allclose(y.mean(axis=0), 0.0, atol=1e-8)
    np.testing.assert_allclose(np.cov(y.T, bias=True), np.eye(4), atol=1e-6)
    np.testing.assert_allclose(np.mean(np.diff(y, axis=0) ** 2, axis=0), model.delta_values_)
    assert np.all(np.diff(model.delta_values_) >= 0)


def test_rotation_training_gives_orientation_invariant_features():
    pans = synthetic_panoramas(40, H, W, seed=3, n_keyframes=6)
    model = _net(dtype="float32").fit_rotations(pans, step=2)
    y = model.transform(_views(pans, 2)).reshape(40, W // 2, 4)
    eta_phi = y.var(axis=1).mean(axis=0)  # mean variance over orientations, per output
    eta_r = y.mean(axis=1).var(axis=0)  # variance over locations of the mean per location
    assert np.all(eta_phi < 0.05), eta_phi
    assert np.all(eta_r > 0.9), eta_r


def test_sequence_ids_separate_runs():
    views = synthetic_panoramas(50, H, W, seed=11, n_keyframes=6)  # a path, no rotation
    ids = np.repeat([0, 1], [20, 30])
    split = _net().fit(views, sequence_ids=ids)
    joined = _net().fit(views)
    assert not np.allclose(split.transform(views), joined.transform(views), atol=1e-6)
    np.testing.assert_allclose(
        _net(batch_size=7).fit(views, sequence_ids=ids).transform(views),
        split.transform(views),
        atol=1e-9,
    )


def test_float32_model_matches_float64_and_chunking_does_not_flip_signs(panoramas):
    views = _views(panoramas, 4)
    ref = _net().fit_rotations(panoramas, step=4).transform(views)
    for batch in (1, 5, None):
        y = _net(dtype="float32", batch_size=batch).fit_rotations(panoramas, step=4)
        y = y.transform(views)
        for j in range(4):
            assert np.corrcoef(y[:, j], ref[:, j])[0, 1] > 0.999


def test_individually_learned_nodes(panoramas):
    shared = _net().fit_rotations(panoramas, step=4)
    single = _net(weight_sharing="none").fit_rotations(panoramas, step=4)
    assert single.fit_method_ == "rotations-brute-force"
    assert single.layer_params_[0].reduce.weight.shape == (4, 20, 48, 6)
    views = _views(panoramas, 4)
    a = _net(weight_sharing="none", batch_size=13).fit(views)
    np.testing.assert_allclose(a.transform(views), single.transform(views), atol=1e-8)
    assert not np.allclose(single.transform(views), shared.transform(views), atol=1e-3)


def test_row_shared_nodes_shortcut_equals_brute_force_and_round_trips(panoramas, tmp_path):
    fast = _net(weight_sharing="rows", batch_size=5).fit_rotations(panoramas, step=2)
    slow = _net(weight_sharing="rows", batch_size=7, cache_mb=0).fit_rotations(
        panoramas, step=2, method="brute-force"
    )
    assert fast.fit_method_ == "rotations-shortcut"
    # one node per row of every layer's grid, replicated along the row
    assert fast.layer_params_[0].reduce.weight.shape == (4, 1, 48, 6)
    assert fast.layer_params_[1].expand.weight.shape[:2] == (2, 1)
    views = _views(panoramas, 2)
    y = fast.transform(views)
    np.testing.assert_allclose(y, slow.transform(views), atol=1e-7)
    np.testing.assert_allclose(
        fast.transform_rotations(panoramas, step=2).reshape(-1, 4), y, atol=1e-9
    )
    # the same as individually learned nodes whose statistics are pooled along each row
    a = _net(weight_sharing="rows", batch_size=13).fit(views)
    np.testing.assert_allclose(a.transform(views), y, atol=1e-7)
    rows0 = fast.layer_params_[0].reduce.weight[:, 0]
    assert not np.allclose(rows0[0], rows0[-1], atol=1e-3)  # the rows learned different nodes
    # the per-row inference path equals the generic one of nodes learned per position
    a_in = views[:6].astype(np.float64)
    for p in fast.layer_params_:
        c = p.grid[1]
        full = [
            Affine(*(np.repeat(v, c, axis=1) for v in (f.weight, f.bias, f.delta)))
            for f in (p.reduce, p.expand)
        ]
        generic = LayerParams(p.spec, p.grid, *full)
        np.testing.assert_allclose(p.forward(a_in, 4.0), generic.forward(a_in, 4.0), atol=1e-10)
        a_in = p.forward(a_in, 4.0)
    save_model(fast, tmp_path / "rows.npz")
    back = load_model(tmp_path / "rows.npz")
    assert back.weight_sharing == "rows"
    np.testing.assert_array_equal(back.transform(views), y)
    with pytest.raises(ValueError, match="weight_sharing must be one of 'layer', 'rows' or 'none'"):
        _net(weight_sharing="columns").fit(views)
    with pytest.raises(ValueError, match="for True use 'layer'"):
        _net(weight_sharing=True).fit(views)


@pytest.mark.parametrize("method", ["views", "rotations"])
def test_training_is_deterministic_for_any_number_of_threads(panoramas, method):
    views = _views(panoramas[:5], 4)

    def fit(n_jobs):
        net = _net(dtype="float32", batch_size=2, n_jobs=n_jobs)
        return net.fit(views) if method == "views" else net.fit_rotations(panoramas, step=4)

    models = [fit(1), fit(2), fit(2), fit(3)]
    test = _views(panoramas[5:7], 4)
    ref = models[0].transform(test)
    ref_rot = models[0].transform_rotations(panoramas[5:7], step=4)
    for m in models[1:]:
        np.testing.assert_array_equal(m.transform(test), ref)
        np.testing.assert_array_equal(m.transform_rotations(panoramas[5:7], step=4), ref_rot)
        for a, b in zip(m.layer_params_, models[0].layer_params_, strict=True):
            np.testing.assert_array_equal(a.expand.weight, b.expand.weight)
    models[0].n_jobs = 2
    np.testing.assert_array_equal(models[0].transform(test), ref)


def test_progress_flag(panoramas, capsys):
    _net().fit_rotations(panoramas[:3], step=8)
    assert capsys.readouterr().err == ""
    HierarchicalSFA(presets.tiny(), n_outputs=4, progress=True).fit_rotations(panoramas[:3], step=8)
    assert "SFA layer" in capsys.readouterr().err


def test_layer_spec_validation():
    with pytest.raises(ValueError, match="field"):
        LayerSpec(field=(0, 3), stride=(1, 1), reduce_dim=4, out_dim=4)
    with pytest.raises(ValueError, match="at most 300"):
        LayerSpec(field=(2, 2), stride=(1, 1), reduce_dim=4, out_dim=301)
    with pytest.raises(ValueError, match="expansion"):
        LayerSpec(field=(2, 2), stride=(1, 1), reduce_dim=4, out_dim=4, expansion="cubic")
    with pytest.raises(ValueError, match="must divide the width 41"):
        layer_grids(presets.tiny()[:1], H, 41)
    with pytest.raises(ValueError, match="does not fit"):
        layer_grids([LayerSpec(field=(20, 4), stride=(1, 1), reduce_dim=4, out_dim=4)], H, W)


def test_misuse_errors(panoramas):
    views = _views(panoramas[:2], 8)
    with pytest.raises(NotFittedError):
        _net().transform(views)
    with pytest.raises(TypeError, match="uint8"):
        _net().fit(views.astype(np.float32))
    with pytest.raises(ValueError, match=r"\(N, H, W, 3\)"):
        _net().fit(views[..., :2])
    with pytest.raises(ValueError, match="at least 2"):
        _net().fit(views[:1])
    with pytest.raises(ValueError, match="single node"):
        _net(presets.tiny()[:2]).fit(views)
    with pytest.raises(ValueError, match="n_outputs"):
        _net(n_outputs=9).fit(views)
    with pytest.raises(ValueError, match="n_jobs"):
        _net(n_jobs=0).fit(views)
    with pytest.raises(ValueError, match="not a multiple of step"):
        _net().fit_rotations(panoramas, step=3)
    with pytest.raises(ValueError, match="shortcut does not apply"):  # wraps a cropped view
        _net(presets.tiny(H, 32)).fit_rotations(panoramas, step=2, window=32, method="shortcut")
    model = _net().fit(views)
    with pytest.raises(ValueError, match="trained on"):
        model.transform(views[:, :, :32])
    with pytest.raises(ValueError, match="no variance"):
        _net().fit(np.full((6, H, W, 3), 9, dtype=np.uint8))


def test_layer_without_expansion(panoramas, tmp_path):
    layers = presets.tiny()
    layers[1] = LayerSpec(field=(2, 4), stride=(2, 4), reduce_dim=10, out_dim=6, expansion="none")
    fast = _net(layers).fit_rotations(panoramas, step=4)
    slow = _net(layers).fit_rotations(panoramas, step=4, method="brute-force")
    assert fast.layer_params_[1].expand is None
    assert fast.layer_params_[1].reduce.weight.shape == (64, 6)
    views = _views(panoramas, 4)
    np.testing.assert_allclose(fast.transform(views), slow.transform(views), atol=1e-7)
    save_model(fast, tmp_path / "m.npz")
    loaded = load_model(tmp_path / "m.npz")
    np.testing.assert_array_equal(loaded.transform(views), fast.transform(views))


def test_fourth_moment_products_give_the_same_model_as_rank_k_updates(panoramas, monkeypatch):
    from sfa_gym.sfa import _training

    views = _views(panoramas[:6], 4)
    models = []
    for fourth in (True, False):
        monkeypatch.setattr(_training, "fourth_moments_pay_off", lambda f=fourth: f)
        models.append(_net(batch_size=5).fit(views))
        models.append(_net(batch_size=3).fit_rotations(panoramas, step=4))
    for a, b in ((models[0], models[2]), (models[1], models[3])):
        for pa, pb in zip(a.layer_params_, b.layer_params_, strict=True):
            np.testing.assert_allclose(pa.expand.weight, pb.expand.weight, rtol=1e-7, atol=1e-9)
