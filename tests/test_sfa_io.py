"""Saving and loading hierarchical SFA models: round trip and every kind of bad file."""

from __future__ import annotations

import json
import warnings

import numpy as np
import pytest

from sfa_gym.sfa import HierarchicalSFA, RankDeficiencyWarning, presets
from sfa_gym.sfa.io import FORMAT, FORMAT_VERSION
from sfa_gym.sfa.synthetic import synthetic_panoramas


@pytest.fixture(scope="module")
def data():
    pans = synthetic_panoramas(6, 10, 40, seed=1, n_keyframes=3)
    views = np.stack([np.roll(p, -4 * k, axis=1) for p in pans for k in range(10)])
    return pans, views


@pytest.fixture(scope="module", params=[True, False], ids=["shared", "individual"])
def model(request, data):
    pans, _ = data
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RankDeficiencyWarning)
        return HierarchicalSFA(
            presets.tiny(), n_outputs=3, weight_sharing=request.param, progress=False
        ).fit_rotations(pans, step=4)


def _rewrite(src, dst, header_edit=None, drop=None, replace=None):
    with np.load(src, allow_pickle=False) as npz:
        arrays = {k: npz[k] for k in npz.files}
    header = json.loads(str(arrays["header"]))
    if header_edit:
        header_edit(header)
    arrays["header"] = np.array(json.dumps(header))
    if drop:
        del arrays[drop]
    if replace:
        arrays.update(replace)
    with open(dst, "wb") as fh:
        np.savez(fh, **arrays)


def test_save_load_round_trip_gives_identical_features(model, data, tmp_path):
    _, views = data
    path = tmp_path / "model.sfa"  # no .npz suffix: the exact name is kept
    model.save(path)
    assert path.is_file()
    loaded = HierarchicalSFA.load(path, expected_input_shape=(10, 40, 3))
    np.testing.assert_array_equal(loaded.transform(views), model.transform(views))
    np.testing.assert_array_equal(loaded.delta_values_, model.delta_values_)
    assert loaded.input_shape_ == model.input_shape_ and loaded.grids_ == model.grids_
    assert loaded.architecture() == model.architecture()
    assert loaded.fit_method_ == model.fit_method_


def test_file_holds_documented_arrays_and_header(model, tmp_path):
    path = tmp_path / "m.npz"
    model.save(path)
    with np.load(path, allow_pickle=False) as npz:
        header = json.loads(str(npz["header"]))
        names = set(npz.files)
        lead = () if model.weight_sharing else (4, 20)
        assert npz["layer1.reduce.weight"].shape == (*lead, 48, 6)
        assert npz["layer1.expand.weight"].shape == (*lead, 27, 8)
    assert header["format"] == FORMAT and header["version"] == FORMAT_VERSION
    assert header["input_shape"] == [10, 40, 3]
    assert header["architecture"]["layers"][0]["field"] == [4, 4]
    expected = {
        f"layer{i}.{s}.{n}"
        for i in (1, 2, 3)
        for s in ("reduce", "expand")
        for n in ("weight", "bias", "delta")
    }
    assert names == expected | {"header"}


def test_bad_files_are_rejected_with_the_reason(model, tmp_path):
    good = tmp_path / "good.npz"
    model.save(good)
    bad = tmp_path / "bad.npz"

    with pytest.raises(FileNotFoundError):
        HierarchicalSFA.load(tmp_path / "missing.npz")

    bad.write_bytes(b"this is not a zip archive at all")
    with pytest.raises(ValueError, match="not a readable .npz"):
        HierarchicalSFA.load(bad)

    with open(bad, "wb") as fh:
        np.savez(fh, weights=np.ones(3))
    with pytest.raises(ValueError, match="no 'header'"):
        HierarchicalSFA.load(bad)

    _rewrite(good, bad, header_edit=lambda h: h.update(format="other-model"))
    with pytest.raises(ValueError, match="not an sfa-gym model"):
        HierarchicalSFA.load(bad)

    _rewrite(good, bad, header_edit=lambda h: h.update(version=FORMAT_VERSION + 1))
    with pytest.raises(ValueError, match="newer than"):
        HierarchicalSFA.load(bad)

    _rewrite(good, bad, drop="layer2.expand.bias")
    with pytest.raises(ValueError, match="missing array 'layer2.expand.bias'"):
        HierarchicalSFA.load(bad)

    _rewrite(good, bad, replace={"layer1.reduce.weight": np.zeros((5, 5))})
    with pytest.raises(ValueError, match="'layer1.reduce.weight' has shape"):
        HierarchicalSFA.load(bad)

    _rewrite(good, bad, header_edit=lambda h: h.update(input_shape=[10, 41, 3]))
    with pytest.raises(ValueError, match="invalid header"):
        HierarchicalSFA.load(bad)

    with pytest.raises(ValueError, match="takes views of shape"):
        HierarchicalSFA.load(good, expected_input_shape=(40, 350, 3))


def test_saving_an_unfitted_model_fails(tmp_path):
    with pytest.raises(ValueError, match="not fitted"):
        HierarchicalSFA(presets.tiny()).save(tmp_path / "x.npz")
