"""Saving and loading fitted hierarchical SFA models: one ``.npz`` file, arrays only.

File layout (``np.savez``; read with ``allow_pickle=False``, so no code is ever executed):

- ``header``: 0-d unicode array holding a JSON object::

      {"format": "sfa-gym-model", "version": 1, "library_version": "0.1.0",
       "architecture": {"layers": [{"field": [10, 10], "stride": [5, 5], "reduce_dim": 32,
                                    "out_dim": 32, "expansion": "quadratic", "wrap": true}, ...],
                        "n_outputs": 8, "weight_sharing": true, "clip": 4.0, "dtype": "float32"},
       "input_shape": [40, 350, 3], "grids": [[7, 70], ...],
       "node_dims": [[32, 32], ...],           # [linear SFA outputs, node outputs] per layer
       "fit_method": "rotations-shortcut", "n_training_views": 43680}

- per layer ``i`` (1-based), float64: ``layer{i}.reduce.weight`` ``(F, r)``,
  ``layer{i}.reduce.bias`` ``(r,)``, ``layer{i}.reduce.delta`` ``(r,)``; with a quadratic
  expansion also ``layer{i}.expand.weight`` ``(r + r(r+1)/2, o)``, ``layer{i}.expand.bias``
  ``(o,)``, ``layer{i}.expand.delta`` ``(o,)``. A node computes
  ``y = x @ reduce.weight + reduce.bias``, then ``z = quad(y) @ expand.weight + expand.bias``.
  Without weight sharing every array has two leading axes ``(rows, cols)`` of the layer's grid.
  ``F`` = field rows x field cols x input channels, in (row, col, channel) order.
"""

from __future__ import annotations

import json
import os
import tempfile
import zipfile
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from sfa_gym.sfa._layers import Affine, LayerParams
from sfa_gym.sfa.expansion import n_quadratic_features
from sfa_gym.sfa.network import HierarchicalSFA, node_grid
from sfa_gym.sfa.spec import LayerSpec

__all__ = ["FORMAT", "FORMAT_VERSION", "save_model", "load_model"]

FORMAT = "sfa-gym-model"
FORMAT_VERSION = 1


def _library_version() -> str:
    from sfa_gym import __version__

    return __version__


def save_model(model: HierarchicalSFA, path: str | os.PathLike[str]) -> None:
    """Write a fitted model to ``path`` (exactly that name), atomically."""
    params = model._check_fitted()
    header = {
        "format": FORMAT,
        "version": FORMAT_VERSION,
        "library_version": _library_version(),
        "architecture": model.architecture(),
        "input_shape": list(model.input_shape_),
        "grids": [list(g) for g in model.grids_],
        "node_dims": [[p.reduce.out_dim, p.out_dim] for p in params],
        "fit_method": getattr(model, "fit_method_", None),
        "n_training_views": getattr(model, "n_training_views_", None),
    }
    arrays: dict[str, np.ndarray] = {"header": np.array(json.dumps(header))}
    for i, p in enumerate(params, start=1):
        for stage, aff in (("reduce", p.reduce), ("expand", p.expand)):
            if aff is None:
                continue
            for name in ("weight", "bias", "delta"):
                arrays[f"layer{i}.{stage}.{name}"] = np.asarray(getattr(aff, name), np.float64)
    path = Path(path)
    fd, tmp = tempfile.mkstemp(prefix=path.name + ".", suffix=".tmp", dir=path.parent or ".")
    try:
        with os.fdopen(fd, "wb") as fh:
            np.savez(fh, **arrays)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def _fail(path: Any, why: str) -> ValueError:
    return ValueError(f"cannot load SFA model {str(path)!r}: {why}")


def load_model(
    path: str | os.PathLike[str], expected_input_shape: Sequence[int] | None = None
) -> HierarchicalSFA:
    """Read a model written by :func:`save_model`.

    Args:
        path: the ``.npz`` file.
        expected_input_shape: if given, the ``(H, W, 3)`` the caller will feed; a model trained
            for another shape is rejected here rather than at the first ``transform``.

    Raises:
        FileNotFoundError: no such file.
        ValueError: not an sfa-gym model (foreign or corrupt file), a format version newer than
            this library reads, missing or misshapen arrays, or an input shape mismatch; the
            message says which.
    """
    if not Path(path).is_file():
        raise FileNotFoundError(f"no SFA model file at {str(path)!r}")
    try:
        with np.load(path, allow_pickle=False) as npz:
            arrays = {k: npz[k] for k in npz.files}
    except (zipfile.BadZipFile, OSError, ValueError, EOFError) as err:
        raise _fail(path, f"not a readable .npz archive ({err})") from None
    if "header" not in arrays:
        raise _fail(path, "no 'header' array: not an sfa-gym model file")
    try:
        header = json.loads(str(arrays.pop("header")))
    except (json.JSONDecodeError, TypeError) as err:
        raise _fail(path, f"the header is not valid JSON ({err})") from None
    if not isinstance(header, dict) or header.get("format") != FORMAT:
        got = header.get("format") if isinstance(header, dict) else type(header).__name__
        raise _fail(path, f"format is {got!r}, expected {FORMAT!r}: not an sfa-gym model file")
    version = header.get("version")
    if not isinstance(version, int) or version < 1:
        raise _fail(path, f"invalid format version {version!r}")
    if version > FORMAT_VERSION:
        raise _fail(
            path,
            f"format version {version} is newer than this sfa-gym {_library_version()} reads "
            f"(up to {FORMAT_VERSION}); upgrade sfa-gym (the file was written by "
            f"{header.get('library_version')!r})",
        )
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
        model = HierarchicalSFA(
            layers,
            n_outputs=arch["n_outputs"],
            weight_sharing=arch["weight_sharing"],
            clip=arch["clip"],
            dtype=arch["dtype"],
            progress=False,
        )
        model._validated_layers()
        input_shape = tuple(int(v) for v in header["input_shape"])
        node_dims = [tuple(int(v) for v in d) for d in header["node_dims"]]
        if len(input_shape) != 3 or input_shape[2] != 3:
            raise ValueError(f"input_shape {input_shape} is not (H, W, 3)")
        grids = model._grids(layers, input_shape[0], input_shape[1])
        if [list(g) for g in grids] != header["grids"]:
            raise ValueError(f"grids {header['grids']} do not match the architecture ({grids})")
        if len(node_dims) != len(layers):
            raise ValueError(f"{len(node_dims)} node_dims entries for {len(layers)} layers")
    except (KeyError, TypeError, ValueError) as err:
        raise _fail(path, f"invalid header ({type(err).__name__}: {err})") from None
    if expected_input_shape is not None and tuple(expected_input_shape) != input_shape:
        raise _fail(
            path,
            f"the model takes views of shape {input_shape}, expected {tuple(expected_input_shape)}",
        )
    params = []
    channels = 3
    for i, (spec, grid, (r, o)) in enumerate(zip(layers, grids, node_dims, strict=True), start=1):
        lead = node_grid(model._sharing, grid) or ()
        f = spec.field[0] * spec.field[1] * channels
        stages = {"reduce": (f, r)}
        if spec.expansion == "quadratic":
            stages["expand"] = (n_quadratic_features(r), o)
        elif o != r:
            raise _fail(path, f"layer {i} has no expansion but node_dims {[r, o]} differ")
        affines = {}
        for stage, (fin, fout) in stages.items():
            expected = {"weight": (*lead, fin, fout), "bias": (*lead, fout), "delta": (*lead, fout)}
            got = {}
            for name, shape in expected.items():
                key = f"layer{i}.{stage}.{name}"
                if key not in arrays:
                    raise _fail(path, f"missing array {key!r}")
                arr = arrays[key]
                if arr.shape != shape:
                    raise _fail(path, f"array {key!r} has shape {arr.shape}, expected {shape}")
                if arr.dtype.kind != "f" or not np.all(np.isfinite(arr)):
                    raise _fail(path, f"array {key!r} is not finite floating point data")
                got[name] = arr.astype(np.float64)
            affines[stage] = Affine(**got)
        params.append(LayerParams(spec, tuple(grid), affines["reduce"], affines.get("expand")))
        channels = o
    if params[-1].out_dim < model.n_outputs:
        raise _fail(path, f"the top layer has {params[-1].out_dim} < n_outputs outputs")
    model.layer_params_ = params
    model.grids_ = [tuple(g) for g in grids]
    model.input_shape_ = input_shape
    top = params[-1].expand or params[-1].reduce
    model.delta_values_ = top.delta.reshape(-1)[: model.n_outputs].astype(np.float64)
    model.fit_method_ = header.get("fit_method")
    model.n_training_views_ = header.get("n_training_views")
    return model
