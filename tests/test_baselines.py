"""Built-in feature methods: scikit-learn estimators (clone, get_params), their declared
capabilities, invariances, known answers, PCA against an SVD, bad input."""

from __future__ import annotations

import ast
import dataclasses
from pathlib import Path

import numpy as np
import pytest
from sklearn.base import clone
from sklearn.exceptions import NotFittedError

from sfa_gym.plugins import Capabilities, get_capabilities, load_method_plugin
from sfa_gym.protocols.settings import SFASettings
from sfa_gym.rotation import Rotation, rotated_views

BASELINES = Path(__file__).resolve().parents[1] / "baselines"


def _method(name: str, **kwargs):
    return load_method_plugin(BASELINES / f"{name}.py")(**kwargs)


def _views(n: int = 6, h: int = 40, w: int = 350, seed: int = 0) -> np.ndarray:
    return np.random.default_rng(seed).integers(0, 256, size=(n, h, w, 3), dtype=np.uint8)


def test_baselines_import_only_the_library_not_each_other():
    stems = {p.stem for p in BASELINES.glob("*.py")}
    for path in BASELINES.glob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                names = [node.module or ""]
            else:
                continue
            for name in names:
                top = name.split(".")[0]
                assert top != "baselines" and top not in stems, f"{path.name} imports {name}"


BUILT_IN = ["band_means", "fft_magnitude", "raw_pixels", "pca", "sfa", "deep_sfa", "contrastive"]


@pytest.mark.parametrize("name", BUILT_IN)
def test_every_built_in_method_is_a_scikit_learn_estimator(name):
    method = _method(name)
    params = method.get_params()
    copy = clone(method)
    assert copy is not method and type(copy) is type(method)
    assert copy.get_params() == params
    if name == "sfa":  # its arguments are the SFA settings, held whole
        settings = params.pop("settings")  # the file's Args: SFASettings, the network "auto"
        assert isinstance(settings, SFASettings) and params == {
            "rotation": Rotation(),
            "progress": False,
        }
        assert dataclasses.asdict(settings) == dataclasses.asdict(SFASettings(network="auto"))
        assert clone(_method(name, node_dim=16)).get_params()["settings"].node_dim == 16
        return
    # the estimator's parameters are the fields of Args, with the same defaults
    factory = load_method_plugin(BASELINES / f"{name}.py")
    assert params == factory.arguments()
    first = dataclasses.fields(factory.args_type)[0].name
    changed = clone(method).set_params(**{first: 2})
    assert changed.get_params()[first] == 2 and method.get_params()[first] == params[first]


@pytest.mark.parametrize("name", ["band_means", "fft_magnitude", "raw_pixels", "pca"])
def test_a_clone_is_unfitted_and_fits_to_the_same_features(name):
    views = _views(12)
    fitted = _method(name, regressor="map").fit(views)
    copy = clone(fitted)
    assert not hasattr(copy, "input_shape_") and copy.get_params()["regressor"] == "map"
    np.testing.assert_array_equal(copy.fit(views).transform(views), fitted.transform(views))


def test_the_capabilities_of_each_built_in_method():
    expected = {
        "band_means": Capabilities(
            rotation_invariant=True, regressor="quadratic", extra_regressors=("map",)
        ),
        "fft_magnitude": Capabilities(
            rotation_invariant=True, regressor="linear", extra_regressors=("map",)
        ),
        "raw_pixels": Capabilities(regressor="knn"),
        "pca": Capabilities(regressor="quadratic", extra_regressors=("map",)),
        "sfa": Capabilities(regressor="linear"),
        # invariant by construction: circular convolutions pooled by |DFT| along the width
        "deep_sfa": Capabilities(rotation_invariant=True, extra_regressors=("map",)),
        "contrastive": Capabilities(rotation_invariant=True, extra_regressors=("map",)),
    }
    assert {name: get_capabilities(_method(name)) for name in BUILT_IN} == expected
    # the paired regression is a parameter where the method has one
    assert get_capabilities(_method("band_means", regressor="map")).regressor == "map"


def test_capabilities_that_are_not_a_capabilities_are_refused():
    class Liar:
        name = "liar"
        capabilities = {"rotation_invariant": True}

    with pytest.raises(TypeError, match="capabilities must be a sfa_gym.capabilities"):
        get_capabilities(Liar())
    assert get_capabilities(object()) == Capabilities()  # nothing declared: nothing used


def test_the_built_in_sfa_trains_the_settings_it_is_given():
    from eval.synthetic import synthetic_panoramas
    from sfa_gym.features import fit_method, view_features

    panoramas = synthetic_panoramas(8, 10, 40, seed=1)
    method = _method("sfa", network="tiny", node_dim=6, n_outputs=3)
    fitted = fit_method(method, panoramas, Rotation())
    assert fitted.model_.n_outputs == 3
    assert view_features(fitted, panoramas, Rotation(), progress=False).shape == (8, 8, 3)
    with pytest.raises(ValueError, match="n_outputs must be a positive int"):
        _method("sfa", n_outputs=0)


@pytest.mark.parametrize("name", ["band_means", "fft_magnitude", "raw_pixels", "pca"])
def test_only_column_statistics_declare_rotation_invariance(name):
    # the evaluation loop transforms each panorama once for these: the claim must hold
    declared = get_capabilities(_method(name)).rotation_invariant
    assert declared == (name in ("band_means", "fft_magnitude"))


@pytest.mark.parametrize("name", ["band_means", "fft_magnitude"])
def test_rotation_invariant_baselines_under_every_circular_shift(name):
    views = _views(2, w=60)
    method = _method(name).fit(views)
    assert get_capabilities(method).rotation_invariant
    reference = method.transform(views)
    for panorama, expected in zip(views, reference, strict=True):
        rotated, _ = rotated_views(panorama, step=1)  # all 60 shifts, np.roll(-k) each
        np.testing.assert_array_equal(rotated[7], np.roll(panorama, -7, axis=1))
        features = method.transform(rotated)
        if name == "band_means":
            # Integer sums: bit-exact.
            assert np.all(features == expected)
        else:
            np.testing.assert_allclose(
                features, np.broadcast_to(expected, features.shape), rtol=1e-12, atol=1e-14
            )


@pytest.mark.parametrize("name", ["band_means", "fft_magnitude", "raw_pixels", "pca"])
def test_baselines_tell_different_panoramas_apart(name):
    views = _views(12)
    features = _method(name).fit(views).transform(views)
    assert np.linalg.matrix_rank(features - features.mean(axis=0), tol=1e-9) >= min(
        features.shape[1], 6
    )


def test_band_means_known_answer():
    views = np.zeros((1, 8, 10, 3), dtype=np.uint8)
    views[0, :4] = (255, 0, 51)  # top half
    views[0, 4:, :5] = (0, 255, 0)  # bottom half: half the columns green, half black
    features = _method("band_means", n_bands=2).fit(views).transform(views)
    np.testing.assert_allclose(features, [[1.0, 0.0, 0.2, 0.0, 0.5, 0.0]])
    # Uneven bands: 5 rows into 2 bands of 3 and 2 rows.
    views = np.zeros((1, 5, 4, 3), dtype=np.uint8)
    views[0, 2] = 255
    features = _method("band_means", n_bands=2).fit(views).transform(views)
    np.testing.assert_allclose(features, [[1 / 3] * 3 + [0.0] * 3])


def test_fft_magnitude_known_answer():
    w = 64
    columns = np.arange(w)
    profile = 100 + 50 * np.cos(2 * np.pi * 3 * columns / w)  # constant 100 plus frequency 3
    views = np.broadcast_to(np.round(profile)[None, :, None], (4, w, 3)).astype(np.uint8)[None]
    features = _method("fft_magnitude", n_bands=1, n_frequencies=5).fit(views).transform(views)
    spectrum = features.reshape(5, 3)[:, 0]  # frequency x channel
    expected = [100 / 255, 0.0, 0.0, 25 / 255, 0.0]  # |X_f| / W = amplitude / 2 for f > 0
    np.testing.assert_allclose(spectrum, expected, atol=3e-3)  # uint8 rounding of the profile
    assert features.shape == (1, 15)


def test_raw_pixels_known_answer_and_size():
    blocks = np.random.default_rng(2).integers(0, 256, size=(1, 4, 35, 3), dtype=np.uint8)
    views = np.repeat(np.repeat(blocks, 10, axis=1), 10, axis=2)  # 40 x 350, constant 10x10 blocks
    method = _method("raw_pixels").fit(views)
    np.testing.assert_allclose(method.transform(views), blocks.reshape(1, -1) / 255.0)
    with pytest.raises(ValueError, match="only shrinks"):
        _method("raw_pixels", width=400).fit(views)


def test_pca_matches_an_svd_and_whitens():
    views = _views(40, h=10, w=30, seed=3)
    method = _method("pca", n_components=5, shrink=2).fit(views)
    assert method.components_.shape == (5, 5 * 15 * 3)
    np.testing.assert_allclose(method.components_ @ method.components_.T, np.eye(5), atol=1e-10)
    features = method.transform(views)
    assert features.shape == (40, 5)
    np.testing.assert_allclose(features.mean(axis=0), 0.0, atol=1e-10)
    np.testing.assert_allclose(features.var(axis=0, ddof=1), 1.0, rtol=1e-8)
    # Same subspace and variances as a plain SVD of the centred data.
    import cv2

    data = np.stack([cv2.resize(v, (15, 5), interpolation=cv2.INTER_AREA) for v in views])
    data = data.reshape(40, -1) / 255.0
    _, s, vt = np.linalg.svd(data - data.mean(axis=0), full_matrices=False)
    np.testing.assert_allclose(method.explained_variance_, s[:5] ** 2 / 39, rtol=1e-8)
    np.testing.assert_allclose(np.abs(method.components_ @ vt[:5].T), np.eye(5), atol=1e-6)
    # Chunked accumulation gives the same components; the same data give the same signs.
    chunked = _method("pca", n_components=5, shrink=2, chunk=7).fit(views)
    np.testing.assert_allclose(chunked.transform(views), features, atol=1e-8)


@pytest.mark.parametrize(
    ("name", "kwargs", "size", "step", "window"),
    [
        ("pca", {}, (40, 350), 1, None),  # a feature field: every column
        ("pca", {}, (40, 350), 5, 175),  # a narrower field of view
        ("pca", {"shrink": 4}, (30, 120), 2, None),  # 4 does not divide 30: 7 rows
        ("raw_pixels", {}, (40, 350), 5, None),
        ("raw_pixels", {}, (60, 600), 5, None),  # 600 / 35 columns: each view shrunk
    ],
)
def test_transform_rotations_gives_the_features_of_each_rotated_view(
    name, kwargs, size, step, window
):
    panoramas = _views(4, *size, seed=5)
    train = rotated_views(panoramas, step=10, window=window)[0]
    method = _method(name, **kwargs).fit(train.reshape(-1, *train.shape[2:]))
    fast = method.transform_rotations(panoramas, step)
    views = rotated_views(panoramas, step=step, window=window)[0]
    # what the protocols computed before: each panorama's views transformed together
    each = np.stack([method.transform(v) for v in views])
    assert fast.shape == each.shape and np.array_equal(fast, each)
    with pytest.raises(ValueError, match="do not give such views"):
        method.transform_rotations(panoramas[:, :-1], step)
    # only the rotations asked for, in the order asked: the same values as picking them
    picked = np.array([3, 0, fast.shape[1] - 1, 3])
    assert np.array_equal(method.transform_rotations(panoramas, step, picked), fast[:, picked])
    if name == "raw_pixels":  # computes only those, and checks them
        with pytest.raises(ValueError, match=r"indices must be a 1-d array of view indices"):
            method.transform_rotations(panoramas, step, np.array([fast.shape[1]]))


def test_pca_bad_input_is_refused_clearly():
    views = _views(5, h=10, w=30)
    with pytest.raises(ValueError, match=r"n_components must lie in \[1, 4\]"):
        _method("pca").fit(views)
    with pytest.raises(NotFittedError, match="not fitted"):
        _method("pca").transform(views)
    method = _method("pca", n_components=2).fit(views)
    with pytest.raises(ValueError, match=r"fitted on views of shape \(10, 30, 3\)"):
        method.transform(_views(2, h=10, w=35))
    with pytest.raises(TypeError, match="uint8"):
        method.transform(views.astype(np.float32))
    with pytest.raises(ValueError, match="shrink"):
        _method("pca", shrink=0).fit(views)
    with pytest.raises(ValueError, match="whiten"):
        _method("pca", n_components=2).fit(np.repeat(views[:1], 5, axis=0))


@pytest.mark.parametrize("name", ["band_means", "fft_magnitude", "raw_pixels"])
def test_stateless_baselines_refuse_bad_input(name):
    with pytest.raises(NotFittedError, match="not fitted"):
        _method(name).transform(_views(1))
    with pytest.raises(ValueError, match=r"\(N, H, W, 3\)"):
        _method(name).fit(np.zeros((2, 40, 350), dtype=np.uint8))
    with pytest.raises(TypeError, match="uint8"):
        _method(name).fit(np.zeros((2, 40, 350, 3)))


def test_band_and_frequency_counts_are_checked_against_the_view():
    with pytest.raises(ValueError, match=r"n_bands must be an int in \[1, 4\]"):
        _method("band_means", n_bands=8).fit(_views(1, h=4, w=20))
    with pytest.raises(ValueError, match=r"n_frequencies must be an int in \[1, 11\]"):
        _method("fft_magnitude", n_frequencies=12).fit(_views(1, h=8, w=20))
