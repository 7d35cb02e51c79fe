"""Architecture of a hierarchical SFA network: one :class:`LayerSpec` per layer.

Geometry. Layer 1 sees the image as a ``H x W`` grid of pixels with 3 channels; layer ``l+1``
sees the ``R_l x C_l`` grid of layer-``l`` nodes, each with that layer's output dimension as
channels. A node at grid position ``(r, j)`` reads the ``field`` rows ``r*sr .. r*sr+fr-1`` and
columns ``j*sc .. j*sc+fc-1`` of the grid below, flattened in (row, column, channel) order.
Rows never wrap: ``R = (R_in - fr) // sr + 1``. Columns wrap around when ``wrap`` is set (the
panorama is periodic in width): ``C = C_in / sc``, which must be a whole number so that the
grid above is again periodic; otherwise ``C = (C_in - fc) // sc + 1``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from sfa_gym._checks import check_positive_int
from sfa_gym.sfa.expansion import n_quadratic_features

__all__ = ["LayerSpec", "MAX_NODE_DIM", "layer_grids", "describe"]

MAX_NODE_DIM = 300
"""Cap on a node's output dimension (the paper's limit, for numerical stability)."""

EXPANSIONS = ("quadratic", "none")


def _pair(value: object, name: str) -> tuple[int, int]:
    if (
        not isinstance(value, tuple | list)
        or len(value) != 2
        or not all(isinstance(v, int | np.integer) and not isinstance(v, bool) for v in value)
        or min(value) < 1
    ):
        raise ValueError(f"{name} must be a pair of positive ints (rows, cols), got {value!r}")
    return int(value[0]), int(value[1])


@dataclass(frozen=True)
class LayerSpec:
    """One layer of a converging SFA hierarchy (all nodes of a layer have the same shape).

    Each node: linear SFA to ``reduce_dim`` outputs -> quadratic expansion -> SFA to ``out_dim``
    outputs (with ``expansion="none"``: a single linear SFA to ``min(reduce_dim, out_dim)``).

    Attributes:
        field: receptive field ``(rows, cols)`` in units of the layer below (pixels for
            layer 1, nodes of the layer below otherwise).
        stride: ``(rows, cols)`` step between neighbouring nodes, same units.
        reduce_dim: output dimension of the node's first, linear SFA.
        out_dim: the node's output dimension, at most 300.
        expansion: ``"quadratic"`` or ``"none"``.
        wrap: columns are periodic (the panorama wraps around in width); rows never wrap.
    """

    field: tuple[int, int]
    stride: tuple[int, int]
    reduce_dim: int
    out_dim: int
    expansion: str = "quadratic"
    wrap: bool = True

    def __post_init__(self) -> None:
        object.__setattr__(self, "field", _pair(self.field, "field"))
        object.__setattr__(self, "stride", _pair(self.stride, "stride"))
        for name in ("reduce_dim", "out_dim"):
            object.__setattr__(self, name, check_positive_int(name, getattr(self, name)))
        if self.out_dim > MAX_NODE_DIM:
            raise ValueError(
                f"out_dim must be at most {MAX_NODE_DIM} (node dimensions are capped for "
                f"numerical stability), got {self.out_dim}"
            )
        if self.expansion not in EXPANSIONS:
            raise ValueError(f"expansion must be one of {EXPANSIONS}, got {self.expansion!r}")
        if not isinstance(self.wrap, bool | np.bool_):
            raise ValueError(f"wrap must be a bool, got {self.wrap!r}")
        object.__setattr__(self, "wrap", bool(self.wrap))

    @property
    def node_out_dim(self) -> int:
        """Nominal output dimension of a node (before any rank-deficiency cap)."""
        return self.out_dim if self.expansion == "quadratic" else min(self.reduce_dim, self.out_dim)


def layer_grids(layers: Sequence[LayerSpec], height: int, width: int) -> list[tuple[int, int]]:
    """Node grid ``(rows, cols)`` of every layer for a ``height x width`` input image.

    Raises:
        ValueError: a field does not fit in the grid below, or a wrapping layer's column
            stride does not divide the width of the grid below. The message names the layer.
    """
    if not layers:
        raise ValueError("a network needs at least one layer")
    grids = []
    rows, cols = int(height), int(width)
    unit = "pixels"
    for i, spec in enumerate(layers, start=1):
        if not isinstance(spec, LayerSpec):
            raise TypeError(f"layer {i} must be a LayerSpec, got {type(spec).__name__}")
        fr, fc = spec.field
        sr, sc = spec.stride
        if fr > rows or fc > cols:
            raise ValueError(
                f"layer {i}: field {spec.field} does not fit in the {rows} x {cols} grid of "
                f"{unit} below it"
            )
        if spec.wrap:
            if cols % sc != 0:
                raise ValueError(
                    f"layer {i}: with wrap=True the column stride {sc} must divide the width "
                    f"{cols} of the grid below ({unit}) so that the layer stays periodic; "
                    f"choose a stride among {[d for d in range(1, cols + 1) if cols % d == 0]}"
                )
            new_cols = cols // sc
        else:
            new_cols = (cols - fc) // sc + 1
        rows = (rows - fr) // sr + 1
        cols = new_cols
        grids.append((rows, cols))
        unit = f"layer-{i} nodes"
    return grids


def describe(layers: Sequence[LayerSpec], input_shape: tuple[int, int, int]) -> str:
    """Human-readable table of the grids and nominal node dimensions for an input shape."""
    h, w, c = input_shape
    grids = layer_grids(layers, h, w)
    lines = [f"input {h} x {w} x {c}"]
    channels = c
    for i, (spec, (r, col)) in enumerate(zip(layers, grids, strict=True), start=1):
        in_dim = spec.field[0] * spec.field[1] * channels
        red = min(spec.reduce_dim, in_dim)
        if spec.expansion == "quadratic":
            dims = f"{in_dim} -> {red} -> {n_quadratic_features(red)} -> {spec.out_dim}"
        else:
            dims = f"{in_dim} -> {spec.node_out_dim}"
        lines.append(
            f"layer {i}: {r} x {col} nodes, field {spec.field[0]}x{spec.field[1]}, "
            f"stride {spec.stride[0]}x{spec.stride[1]}{', wrap' if spec.wrap else ''}; "
            f"dims {dims}"
        )
        channels = spec.node_out_dim
    return "\n".join(lines)
