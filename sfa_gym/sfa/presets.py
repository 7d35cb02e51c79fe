"""Ready-made network architectures (lists of :class:`LayerSpec`).

Layer 1 follows the paper: nodes see 10 x 10 RGB patches every 5 pixels, columns wrapping
around the periodic panorama. The upper layers converge to a single top node in four layers
(the paper's Fig. 2). Node dimensions are chosen so that the paper's outdoor scale trains in
minutes on two cores with the rotation shortcut: each node reduces to 32 dimensions by linear
SFA, expands quadratically to 560 and keeps 32 outputs (the top node keeps 32, of which the
network returns the slowest ``n_outputs``). ``describe(preset(), shape)`` prints the table.

``paper_sim()`` for 40 x 350 panoramas::

    layer 1: 7 x 70 nodes, field 10x10 px, stride 5x5, wrap; 300 -> 32 -> 560 -> 32
    layer 2: 3 x 14 nodes, field 3x10, stride 2x5, wrap;  960 -> 32 -> 560 -> 32
    layer 3: 1 x 7 nodes,  field 3x4,  stride 1x2, wrap;  384 -> 32 -> 560 -> 32
    layer 4: 1 x 1 node,   field 1x7,  stride 1x7, wrap;  224 -> 32 -> 560 -> 32

``paper_outdoor()`` for 60 x 600 panoramas::

    layer 1: 11 x 120 nodes, field 10x10 px, stride 5x5, wrap; 300 -> 32 -> 560 -> 32
    layer 2: 5 x 40 nodes,   field 3x6,  stride 2x3, wrap;  576 -> 32 -> 560 -> 32
    layer 3: 2 x 10 nodes,   field 3x8,  stride 2x4, wrap;  768 -> 32 -> 560 -> 32
    layer 4: 1 x 1 node,     field 2x10, stride 2x10, wrap; 640 -> 32 -> 560 -> 32

Training cost with the rotation shortcut grows with (dense grid rows) x (node input dim)^2 per
layer for the expanded SFA, so layer 2 of the outdoor network (the largest dense grid after
layer 1) gets a narrow field; a 3 x 10 field there (960 inputs) made training about 15 % slower
(measured before the linear SFA of layers 2-4 was computed from cross-correlations, which grow
only linearly with the field width).
"""

from __future__ import annotations

from sfa_gym.sfa.spec import LayerSpec, layer_grids

__all__ = ["paper_sim", "paper_outdoor", "tiny"]


def paper_sim(dim: int = 32, out_dim: int = 32) -> list[LayerSpec]:
    """Four layers for 40 x 350 panoramas (the paper's simulator); grids in the module doc.

    Args:
        dim: every node's linear SFA dimension (expanded dimension ``dim + dim(dim+1)/2``).
        out_dim: every node's output dimension.
    """
    return [
        LayerSpec(field=(10, 10), stride=(5, 5), reduce_dim=dim, out_dim=out_dim),
        LayerSpec(field=(3, 10), stride=(2, 5), reduce_dim=dim, out_dim=out_dim),
        LayerSpec(field=(3, 4), stride=(1, 2), reduce_dim=dim, out_dim=out_dim),
        LayerSpec(field=(1, 7), stride=(1, 7), reduce_dim=dim, out_dim=out_dim),
    ]


def paper_outdoor(dim: int = 32, out_dim: int = 32) -> list[LayerSpec]:
    """Four layers for 60 x 600 panoramas (the paper's outdoor camera); grids in the module doc."""
    return [
        LayerSpec(field=(10, 10), stride=(5, 5), reduce_dim=dim, out_dim=out_dim),
        LayerSpec(field=(3, 6), stride=(2, 3), reduce_dim=dim, out_dim=out_dim),
        LayerSpec(field=(3, 8), stride=(2, 4), reduce_dim=dim, out_dim=out_dim),
        LayerSpec(field=(2, 10), stride=(2, 10), reduce_dim=dim, out_dim=out_dim),
    ]


def tiny(height: int = 10, width: int = 40, dim: int = 6, out_dim: int = 8) -> list[LayerSpec]:
    """A small three-layer network for tests and quick experiments.

    Layer 1: 4 x 4 patches every 2 pixels (wrap); layer 2: 2 x 4 fields, stride 2 x 4 (wrap);
    layer 3: one node over the whole layer-2 grid. For the default 10 x 40 input the grids are
    4 x 20, 2 x 5 and 1 x 1. Rotation steps that are multiples of 2 use the shortcut.

    Args:
        height: input height in pixels, ``>= 6``.
        width: input width in pixels, a multiple of 8.
        dim: linear SFA dimension of every node.
        out_dim: output dimension of every node (the network's ``n_outputs`` must not exceed it).

    Raises:
        ValueError: the size does not fit the layout.
    """
    if height < 6 or width < 8 or width % 8:
        raise ValueError(
            f"tiny() needs height >= 6 and a width that is a multiple of 8, got {height} x {width}"
        )
    l1 = LayerSpec(field=(4, 4), stride=(2, 2), reduce_dim=dim, out_dim=out_dim)
    l2 = LayerSpec(field=(2, 4), stride=(2, 4), reduce_dim=dim, out_dim=out_dim)
    r2, c2 = layer_grids([l1, l2], height, width)[-1]
    top = LayerSpec(field=(r2, c2), stride=(r2, c2), reduce_dim=dim, out_dim=out_dim)
    return [l1, l2, top]
