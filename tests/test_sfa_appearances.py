"""Several appearances of each location inside its rotation sequence
(``HierarchicalSFA.fit_rotations(..., appearances=A)``): the order, the shortcut against brute
force, the views it stands for, and what it is for (features that ignore the appearance)."""

from __future__ import annotations

import numpy as np
import pytest

from eval.synthetic import synthetic_panoramas
from sfa_gym.rotation import rotated_views, rotation_sequence
from sfa_gym.sfa import HierarchicalSFA, presets

H, W = 10, 40

# tiny networks on little data drop degenerate expanded directions; that is expected here
pytestmark = pytest.mark.filterwarnings("ignore::sfa_gym.sfa.RankDeficiencyWarning")


def _net(**kw) -> HierarchicalSFA:
    kw.setdefault("n_outputs", 4)
    kw.setdefault("dtype", "float64")
    return HierarchicalSFA(presets.tiny(), progress=False, **kw)


def _relit(panoramas: np.ndarray, gain: float, tint: tuple[float, float, float]) -> np.ndarray:
    """The same places under another light: a global gain and a colour cast."""
    light = panoramas.astype(np.float64) * gain * np.asarray(tint)
    return np.clip(np.rint(light), 0, 255).astype(np.uint8)


def _places(n: int, appearances: int, seed: int = 7) -> np.ndarray:
    """``n`` places, each under ``appearances`` lights, interleaved place by place."""
    base = synthetic_panoramas(n, H, W, seed=seed, n_keyframes=5)
    lights = [(1.0, (1.0, 1.0, 1.0)), (0.6, (1.1, 0.9, 0.7)), (1.3, (0.8, 1.0, 1.1))]
    runs = [_relit(base, *lights[a]) for a in range(appearances)]
    return np.stack(runs, axis=1).reshape(-1, H, W, 3)


def test_rotation_sequence_is_a_snake_over_the_appearances():
    k, a = rotation_sequence(3, 2)
    assert k.tolist() == [0, 0, 1, 1, 2, 2]
    assert a.tolist() == [0, 1, 1, 0, 0, 1]
    k, a = rotation_sequence(4)
    assert k.tolist() == [0, 1, 2, 3] and a.tolist() == [0, 0, 0, 0]
    k, a = rotation_sequence(2, 3)
    assert a.tolist() == [0, 1, 2, 2, 1, 0]
    # every (rotation, appearance) once; consecutive views differ in exactly one of the two
    k, a = rotation_sequence(5, 3)
    assert len(set(zip(k.tolist(), a.tolist(), strict=True))) == 15
    assert np.all((np.diff(k) != 0) ^ (np.diff(a) != 0))


@pytest.mark.parametrize(("n_rot", "appearances"), [(0, 1), (3, 0), (3, 1.5), (True, 2)])
def test_rotation_sequence_names_a_bad_count(n_rot, appearances):
    with pytest.raises(ValueError, match="must be a positive int"):
        rotation_sequence(n_rot, appearances)


def _materialised(panoramas: np.ndarray, step: int, appearances: int) -> np.ndarray:
    """The training sequence written out view by view from its definition."""
    views = rotated_views(panoramas, step)[0]  # (L * A, K, H, W, 3)
    k, a = rotation_sequence(views.shape[1], appearances)
    out = [
        views[place * appearances + a_j, k_j]
        for place in range(len(panoramas) // appearances)
        for k_j, a_j in zip(k, a, strict=True)
    ]
    return np.stack(out)


@pytest.mark.parametrize("appearances", [2, 3])
def test_brute_force_trains_on_the_sequence_it_defines(appearances):
    pans = _places(6, appearances)
    views = _materialised(pans, 4, appearances)
    a = _net(batch_size=11).fit(views)
    b = _net().fit_rotations(pans, step=4, method="brute-force", appearances=appearances)
    assert b.n_training_views_ == len(views)
    np.testing.assert_allclose(a.transform(views), b.transform(views), atol=1e-9)


@pytest.mark.parametrize(
    ("appearances", "step", "batch", "sharing"),
    [(2, 2, 5, "layer"), (2, 4, 1, "rows"), (3, 2, None, "layer"), (3, 4, 4, "rows")],
)
def test_shortcut_gives_the_same_model_as_brute_force(appearances, step, batch, sharing):
    pans = _places(5, appearances, seed=3)
    fast = _net(batch_size=batch, weight_sharing=sharing).fit_rotations(
        pans, step=step, method="shortcut", appearances=appearances
    )
    slow = _net(batch_size=7, cache_mb=0, weight_sharing=sharing).fit_rotations(
        pans, step=step, method="brute-force", appearances=appearances
    )
    assert fast.fit_method_ == "rotations-shortcut"
    views = _materialised(pans, step, appearances)
    np.testing.assert_allclose(fast.transform(views), slow.transform(views), atol=1e-7)
    np.testing.assert_allclose(fast.delta_values_, slow.delta_values_, rtol=1e-7)


def test_appearances_inside_the_rotation_sequence_are_ignored():
    """Trained on two lights inside each place's rotations, the features barely differ between
    the lights at the same place and rotation; trained on one light they do."""
    pans = _places(30, 2, seed=5)
    views = rotated_views(pans, 4)[0].reshape(-1, H, W, 3)

    def light_share(model: HierarchicalSFA) -> np.ndarray:
        """Per output: the variance between the lights over the output's variance."""
        y = model.transform(views).reshape(30, 2, -1, 4)
        return (y[:, 1] - y[:, 0]).var(axis=(0, 1)) / y.var(axis=(0, 1, 2))

    one_light = light_share(_net().fit_rotations(pans[0::2], step=4))
    both = light_share(_net().fit_rotations(pans, step=4, appearances=2))
    assert one_light.max() > 0.5, one_light
    assert both.max() < 0.2 and both.mean() < 0.1 * one_light.mean(), (both, one_light)


@pytest.mark.parametrize(
    ("appearances", "message"),
    [(0, "appearances must be a positive int"), (2.0, "positive int"), (4, "whole locations")],
)
def test_bad_appearances_are_named(appearances, message):
    pans = _places(3, 2)  # 6 panoramas
    with pytest.raises(ValueError, match=message):
        _net().fit_rotations(pans, step=4, appearances=appearances)


def test_training_views_are_the_sequence_for_methods_without_the_shortcut():
    from sfa_gym.features import fit_method, training_views
    from sfa_gym.rotation import Rotation

    pans = _places(4, 2)
    rotation = Rotation(step=4)
    views = training_views(pans, rotation, appearances=2)
    assert np.array_equal(views, _materialised(pans, 4, 2))
    # one appearance: every place's rotations in order, the definition's sequence too
    assert np.array_equal(training_views(pans, rotation), _materialised(pans, 4, 1))
    # a subset of rotations keeps the snake over the appearances at each of them
    picked = training_views(pans, rotation, 2, indices=np.array([0, 5]))
    full = views.reshape(4, -1, H, W, 3)
    k, a = rotation_sequence(10, 2)
    at = {(int(kk), int(aa)): i for i, (kk, aa) in enumerate(zip(k, a, strict=True))}
    expected = full[:, [at[0, 0], at[0, 1], at[5, 1], at[5, 0]]].reshape(-1, H, W, 3)
    assert np.array_equal(picked, expected)
    with pytest.raises(ValueError, match="7 panoramas are not whole locations of 2"):
        training_views(pans[:7], rotation, 2)

    class Recorder:  # a method with no capabilities: fitted on the views themselves
        def fit(self, views):
            self.seen = views
            return self

    assert np.array_equal(fit_method(Recorder(), pans, rotation, 2).seen, views)


def test_the_loaded_sfa_plugin_takes_the_appearances():
    from sfa_gym.features import fit_method
    from sfa_gym.plugins import default_plugin_folder, load_method, load_method_plugin
    from sfa_gym.rotation import Rotation

    pans = _places(6, 2)
    path = default_plugin_folder()[0] / "sfa.py"
    args = {"network": "tiny", "node_dim": 6, "n_outputs": 4}
    with load_method(path, args) as isolated:
        fit_method(isolated, pans, Rotation(), appearances=2)
        got = isolated.transform_rotations(pans, 5)
    inside = fit_method(load_method_plugin(path)(**args), pans, Rotation(), appearances=2)
    assert inside.model_.n_training_views_ == 12 * 8  # 6 places x 2 lights x 8 rotations
    np.testing.assert_array_equal(got, inside.transform_rotations(pans, 5))
    once = fit_method(load_method_plugin(path)(**args), pans, Rotation())
    assert not np.allclose(once.transform_rotations(pans, 5), got, atol=1e-3)


def test_shortcut_with_a_cropped_window_gives_the_brute_force_model():
    from sfa_gym.sfa import LayerSpec, layer_grids, shortcut_applies

    l1 = LayerSpec(field=(4, 4), stride=(2, 2), reduce_dim=6, out_dim=8, wrap=False)
    l2 = LayerSpec(field=(2, 4), stride=(2, 3), reduce_dim=6, out_dim=8, wrap=False)
    grid = layer_grids([l1, l2], H, 24)[-1]
    layers = [l1, l2, LayerSpec(field=grid, stride=grid, reduce_dim=6, out_dim=8, wrap=False)]
    assert shortcut_applies(layers, W, step=2, window=24)
    pans = _places(4, 2, seed=9)

    def fit(method: str, batch: int | None) -> HierarchicalSFA:
        net = HierarchicalSFA(layers, n_outputs=4, dtype="float64", progress=False)
        net.set_params(batch_size=batch)
        return net.fit_rotations(pans, step=2, window=24, method=method, appearances=2)

    fast, slow = fit("shortcut", 3), fit("brute-force", None)
    assert fast.fit_method_ == "rotations-shortcut"
    views = rotated_views(pans, 2, 24)[0].reshape(-1, H, 24, 3)
    np.testing.assert_allclose(fast.transform(views), slow.transform(views), atol=1e-7)
