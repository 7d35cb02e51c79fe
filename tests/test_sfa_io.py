"""Saving and loading hierarchical SFA models: round trip, the old format, and every kind of bad
file (foreign, corrupt, inflating, oversized, with weights that overflow)."""

from __future__ import annotations

import io
import json
import tracemalloc
import warnings
import zipfile

import numpy as np
import pytest
from numpy.lib import format as npy
from sklearn.exceptions import NotFittedError

from eval.synthetic import synthetic_panoramas
from sfa_gym.files import MAX_COMPRESSION_RATIO
from sfa_gym.rotation import rotated_views
from sfa_gym.sfa import HierarchicalSFA, RankDeficiencyWarning, load_model, presets, save_model
from sfa_gym.sfa._layers import Affine, LayerParams
from sfa_gym.sfa.io import FORMAT, FORMAT_VERSION, architecture


@pytest.fixture(scope="module")
def data():
    pans = synthetic_panoramas(6, 10, 40, seed=1, n_keyframes=3)
    views = rotated_views(pans, step=4)[0].reshape(-1, 10, 40, 3)
    return pans, views


def _fit(pans, sharing="layer", clip=4.0):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RankDeficiencyWarning)
        model = HierarchicalSFA(
            presets.tiny(), n_outputs=3, weight_sharing=sharing, clip=clip, progress=False
        )
        return model.fit_rotations(pans, step=4)


@pytest.fixture(scope="module", params=["layer", "rows", "none"])
def model(request, data):
    return _fit(data[0], request.param)


@pytest.fixture(scope="module")
def good(data, tmp_path_factory):
    path = tmp_path_factory.mktemp("models") / "good.npz"
    save_model(_fit(data[0]), path)
    return path


def _arrays(path):
    with np.load(path, allow_pickle=False) as npz:
        return {k: npz[k] for k in npz.files}


def _rewrite(src, dst, header_edit=None, drop=None, replace=None):
    arrays = _arrays(src)
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


def _npy_bytes(array: np.ndarray) -> bytes:
    buffer = io.BytesIO()
    npy.write_array(buffer, array, allow_pickle=False)
    return buffer.getvalue()


def _zip(dst, members: dict[str, bytes], compression=zipfile.ZIP_STORED):
    with zipfile.ZipFile(dst, "w", compression) as archive:
        for name, raw in members.items():
            archive.writestr(name + ".npy", raw)


def test_save_load_round_trip_gives_identical_features(model, data, tmp_path):
    _, views = data
    path = tmp_path / "model.sfa"  # no .npz suffix: the exact name is kept
    save_model(model, path)
    assert path.is_file() and [p.name for p in tmp_path.iterdir()] == ["model.sfa"]
    loaded = load_model(path, expected_input_shape=(10, 40, 3))
    np.testing.assert_array_equal(loaded.transform(views), model.transform(views))
    np.testing.assert_array_equal(loaded.delta_values_, model.delta_values_)
    assert loaded.input_shape_ == model.input_shape_ and loaded.grids_ == model.grids_
    assert architecture(loaded) == architecture(model)
    assert loaded.get_params() == model.get_params()
    assert loaded.weight_sharing == model.weight_sharing
    assert loaded.fit_method_ == model.fit_method_
    assert loaded.n_training_views_ == model.n_training_views_ == 60


def test_file_holds_documented_arrays_and_header(model, tmp_path):
    path = tmp_path / "m.npz"
    save_model(model, path)
    arrays = _arrays(path)
    header = json.loads(str(arrays["header"]))
    lead = {"layer": (), "rows": (4, 1), "none": (4, 20)}[model.weight_sharing]
    assert arrays["layer1.reduce.weight"].shape == (*lead, 48, 6)
    assert arrays["layer1.expand.weight"].shape == (*lead, 27, 8)
    assert header["format"] == FORMAT and header["version"] == FORMAT_VERSION == 2
    assert header["architecture"]["weight_sharing"] == model.weight_sharing
    assert header["input_shape"] == [10, 40, 3]
    assert header["architecture"]["layers"][0]["field"] == [4, 4]
    expected = {
        f"layer{i}.{s}.{n}"
        for i in (1, 2, 3)
        for s in ("reduce", "expand")
        for n in ("weight", "bias", "delta")
    }
    assert set(arrays) == expected | {"header"}


@pytest.mark.parametrize(("old", "new"), [(True, "layer"), ("rows", "rows"), (False, "none")])
def test_files_of_format_version_1_still_load(data, tmp_path, old, new):
    """Version 1 wrote weight_sharing as true, "rows" or false; the arrays are the same."""
    pans, views = data
    model = _fit(pans, new)
    save_model(model, tmp_path / "new.npz")

    def as_version_1(header):
        header["version"] = 1
        header["architecture"]["weight_sharing"] = old

    _rewrite(tmp_path / "new.npz", tmp_path / "old.npz", header_edit=as_version_1)
    loaded = load_model(tmp_path / "old.npz")
    assert loaded.weight_sharing == new
    np.testing.assert_array_equal(loaded.transform(views), model.transform(views))
    # the booleans belong to version 1 only
    _rewrite(tmp_path / "new.npz", tmp_path / "bad.npz", header_edit=lambda h: h["architecture"]
             .update(weight_sharing=old if old != "rows" else "columns"))  # fmt: skip
    with pytest.raises(ValueError, match="weight_sharing must be one of"):
        load_model(tmp_path / "bad.npz")


def test_bad_files_are_rejected_with_the_reason(good, tmp_path):
    bad = tmp_path / "bad.npz"

    with pytest.raises(FileNotFoundError):
        load_model(tmp_path / "missing.npz")

    bad.write_bytes(b"this is not a zip archive at all")
    with pytest.raises(ValueError, match="not a readable .npz"):
        load_model(bad)

    with open(bad, "wb") as fh:
        np.savez(fh, weights=np.ones(3))
    with pytest.raises(ValueError, match=r"missing member\(s\) \['header'\]"):
        load_model(bad)

    _rewrite(good, bad, header_edit=lambda h: h.update(format="other-model"))
    with pytest.raises(ValueError, match="expected 'sfa-gym-model'"):
        load_model(bad)

    _rewrite(good, bad, header_edit=lambda h: h.update(version=FORMAT_VERSION + 1))
    with pytest.raises(ValueError, match="newer than"):
        load_model(bad)

    _rewrite(good, bad, drop="layer2.expand.bias")
    with pytest.raises(ValueError, match=r"missing member\(s\) \['layer2.expand.bias'\]"):
        load_model(bad)

    _rewrite(good, bad, replace={"layer1.reduce.weight": np.zeros((5, 5))})
    with pytest.raises(ValueError, match="'layer1.reduce.weight' has shape"):
        load_model(bad)

    _rewrite(good, bad, replace={"layer1.reduce.weight": np.zeros((48, 6), np.float32)})
    with pytest.raises(ValueError, match="'layer1.reduce.weight' has dtype float32"):
        load_model(bad)

    _rewrite(good, bad, header_edit=lambda h: h.update(input_shape=[10, 41, 3]))
    with pytest.raises(ValueError, match="invalid header"):
        load_model(bad)

    # node dimensions beyond what the architecture allows would size the arrays
    _rewrite(good, bad, header_edit=lambda h: h["node_dims"][0].__setitem__(0, 10**6))
    with pytest.raises(ValueError, match=r"layer 1: linear SFA dimension 1000000 outside \[1, 6\]"):
        load_model(bad)

    # every message names the file
    with pytest.raises(ValueError, match=f"cannot load SFA model {str(good)!r}: .*takes views of"):
        load_model(good, expected_input_shape=(40, 350, 3))


def test_members_the_format_does_not_define_are_refused(good, tmp_path):
    bad = tmp_path / "extra.npz"
    _rewrite(good, bad, replace={"notes": np.arange(3.0)})
    with pytest.raises(ValueError, match=r"members the format does not define: \['notes'\]"):
        load_model(bad)


def test_a_small_file_that_inflates_to_gigabytes_is_refused_before_inflating(good, tmp_path):
    """A deflated member of zeros: ~120 kB on disk, 128 MB inflated. It is refused from the
    sizes in the zip directory, whether it pretends to be a weight array or an extra member;
    the test streams it into the archive and never holds it in memory."""
    size = 16 * 2**20  # float64 values: 128 MB
    members = {k: _npy_bytes(v) for k, v in _arrays(good).items()}
    for name in ("layer1.reduce.weight", "padding"):
        bomb = tmp_path / f"bomb_{name}.npz"
        with zipfile.ZipFile(bomb, "w", zipfile.ZIP_DEFLATED) as archive:
            for key, raw in members.items():
                if key != name:
                    archive.writestr(key + ".npy", raw)
            with archive.open(name + ".npy", "w", force_zip64=True) as member:
                header = io.BytesIO()
                npy.write_array_header_1_0(
                    header, {"descr": "<f8", "fortran_order": False, "shape": (size,)}
                )
                member.write(header.getvalue())
                zeros = bytes(2**20)
                for _ in range(size * 8 // len(zeros)):
                    member.write(zeros)
        assert bomb.stat().st_size < 1_000_000
        assert zipfile.ZipFile(bomb).getinfo(name + ".npy").file_size > 100 * 2**20
        tracemalloc.start()
        try:
            why = rf"would inflate from \d+ to \d+ bytes \(more than {MAX_COMPRESSION_RATIO} times"
            with pytest.raises(ValueError, match=why):
                load_model(bomb)
            peak = tracemalloc.get_traced_memory()[1]
        finally:
            tracemalloc.stop()
        assert peak < 5 * 2**20, f"{peak} bytes allocated while refusing {bomb.name}"


def test_array_headers_that_declare_more_than_the_header_allows_are_refused(good, tmp_path):
    """A few bytes whose .npy header declares a huge array (numpy would allocate it before
    finding the data short), or a member longer than its array: both refused from the
    headers."""
    members = {k: _npy_bytes(v) for k, v in _arrays(good).items()}
    huge = io.BytesIO()
    npy.write_array_header_1_0(huge, {"descr": "<f8", "fortran_order": False, "shape": (10**10,)})
    _zip(tmp_path / "huge.npz", members | {"layer1.reduce.weight": huge.getvalue() + bytes(64)})
    with pytest.raises(ValueError, match=r"'layer1.reduce.weight' has shape \(10000000000,\)"):
        load_model(tmp_path / "huge.npz")
    longer = members | {"layer1.reduce.bias": members["layer1.reduce.bias"] + bytes(4096)}
    _zip(tmp_path / "longer.npz", longer)
    with pytest.raises(ValueError, match="holds .* bytes, but its header declares"):
        load_model(tmp_path / "longer.npz")
    # the same members, compressed as np.savez_compressed would: still loads
    _zip(tmp_path / "deflated.npz", members, zipfile.ZIP_DEFLATED)
    assert load_model(tmp_path / "deflated.npz").n_outputs == 3


def test_a_corrupt_member_is_refused(good, tmp_path):
    raw = bytearray(good.read_bytes())
    with zipfile.ZipFile(good) as archive:
        info = archive.getinfo("layer2.expand.weight.npy")
    # a byte in the member's data: past the local file header, its name and the .npy header
    raw[info.header_offset + 30 + len(info.filename) + 200] ^= 0xFF
    bad = tmp_path / "flipped.npz"
    bad.write_bytes(bytes(raw))
    with pytest.raises(ValueError, match="'layer2.expand.weight' is corrupt"):
        load_model(bad)


def test_weights_that_are_not_finite_or_overflow_are_refused(data, good, tmp_path):
    arrays = _arrays(good)
    w = arrays["layer1.reduce.weight"]
    bad = tmp_path / "bad.npz"
    _rewrite(good, bad, replace={"layer1.reduce.weight": np.where(w > 0, np.nan, w)})
    with pytest.raises(ValueError, match="layer 1 reduce.weight is not finite"):
        load_model(bad)
    # finite in float64, infinite in the model's float32
    _rewrite(good, bad, replace={"layer2.expand.bias": arrays["layer2.expand.bias"] * 1e40})
    with pytest.raises(ValueError, match="layer 2 expand holds a weight of magnitude .* float32"):
        load_model(bad)
    # every weight within float32, but squared by the expansion the values leave its range
    _rewrite(good, bad, replace={"layer1.reduce.weight": w * 1e19})
    with pytest.raises(ValueError, match="too large: values computed in layer 1 can reach"):
        load_model(bad)
    # what the check prevents: features that are not finite
    model = load_model(good)
    first = model.layer_params_[0]
    reduce = Affine(first.reduce.weight * 1e19, first.reduce.bias, first.reduce.delta)
    model.layer_params_[0] = LayerParams(first.spec, first.grid, reduce, first.expand)
    with np.errstate(all="ignore"):
        assert not np.all(np.isfinite(model.transform(data[1][:4])))


def test_unclipped_networks_are_checked_on_probe_views(data, tmp_path):
    """Without clipping, the worst-case bound of a working network already leaves the float32
    range (it compounds over the layers): such a model loads, and probe views decide."""
    pans, views = data
    model = _fit(pans, clip=None)
    save_model(model, tmp_path / "unclipped.npz")
    loaded = load_model(tmp_path / "unclipped.npz")
    np.testing.assert_array_equal(loaded.transform(views), model.transform(views))
    w = _arrays(tmp_path / "unclipped.npz")["layer2.reduce.weight"]
    _rewrite(tmp_path / "unclipped.npz", tmp_path / "bad.npz",
             replace={"layer2.reduce.weight": w * 1e12})  # fmt: skip
    with pytest.raises(ValueError, match="too large"):
        load_model(tmp_path / "bad.npz")


def test_from_layer_params_checks_the_layers(good):
    params = load_model(good).layer_params_
    with pytest.raises(ValueError, match="layer 1: grid"):
        HierarchicalSFA.from_layer_params(params, (12, 40, 3), n_outputs=3)
    with pytest.raises(ValueError, match="layer 1 reduce.weight has shape"):
        HierarchicalSFA.from_layer_params(params, (10, 40, 3), weight_sharing="rows")
    with pytest.raises(ValueError, match="n_outputs"):
        HierarchicalSFA.from_layer_params(params, (10, 40, 3), n_outputs=9)


def test_saving_an_unfitted_model_fails(tmp_path):
    with pytest.raises(NotFittedError, match="not fitted"):
        save_model(HierarchicalSFA(presets.tiny()), tmp_path / "x.npz")
    assert not list(tmp_path.iterdir())
