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

Reading an untrusted file: :func:`sfa_gym.files.read_npz` checks every member against the
header's architecture (names, dtypes, shapes, sizes) before reading any data. The weights are then
checked by :meth:`~sfa_gym.sfa.network.HierarchicalSFA.from_layer_params` (finite, and small
enough that no input makes the features overflow).
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from typing import Any

import numpy as np
from sklearn.utils.validation import check_is_fitted

from sfa_gym.files import load_error, read_npz, write_npz
from sfa_gym.sfa._layers import Affine, LayerParams
from sfa_gym.sfa._weights import affine_shapes, check_weight_sharing
from sfa_gym.sfa.network import HierarchicalSFA
from sfa_gym.sfa.spec import LayerSpec, layer_grids

__all__ = ["FORMAT", "FORMAT_VERSION", "architecture", "load_model", "save_model"]

FORMAT = "sfa-gym-model"
FORMAT_VERSION = 2
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
    arrays: dict[str, np.ndarray] = {}
    for i, p in enumerate(params, start=1):
        for stage, aff in (("reduce", p.reduce), ("expand", p.expand)):
            if aff is None:
                continue
            for name in ("weight", "bias", "delta"):
                arrays[f"layer{i}.{stage}.{name}"] = np.asarray(getattr(aff, name), np.float64)
    write_npz(path, header, arrays)


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
    args, arrays = read_npz(path, "SFA model", FORMAT, FORMAT_VERSION, _parse_header)
    input_shape = args["input_shape"]
    try:
        if expected_input_shape is not None and tuple(expected_input_shape) != input_shape:
            raise ValueError(
                f"the model takes views of shape {input_shape}, "
                f"expected {tuple(expected_input_shape)}"
            )
        params = []
        for i, (spec, grid) in enumerate(zip(args["layers"], args["grids"], strict=True), start=1):
            stages = {}
            for stage in ("reduce", "expand"):
                if f"layer{i}.{stage}.weight" in arrays:
                    parts = (arrays[f"layer{i}.{stage}.{n}"] for n in ("weight", "bias", "delta"))
                    stages[stage] = Affine(*parts)
            params.append(LayerParams(spec, grid, stages["reduce"], stages.get("expand")))
        return HierarchicalSFA.from_layer_params(
            params,
            input_shape,
            n_outputs=args["n_outputs"],
            weight_sharing=args["weight_sharing"],
            clip=args["clip"],
            dtype=args["dtype"],
            fit_method=args["fit_method"],
            n_training_views=args["n_training_views"],
            progress=False,
        )
    except (TypeError, ValueError) as err:
        raise load_error("SFA model", path, err) from None


def _parse_header(
    header: dict[str, Any], version: int
) -> tuple[dict[str, Any], dict[str, tuple[str, tuple[int, ...]]]]:
    """The model's arguments and the expected arrays, name -> (dtype, shape), from a header."""
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
                expected[f"layer{i + 1}.{stage}.{name}"] = ("<f8", shape)
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
    return args, expected
