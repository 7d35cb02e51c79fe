"""Saving and loading fitted hierarchical SFA models: one ``.npz`` file, arrays only.

File layout (a zip archive as ``np.savez`` writes it, one ``.npy`` member per array; never
unpickled, so no code is ever executed):

- ``header``: 0-d unicode array holding a JSON object::

      {"format": "sfa-gym-model", "version": 2, "library_version": "0.1.0",
       "architecture": {"layers": [{"field": [10, 10], "stride": [5, 5], "reduce_dim": 32,
                                    "out_dim": 32, "expansion": "quadratic", "wrap": true}, ...],
                        "n_outputs": 8, "weight_sharing": "layer", "clip": 4.0,
                        "dtype": "float32"},
       "input_shape": [40, 350, 3], "grids": [[7, 70], ...],
       "node_dims": [[32, 32], ...],           # [linear SFA outputs, node outputs] per layer
       "fit_method": "rotations-shortcut", "n_training_views": 43680}

- per layer ``i`` (1-based), float64: ``layer{i}.reduce.weight`` ``(F, r)``,
  ``layer{i}.reduce.bias`` ``(r,)``, ``layer{i}.reduce.delta`` ``(r,)``; with a quadratic
  expansion also ``layer{i}.expand.weight`` ``(r + r(r+1)/2, o)``, ``layer{i}.expand.bias``
  ``(o,)``, ``layer{i}.expand.delta`` ``(o,)``. A node computes
  ``y = x @ reduce.weight + reduce.bias``, then ``z = quad(y) @ expand.weight + expand.bias``.
  With one node per grid row (``weight_sharing="rows"``) every array has two leading axes
  ``(rows, 1)``, without weight sharing (``"none"``) ``(rows, cols)`` of the layer's grid.
  ``F`` = field rows x field cols x input channels, in (row, col, channel) order.

Versions: 2 names the weight sharing ``"layer"``, ``"rows"`` or ``"none"``; version 1 (read as
well) wrote ``true``, ``"rows"`` or ``false``.

Reading an untrusted file. Nothing large is read before the file has been checked against its
own header: the member list must be exactly the arrays the header's architecture defines; each
member's ``.npy`` header (read from the start of the member, without inflating its data) must
declare the shape and dtype the architecture gives, and the member's size in the zip directory
must equal that; a compressed member may not inflate to more than
:data:`MAX_COMPRESSION_RATIO` times its stored size. A small file whose members would inflate
to gigabytes is thus refused after reading a few hundred bytes. The weights are then checked by
:meth:`~sfa_gym.sfa.network.HierarchicalSFA.from_layer_params` (finite, and small enough that
no input makes the features overflow).
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import zipfile
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import IO, Any

import numpy as np
from sklearn.utils.validation import check_is_fitted

from sfa_gym.files import check_format_header, read_npy_header, strict_json, write_atomic
from sfa_gym.sfa._layers import Affine, LayerParams
from sfa_gym.sfa._weights import affine_shapes, check_weight_sharing
from sfa_gym.sfa.network import HierarchicalSFA
from sfa_gym.sfa.spec import LayerSpec, layer_grids

__all__ = [
    "FORMAT",
    "FORMAT_VERSION",
    "MAX_COMPRESSION_RATIO",
    "architecture",
    "load_model",
    "save_model",
]

FORMAT = "sfa-gym-model"
FORMAT_VERSION = 2
MAX_HEADER_BYTES = 1 << 20
"""Largest header member accepted (a real header is a few kB)."""
MAX_COMPRESSION_RATIO = 100
"""Largest inflated / stored size of a compressed member (float weights compress ~1.1 : 1)."""
_SHARING_V1 = {True: "layer", False: "none", "rows": "rows"}


def _library_version() -> str:
    from sfa_gym import __version__

    return __version__


def architecture(model: HierarchicalSFA) -> dict[str, Any]:
    """JSON-able description of a model's parameters (the header's ``architecture``)."""
    params = model.get_params()
    return {
        "layers": [
            {
                "field": list(s.field),
                "stride": list(s.stride),
                "reduce_dim": s.reduce_dim,
                "out_dim": s.out_dim,
                "expansion": s.expansion,
                "wrap": s.wrap,
            }
            for s in params["layers"]
        ],
        "n_outputs": int(params["n_outputs"]),
        "weight_sharing": check_weight_sharing(params["weight_sharing"]),
        "clip": None if params["clip"] is None else float(params["clip"]),
        "dtype": params["dtype"],
    }


def save_model(model: HierarchicalSFA, path: str | os.PathLike[str]) -> None:
    """Write a fitted model to ``path`` (exactly that name), atomically and durably.

    Raises:
        sklearn.exceptions.NotFittedError: the model is not fitted.
    """
    check_is_fitted(
        model, "layer_params_", msg="this HierarchicalSFA is not fitted: nothing to save"
    )
    params = model.layer_params_
    header = {
        "format": FORMAT,
        "version": FORMAT_VERSION,
        "library_version": _library_version(),
        "architecture": architecture(model),
        "input_shape": list(model.input_shape_),
        "grids": [list(g) for g in model.grids_],
        "node_dims": [[p.reduce.out_dim, p.out_dim] for p in params],
        "fit_method": getattr(model, "fit_method_", None),
        "n_training_views": getattr(model, "n_training_views_", None),
    }
    arrays: dict[str, np.ndarray] = {"header": np.array(strict_json(header, indent=None))}
    for i, p in enumerate(params, start=1):
        for stage, aff in (("reduce", p.reduce), ("expand", p.expand)):
            if aff is None:
                continue
            for name in ("weight", "bias", "delta"):
                arrays[f"layer{i}.{stage}.{name}"] = np.asarray(getattr(aff, name), np.float64)
    write_atomic(path, lambda file: np.savez(file, **arrays))


class _BadModel(ValueError):
    """What is wrong with a model file (the caller adds the file's name)."""


def _fail(path: Any, why: str) -> ValueError:
    return ValueError(f"cannot load SFA model {str(path)!r}: {why}")


def load_model(
    path: str | os.PathLike[str], expected_input_shape: Sequence[int] | None = None
) -> HierarchicalSFA:
    """Read a model written by :func:`save_model` (format version 1 or 2).

    Args:
        path: the ``.npz`` file.
        expected_input_shape: if given, the ``(H, W, 3)`` the caller will feed; a model trained
            for another shape is rejected here rather than at the first ``transform``.

    Raises:
        FileNotFoundError: no such file.
        ValueError: not an sfa-gym model (foreign or corrupt file), a format version newer than
            this library reads, members the format does not define or sizes that do not match
            the header (see the module docstring), missing or misshapen arrays, weights that
            are not finite or would overflow, or an input shape mismatch; the message names the
            file and says which.
    """
    if not Path(path).is_file():
        raise FileNotFoundError(f"no SFA model file at {str(path)!r}")
    try:
        with zipfile.ZipFile(path) as archive:
            return _load(archive, expected_input_shape)
    except _BadModel as err:
        raise _fail(path, str(err)) from None
    except (zipfile.BadZipFile, OSError, EOFError) as err:
        raise _fail(path, f"not a readable .npz archive ({err})") from None


def _load(archive: zipfile.ZipFile, expected_input_shape: Sequence[int] | None) -> HierarchicalSFA:
    members: dict[str, zipfile.ZipInfo] = {}
    for info in archive.infolist():
        name = info.filename.removesuffix(".npy")
        if name == info.filename or name in members:
            raise _BadModel(f"member {info.filename!r} is not a (single) .npy array")
        _check_inflation(info)
        members[name] = info
    if "header" not in members:
        raise _BadModel("no 'header' array: not an sfa-gym model file")
    header = _read_header(archive, members["header"])
    model_args, expected = _parse_header(header)
    input_shape = model_args["input_shape"]
    if expected_input_shape is not None and tuple(expected_input_shape) != input_shape:
        raise _BadModel(
            f"the model takes views of shape {input_shape}, expected {tuple(expected_input_shape)}"
        )
    unknown = sorted(set(members) - set(expected) - {"header"})
    if unknown:
        raise _BadModel(f"members the format does not define: {unknown}")
    for key in expected:
        if key not in members:
            raise _BadModel(f"missing array {key!r}")
    # every member's declared size is checked before any member's data is read
    for key, shape in expected.items():
        with _member(archive, members[key], key) as file:
            _npy_header(file, members[key], key, np.dtype("<f8"), shape)
    arrays = {}
    for key, shape in expected.items():
        with _member(archive, members[key], key) as file:
            fortran, _ = _npy_header(file, members[key], key, np.dtype("<f8"), shape)
            arrays[key] = _read_data(file, key, shape, fortran)
    params = []
    layers, grids = model_args["layers"], model_args["grids"]
    for i, (spec, grid) in enumerate(zip(layers, grids, strict=True), start=1):
        stages = {}
        for stage in ("reduce", "expand"):
            if f"layer{i}.{stage}.weight" in expected:
                parts = (arrays[f"layer{i}.{stage}.{n}"] for n in ("weight", "bias", "delta"))
                stages[stage] = Affine(*parts)
        params.append(LayerParams(spec, grid, stages["reduce"], stages.get("expand")))
    try:
        return HierarchicalSFA.from_layer_params(
            params,
            input_shape,
            n_outputs=model_args["n_outputs"],
            weight_sharing=model_args["weight_sharing"],
            clip=model_args["clip"],
            dtype=model_args["dtype"],
            fit_method=model_args["fit_method"],
            n_training_views=model_args["n_training_views"],
            progress=False,
        )
    except (TypeError, ValueError) as err:
        raise _BadModel(str(err)) from None


def _check_inflation(info: zipfile.ZipInfo) -> None:
    if info.compress_type == zipfile.ZIP_STORED:
        if info.file_size != info.compress_size:
            raise _BadModel(
                f"member {info.filename!r} is stored uncompressed but declares "
                f"{info.file_size} bytes in {info.compress_size}"
            )
    elif info.file_size > MAX_COMPRESSION_RATIO * max(info.compress_size, 1):
        raise _BadModel(
            f"member {info.filename!r} would inflate from {info.compress_size} to "
            f"{info.file_size} bytes (more than {MAX_COMPRESSION_RATIO} times): refused"
        )


def _npy_header(
    file: IO[bytes],
    info: zipfile.ZipInfo,
    key: str,
    dtype: np.dtype[Any] | None,
    shape: tuple[int, ...],
) -> tuple[bool, np.dtype[Any]]:
    """Read the ``.npy`` header at the start of ``file`` and check it against the expected
    ``dtype`` (None: any but objects) and ``shape`` and against the member's size; returns
    whether the data is in Fortran order and its dtype (``file`` is left at the data)."""
    try:
        got_shape, fortran, got_dtype = read_npy_header(file)
    except ValueError as err:
        raise _BadModel(f"member {key!r} is not a .npy array ({err})") from None
    if got_dtype.hasobject or (dtype is not None and got_dtype != dtype):
        want = "unicode text" if dtype is None else dtype.name
        raise _BadModel(f"array {key!r} has dtype {got_dtype}, expected {want}")
    if tuple(got_shape) != shape:
        raise _BadModel(f"array {key!r} has shape {tuple(got_shape)}, expected {shape}")
    data_bytes = math.prod(got_shape) * got_dtype.itemsize
    if info.file_size != file.tell() + data_bytes:
        raise _BadModel(
            f"member {info.filename!r} holds {info.file_size} bytes, but its header declares "
            f"{tuple(got_shape)} {got_dtype} ({file.tell() + data_bytes} bytes with the header)"
        )
    return bool(fortran), got_dtype


@contextlib.contextmanager
def _member(archive: zipfile.ZipFile, info: zipfile.ZipInfo, key: str) -> Iterator[IO[bytes]]:
    """The member opened for reading; a checksum error becomes an error naming the array (a
    small member is read whole, and its checksum checked, with its first bytes)."""
    try:
        with archive.open(info) as file:
            yield file
    except zipfile.BadZipFile as err:
        raise _BadModel(f"array {key!r} is corrupt ({err})") from None


def _read_data(file: IO[bytes], key: str, shape: tuple[int, ...], fortran: bool) -> np.ndarray:
    count = math.prod(shape)
    data = file.read(count * 8)
    if len(data) != count * 8:
        raise _BadModel(f"array {key!r} is truncated")
    return np.frombuffer(data, dtype="<f8").reshape(shape, order="F" if fortran else "C").copy()


def _read_header(archive: zipfile.ZipFile, info: zipfile.ZipInfo) -> Any:
    if info.file_size > MAX_HEADER_BYTES:
        raise _BadModel(f"the header member holds {info.file_size} bytes; a header is a few kB")
    with _member(archive, info, "header") as file:
        _, dtype = _npy_header(file, info, "header", None, ())
        if dtype.kind != "U":
            raise _BadModel(f"the header has dtype {dtype}, expected unicode text")
        data = file.read(dtype.itemsize)
    if len(data) != dtype.itemsize:
        raise _BadModel("the header is truncated")
    try:
        return json.loads(str(np.frombuffer(data, dtype=dtype)[0]))
    except (json.JSONDecodeError, UnicodeError) as err:
        raise _BadModel(f"the header is not valid JSON ({err})") from None


def _parse_header(header: Any) -> tuple[dict[str, Any], dict[str, tuple[int, ...]]]:
    """The model's arguments and the expected array shapes, from a parsed header."""
    try:
        version = check_format_header(header, FORMAT, FORMAT_VERSION, "an sfa-gym model file")
    except ValueError as err:
        raise _BadModel(str(err)) from None
    try:
        arch = header["architecture"]
        layers = [
            LayerSpec(
                field=tuple(d["field"]),
                stride=tuple(d["stride"]),
                reduce_dim=d["reduce_dim"],
                out_dim=d["out_dim"],
                expansion=d["expansion"],
                wrap=d["wrap"],
            )
            for d in arch["layers"]
        ]
        sharing = arch["weight_sharing"]
        if version == 1:
            if not isinstance(sharing, bool | str) or sharing not in _SHARING_V1:
                raise ValueError(f"weight_sharing {sharing!r} is not true, false or 'rows'")
            sharing = _SHARING_V1[sharing]
        sharing = check_weight_sharing(sharing)
        input_shape = tuple(int(v) for v in header["input_shape"])
        if len(input_shape) != 3 or input_shape[2] != 3:
            raise ValueError(f"input_shape {input_shape} is not (H, W, 3)")
        grids = layer_grids(layers, input_shape[0], input_shape[1])
        if [list(g) for g in grids] != header["grids"]:
            raise ValueError(f"grids {header['grids']} do not match the architecture ({grids})")
        node_dims = [tuple(int(v) for v in d) for d in header["node_dims"]]
        if len(node_dims) != len(layers) or any(len(d) != 2 for d in node_dims):
            raise ValueError(f"node_dims must hold [r, o] for each of the {len(layers)} layers")
        expected = {}
        channels = 3
        for i, (spec, grid, (r, o)) in enumerate(zip(layers, grids, node_dims, strict=True)):
            try:
                shapes = affine_shapes(spec, grid, sharing, channels, r, o)
            except ValueError as err:
                raise ValueError(f"layer {i + 1}: {err}") from None
            for stage, arrays in shapes.items():
                for name, shape in arrays.items():
                    expected[f"layer{i + 1}.{stage}.{name}"] = shape
            channels = o
        args = {
            "layers": layers,
            "grids": grids,
            "input_shape": input_shape,
            "n_outputs": arch["n_outputs"],
            "weight_sharing": sharing,
            "clip": arch["clip"],
            "dtype": arch["dtype"],
            "fit_method": header.get("fit_method"),
            "n_training_views": header.get("n_training_views"),
        }
    except (KeyError, TypeError, ValueError) as err:
        raise _BadModel(f"invalid header ({type(err).__name__}: {err})") from None
    return args, expected
