"""Our SFA engine against MDP 3.6, the toolkit of the paper (the reference implementation).

Data: a small synthetic world (coloured blocks around an arena, seen from a camera moving along
a smooth open path), rendered analytically as periodic panoramas by
:mod:`eval.synthetic`. An open path gives slow features with well separated delta values,
so outputs can be compared one by one; each comparison first checks that separation (a
near-degenerate pair of outputs is only determined up to a rotation, and then only the subspace
could be compared).
"""

from __future__ import annotations

import importlib.util
import sys
import warnings

import numpy as np
import pytest

from eval import synthetic
from sfa_gym.rotation import rotated_views
from sfa_gym.sfa import SFA, HierarchicalSFA, RankDeficiencyWarning, presets

pytestmark = pytest.mark.skipif(
    importlib.util.find_spec("mdp") is None,
    reason="MDP (`pip install 'mdp>=3.6'`) is not installed: these tests compare against it",
)

H, W = 10, 40
N_OUT = 8


def smooth_path(n: int, seed: int) -> np.ndarray:
    """``(n, 3)`` poses along an open path: a few low-frequency sinusoids, slowly turning."""
    return synthetic.smooth_path(
        n, seed, frequencies=(1, 2, 3), amplitude=0.5, limit=1.2, turn_noise=0.05
    )


def landmark_panoramas(poses: np.ndarray, height: int, width: int) -> np.ndarray:
    """16 coloured blocks around the path (:func:`eval.synthetic.landmark_panoramas`)."""
    return synthetic.landmark_panoramas(poses, height, width, n_landmarks=16)


def abs_corr(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """|Pearson correlation| of matching columns."""
    return np.abs(np.corrcoef(a.T, b.T)[: a.shape[1], a.shape[1] :].diagonal())


def assert_separated(delta: np.ndarray, min_ratio: float = 1.01) -> None:
    """Per-output comparison is meaningful only for outputs with distinct delta values."""
    ratios = delta[1:] / delta[:-1]
    assert np.all(ratios >= min_ratio), f"test data give near-degenerate outputs: {ratios}"


@pytest.fixture(scope="module")
def mdp_bridge():
    from sfa_gym.sfa.reference import mdp as mdp_bridge

    mdp_bridge.import_mdp()
    return mdp_bridge


@pytest.fixture(scope="module")
def views() -> np.ndarray:
    return landmark_panoramas(smooth_path(600, seed=1), H, W)


def test_import_mdp_shim_is_idempotent_and_local(mdp_bridge):
    import scipy
    import scipy.linalg

    eigh_before = scipy.linalg.eigh
    mdp = mdp_bridge.import_mdp()
    assert mdp_bridge.import_mdp() is mdp
    assert mdp.__version__.startswith("3.6")
    # MDP runs its LAPACK generalized-eigenproblem path, as on the scipy it was written for
    assert str(mdp.config.has_symeig) == "scipy.linalg.eigh"
    assert sys.modules["mdp.nodes.sfa_nodes"].symeig is sys.modules["mdp.utils._symeig"].wrap_eigh
    # nothing of ours sees the shim
    assert scipy.linalg.eigh is eigh_before
    assert not hasattr(np, "typeDict") and "typeDict" not in vars(scipy)
    assert "scipy.random" not in sys.modules
    assert scipy.test.__module__.startswith("scipy")


def test_old_eigh_signature_maps_to_subset_by_index(mdp_bridge):
    import scipy.linalg

    from sfa_gym.sfa.reference import mdp_compat

    rng = np.random.default_rng(0)
    a = rng.normal(size=(6, 6))
    a = a @ a.T
    b = np.eye(6) + 0.1 * np.diag(rng.uniform(size=6))
    old = mdp_compat._old_eigh_namespace(scipy.linalg)
    w_old, v_old = old.eigh(a, b, eigvals=(1, 3), turbo=True)
    w_new, v_new = scipy.linalg.eigh(a, b, subset_by_index=[1, 3])
    np.testing.assert_allclose(w_old, w_new)
    np.testing.assert_allclose(np.abs(v_old), np.abs(v_new), atol=1e-10)
    # MDP's own symeig (1-based range) through the shim
    w_mdp, _ = mdp_bridge.import_mdp().utils.symeig(a, b, range=(2, 4))
    np.testing.assert_allclose(w_mdp, w_new)


def test_linear_sfa_matches_mdp_sfanode(mdp_bridge):
    rng = np.random.default_rng(3)
    t = np.linspace(0, 4 * np.pi, 3000)
    sources = np.c_[[np.sin(f * t + rng.uniform(0, 6)) for f in (1, 2.1, 3.3, 5.0, 7.7)]].T
    x = np.c_[sources, rng.normal(size=(t.size, 5))] @ rng.normal(size=(10, 10))
    y_ref, d_ref = mdp_bridge.mdp_linear_sfa(x, 5)
    sfa = SFA(n_components=5).fit(x)
    y = sfa.transform(x)
    assert_separated(sfa.delta_values_, 1.5)
    assert np.all(abs_corr(y, y_ref) >= 0.999), abs_corr(y, y_ref)
    np.testing.assert_allclose(sfa.delta_values_, d_ref, rtol=1e-3)


def reference_patches(x: np.ndarray, field, stride, n_cols: int) -> np.ndarray:
    """Node inputs by the documented geometry (sfa_gym.sfa.spec): node ``(r, j)`` reads rows
    ``r*sr ..`` and columns ``(j*sc + c) mod W``, flattened in (row, column, channel) order."""
    (fr, fc), (sr, sc) = field, stride
    n, h, w, d = x.shape
    rows = (h - fr) // sr + 1
    out = np.empty((n, rows, n_cols, fr * fc * d))
    for r in range(rows):
        for j in range(n_cols):
            cols = (j * sc + np.arange(fc)) % w
            out[:, r, j] = x[:, r * sr : r * sr + fr][:, :, cols].reshape(n, -1)
    return out


def test_mdp_network_routes_the_same_patches(mdp_bridge):
    """Layer-1 fields of the MDP network (with wrap-around padding) = our patches, in order."""
    layers = presets.tiny(H, W)
    flow = mdp_bridge.build_mdp_network(layers, (H, W, 3), N_OUT)
    x = np.arange(H * W * 3, dtype=np.float64).reshape(1, H, W, 3)
    n_boards = [type(node).__name__ for node in flow].index("CloneLayer")
    routed = flow[:n_boards].execute(x.reshape(1, -1))
    ours = reference_patches(x, layers[0].field, layers[0].stride, W // layers[0].stride[1])
    np.testing.assert_array_equal(routed.reshape(-1), ours.reshape(-1))
    # the last node column reads the first panorama columns (periodic boundary)
    assert ours[0, 0, -1].reshape(4, 4, 3)[0, -1, 0] == x[0, 0, 1, 0]


def test_mdp_network_rejects_bad_architecture(mdp_bridge):
    layers = presets.tiny(H, W)[:2]  # no single top node
    with pytest.raises(ValueError, match="single node"):
        mdp_bridge.build_mdp_network(layers, (H, W, 3), N_OUT)
    with pytest.raises(ValueError, match="n_outputs"):
        mdp_bridge.build_mdp_network(presets.tiny(H, W), (H, W, 3), 99)
    with pytest.raises(ValueError, match="no layer whose nodes are shared along grid rows"):
        mdp_bridge.build_mdp_network(presets.tiny(H, W), (H, W, 3), N_OUT, weight_sharing="rows")


def fit_both(views, layers, mdp_bridge, sequence_ids=None, **kwargs):
    ours = HierarchicalSFA(layers, N_OUT, dtype="float64", progress=False, **kwargs)
    ref = mdp_bridge.MDPHierarchicalSFA(layers, N_OUT, progress=False, **kwargs)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # full-rank data: no directions may be dropped
        ours.fit(views, sequence_ids=sequence_ids)
    return ours, ref


def test_hierarchical_network_matches_mdp_hinet(views, mdp_bridge):
    layers = presets.tiny(H, W, dim=6, out_dim=N_OUT)
    ours, ref = fit_both(views, layers, mdp_bridge)
    ref.fit(views)
    assert_separated(ours.delta_values_)
    test_views = landmark_panoramas(smooth_path(200, seed=7), H, W)
    for v in (views, test_views):
        corr = abs_corr(ours.transform(v), ref.transform(v))
        assert np.all(corr >= 0.99), corr
    np.testing.assert_allclose(ours.delta_values_, ref.delta_values_, rtol=1e-3)
    # layer by layer: every output channel of every node grid
    for n_layers in (1, 2):
        a, b = ours.forward(test_views, n_layers), ref.forward(test_views, n_layers)
        assert a.shape == b.shape
        k = a.shape[-1]
        assert np.all(abs_corr(a.reshape(-1, k), b.reshape(-1, k)) >= 0.99)


def test_sequences_and_chunking_match_mdp(mdp_bridge):
    """No difference across sequence boundaries; MDP trained in 37-frame overlapping chunks."""
    v = landmark_panoramas(smooth_path(300, seed=3), H, W)
    ids = np.repeat([0, 1, 2], [120, 100, 80])
    layers = presets.tiny(H, W, dim=6, out_dim=N_OUT)
    ours, _ = fit_both(v, layers, mdp_bridge, ids)
    ref = mdp_bridge.MDPHierarchicalSFA(layers, N_OUT, progress=False, batch_size=37)
    ref.fit(v, sequence_ids=ids)
    assert_separated(ours.delta_values_)
    assert np.all(abs_corr(ours.transform(v), ref.transform(v)) >= 0.99)
    np.testing.assert_allclose(ours.delta_values_, ref.delta_values_, rtol=1e-3)
    # ... and the boundaries matter: one long sequence gives other features
    joined = mdp_bridge.MDPHierarchicalSFA(layers, N_OUT, progress=False).fit(v)
    assert not np.allclose(joined.delta_values_, ref.delta_values_, rtol=1e-2)


def test_rotation_shortcut_matches_mdp_on_every_rotated_view(mdp_bridge):
    """Our dense-grid rotation shortcut vs MDP trained on all materialised rotated views."""
    panoramas = landmark_panoramas(smooth_path(24, seed=2), H, W)
    layers = presets.tiny(H, W, dim=6, out_dim=N_OUT)
    ours = HierarchicalSFA(layers, N_OUT, dtype="float64", progress=False)
    ours.fit_rotations(panoramas, step=2)
    assert ours.fit_method_ == "rotations-shortcut"
    ref = mdp_bridge.MDPHierarchicalSFA(layers, N_OUT, progress=False)
    ref.fit_rotations(panoramas, step=2)
    assert ref.n_training_views_ == 24 * W // 2
    assert_separated(ours.delta_values_)
    test = landmark_panoramas(smooth_path(10, seed=5), H, W)
    rotated = np.concatenate(rotated_views(test, step=1, indices=np.arange(0, W, 3))[0])
    assert np.all(abs_corr(ours.transform(rotated), ref.transform(rotated)) >= 0.99)
    np.testing.assert_allclose(ours.delta_values_, ref.delta_values_, rtol=1e-3)


def test_individual_nodes_match_mdp_layer(mdp_bridge):
    v = landmark_panoramas(smooth_path(300, seed=3), H, W)
    layers = presets.tiny(H, W, dim=6, out_dim=N_OUT)
    ours, ref = fit_both(v, layers, mdp_bridge, weight_sharing="none")
    ref.fit(v)
    assert_separated(ours.delta_values_)
    assert np.all(abs_corr(ours.transform(v), ref.transform(v)) >= 0.99)
    # fewer samples per node: MDP's 1/(n-1) vs our 1/n normalisation shows at 1e-3
    np.testing.assert_allclose(ours.delta_values_, ref.delta_values_, rtol=1e-2)


def test_rank_deficient_input_matches_mdp_with_the_same_rank_rule(mdp_bridge):
    """Green = red: every layer-1 patch covariance is singular. Our engine drops the null
    directions; MDP's default solver fails, and with the same relative rule it agrees."""
    mdp = mdp_bridge.import_mdp()
    v = landmark_panoramas(smooth_path(300, seed=4), H, W)
    v[..., 1] = v[..., 0]
    layers = presets.tiny(H, W, dim=6, out_dim=N_OUT)
    ours = HierarchicalSFA(layers, N_OUT, dtype="float64", rank_tol=1e-9, progress=False)
    with pytest.warns(RankDeficiencyWarning, match="layer 1 linear SFA: dropped 16 of 48"):
        ours.fit(v)
    with pytest.raises(mdp.FlowException):
        mdp_bridge.MDPHierarchicalSFA(layers, N_OUT, progress=False).fit(v)
    ref = mdp_bridge.MDPHierarchicalSFA(layers, N_OUT, rank_tol=1e-9, progress=False).fit(v)
    assert ref.flow_[2].node._flow[0].rank_deficit == 16
    assert_separated(ours.delta_values_)
    assert np.all(abs_corr(ours.transform(v), ref.transform(v)) >= 0.99)
    np.testing.assert_allclose(ours.delta_values_, ref.delta_values_, rtol=1e-3)


def test_mdp_training_rejects_single_frame_sequences(mdp_bridge):
    v = landmark_panoramas(smooth_path(20, seed=3), H, W)
    ids = np.r_[np.zeros(10), [1], np.full(9, 2)]
    ref = mdp_bridge.MDPHierarchicalSFA(presets.tiny(H, W), N_OUT, progress=False)
    with pytest.raises(ValueError, match="single frame"):
        ref.fit(v, sequence_ids=ids)
