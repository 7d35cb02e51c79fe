"""The weights of a fitted layer: solved from its statistics, their shapes per weight-sharing
mode, and the checks a set of weights passes before a network computes with it.

Weight sharing: ``"layer"`` (one node per layer), ``"rows"`` (one per grid row) or ``"none"``
(one per grid position); the distinct nodes are the leading axes of a layer's
:class:`~sfa_gym.sfa._layers.Affine` arrays (:func:`node_grid`).

Overflow. Weights read from a file may be finite and still make the features infinite (a value
of 1e30 times a pixel, squared by the expansion, leaves the float32 range). :func:`check_weights`
refuses them: with clipping every layer's input is bounded, and interval arithmetic
(:func:`output_bounds`) bounds every value the network computes, for any input; a fitted network
stays many orders of magnitude below the float32 range. Without clipping that bound compounds
from layer to layer and may exceed the range for working weights, so the network is run on a few
probe views instead (black, grey, white, noise), whose features must be finite.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from typing import Any, Literal, get_args

import numpy as np

from sfa_gym.sfa._layers import Affine, LayerParams
from sfa_gym.sfa._moments import Moments
from sfa_gym.sfa._parallel import single_threaded_blas
from sfa_gym.sfa.expansion import n_quadratic_features
from sfa_gym.sfa.linear import RankDeficiencyWarning, solve_sfa
from sfa_gym.sfa.spec import LayerSpec

__all__ = [
    "WEIGHT_SHARING",
    "WeightSharing",
    "affine_shapes",
    "check_weight_sharing",
    "check_weights",
    "layer_specs",
    "node_grid",
    "output_bounds",
    "solve_layer",
]

WeightSharing = Literal["layer", "rows", "none"]
"""Nodes that share weights: one per layer (the paper), one per grid row, or none (one node per
grid position)."""

WEIGHT_SHARING: tuple[str, ...] = get_args(WeightSharing)
"""The values of :data:`WeightSharing`."""


def check_weight_sharing(value: Any) -> str:
    """``value`` if it names a weight-sharing mode (``"layer"``, ``"rows"``, ``"none"``).

    Raises:
        ValueError: anything else, booleans included (``True`` was ``"layer"``, ``False``
            ``"none"``).
    """
    if isinstance(value, str) and value in WEIGHT_SHARING:
        return value
    hint = ""
    if isinstance(value, bool | np.bool_):
        hint = f" (for {bool(value)} use {'layer' if value else 'none'!r})"
    raise ValueError(
        f"weight_sharing must be one of 'layer', 'rows' or 'none', got {value!r}{hint}"
    )


def node_grid(sharing: str, grid: Sequence[int]) -> tuple[int, int] | None:
    """The distinct nodes of a layer whose node grid is ``grid``: None for one node per layer
    (``"layer"``), ``(R, 1)`` for one per row (``"rows"``), ``(R, C)`` for one per position
    (``"none"``). These are the leading axes of the layer's :class:`Affine` arrays."""
    rows, cols = int(grid[0]), int(grid[1])
    return {"layer": None, "rows": (rows, 1), "none": (rows, cols)}[sharing]


def affine_shapes(
    spec: LayerSpec,
    grid: Sequence[int],
    sharing: str,
    in_channels: int,
    reduce_dim: int,
    out_dim: int,
) -> dict[str, dict[str, tuple[int, ...]]]:
    """Shapes of a fitted layer's arrays: ``{"reduce": {"weight": .., "bias": .., "delta": ..},
    "expand": {...}}`` (no ``"expand"`` without expansion) for a layer reading ``in_channels``
    channels whose linear SFA keeps ``reduce_dim`` outputs and whose nodes output ``out_dim``.

    Raises:
        ValueError: the dimensions do not fit the layer's spec.
    """
    lead = node_grid(sharing, grid) or ()
    f = spec.field[0] * spec.field[1] * in_channels
    most = min(spec.reduce_dim if spec.expansion == "quadratic" else spec.node_out_dim, f)
    if not 1 <= reduce_dim <= most:
        raise ValueError(f"linear SFA dimension {reduce_dim} outside [1, {most}]")
    if not 1 <= out_dim <= spec.node_out_dim:
        raise ValueError(f"output dimension {out_dim} outside [1, {spec.node_out_dim}]")
    stages = {"reduce": (f, reduce_dim)}
    if spec.expansion == "quadratic":
        stages["expand"] = (n_quadratic_features(reduce_dim), out_dim)
    elif out_dim != reduce_dim:
        raise ValueError(f"no expansion, but dimensions {reduce_dim} and {out_dim} differ")
    return {
        stage: {"weight": (*lead, fin, fout), "bias": (*lead, fout), "delta": (*lead, fout)}
        for stage, (fin, fout) in stages.items()
    }


def solve_layer(
    moments: Moments, dim: int, tol: float, context: str, grid: tuple[int, int], sharing: str
) -> Affine:
    """Solve every node's SFA; individual nodes are cut to the smallest available dimension."""
    sols = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RankDeficiencyWarning)
        for g in range(moments.n_groups):
            try:
                sols.append(solve_sfa(moments.finish(g), dim, tol, context))
            except ValueError as err:
                names = {
                    "layer": "",
                    "rows": f" (row {g})",
                    "none": f" (node {divmod(g, grid[1])})",
                }
                where = names[sharing]
                raise ValueError(f"{err}{where}") from None
    k = min(s.projection.shape[1] for s in sols)
    dropped = max(s.n_dropped for s in sols)
    if dropped:
        nodes = "" if sharing == "layer" else f" (most in one of the {len(sols)} nodes)"
        cut = f"; only {k} outputs are available (asked for {dim})" if k < dim else ""
        warnings.warn(
            f"{context}: dropped {dropped} of {moments.n_features} input directions{nodes} "
            f"whose variance is below {tol:g} x the largest (constant or dependent inputs, or "
            f"too few training samples){cut}",
            RankDeficiencyWarning,
            stacklevel=5,  # the caller of fit or fit_rotations
        )
    return Affine.from_solutions(sols, k, node_grid(sharing, grid))


def _affine_bound(aff: Affine, bound: float) -> float:
    """Largest ``|x @ weight + bias|`` over nodes and outputs for inputs with ``|x| <= bound``."""
    with np.errstate(over="ignore", invalid="ignore"):
        total = bound * np.abs(aff.weight).sum(axis=-2) + np.abs(aff.bias)
        return float(total.max())


def output_bounds(
    params: Sequence[LayerParams], clip: float | None, input_bound: float = 255.0
) -> list[float]:
    """Per layer, a bound on the magnitude of every value computed for any input whose values
    lie in ``[-input_bound, input_bound]`` (uint8 pixels: 255): linear SFA outputs, their
    quadratic expansion and the node outputs before clipping. Interval arithmetic in float64
    (``inf`` where even that overflows); the clip of the layers below the top bounds the input
    of the next layer."""
    bounds = []
    bound = float(input_bound)
    for i, p in enumerate(params):
        out = worst = _affine_bound(p.reduce, bound)
        if p.expand is not None:
            expanded = max(out, out * out)
            out = _affine_bound(p.expand, expanded)
            worst = max(worst, expanded, out)
        bounds.append(worst)
        bound = out if clip is None or i == len(params) - 1 else min(out, float(clip))
    return bounds


def layer_specs(params: Sequence[LayerParams]) -> list[LayerSpec]:
    """The spec of every layer of ``params``, after checking they are :class:`LayerParams`."""
    for i, p in enumerate(params, start=1):
        if not isinstance(p, LayerParams):
            raise TypeError(f"layer {i}: expected LayerParams, got {type(p).__name__}")
    return [p.spec for p in params]


def check_weights(
    params: Sequence[LayerParams],
    grids: Sequence[tuple[int, int]],
    sharing: str,
    clip: float | None,
    dtype: type[np.floating],
    input_shape: tuple[int, int, int],
) -> None:
    """Check that fitted layers make a working network for views of ``input_shape``.

    Raises:
        ValueError: a layer's grid or array shapes do not fit the architecture or the layer
            below, an array is not finite floating point data, or some input would make a
            computed value overflow ``dtype`` (see the module docstring); the message names the
            layer and the array.
    """
    channels = 3
    for i, (p, grid) in enumerate(zip(params, grids, strict=True), start=1):
        if tuple(p.grid) != tuple(grid):
            raise ValueError(f"layer {i}: grid {p.grid}, expected {grid} for {input_shape}")
        try:
            shapes = affine_shapes(p.spec, grid, sharing, channels, p.reduce.out_dim, p.out_dim)
        except ValueError as err:
            raise ValueError(f"layer {i}: {err}") from None
        if (p.expand is not None) != ("expand" in shapes):
            raise ValueError(f"layer {i}: the expansion is {p.spec.expansion!r}, but expand is "
                             f"{'missing' if p.expand is None else 'given'}")  # fmt: skip
        for stage, expected in shapes.items():
            aff = getattr(p, stage)
            for name, want in expected.items():
                arr = getattr(aff, name)
                where = f"layer {i} {stage}.{name}"
                if not isinstance(arr, np.ndarray) or arr.shape != want:
                    got = getattr(arr, "shape", type(arr).__name__)
                    raise ValueError(f"{where} has shape {got}, expected {want}")
                if arr.dtype.kind != "f" or not np.all(np.isfinite(arr)):
                    raise ValueError(f"{where} is not finite floating point data")
        channels = p.out_dim
    _check_no_overflow(params, clip, dtype, input_shape)


def _check_no_overflow(
    params: Sequence[LayerParams],
    clip: float | None,
    dtype: type[np.floating],
    input_shape: tuple[int, int, int],
) -> None:
    limit = float(np.finfo(dtype).max) / 2  # room for rounding in the sums
    name = np.dtype(dtype).name
    for i, p in enumerate(params, start=1):
        for stage, aff in (("reduce", p.reduce), ("expand", p.expand)):
            if aff is not None:
                big = max(float(np.abs(aff.weight).max()), float(np.abs(aff.bias).max()))
                if big > limit:
                    raise ValueError(
                        f"layer {i} {stage} holds a weight of magnitude {big:.3g}, beyond the "
                        f"range of {name}: the features would not be finite"
                    )
    bounds = output_bounds(params, clip)
    bad = [(i, b) for i, b in enumerate(bounds, start=1) if not b <= limit]
    if not bad:
        return
    if clip is None:
        rng = np.random.default_rng(0)
        probe = [np.full(input_shape, v, np.uint8) for v in (0, 128, 255)]
        probe.append(rng.integers(0, 256, input_shape, dtype=np.uint8))
        a = np.stack(probe).astype(dtype)
        with np.errstate(all="ignore"), single_threaded_blas():
            for p in params:
                a = p.forward(a, None)
        if np.all(np.isfinite(a)):
            return
    i, b = bad[0]
    raise ValueError(
        f"the weights are too large: values computed in layer {i} can reach {b:.3g} for some "
        f"input, beyond the range of {name}, so the features would be infinite or NaN"
    )
