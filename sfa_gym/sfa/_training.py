"""Layer-wise training of a hierarchical SFA network from a streamed source.

For each layer, bottom first: one pass over the source gathers the statistics of the nodes'
linear SFA, a second pass those of their expanded SFA; each node's eigenproblems are solved
once (:func:`~sfa_gym.sfa._weights.solve_layer`). The layer's input (the output of the fitted
layers below, for all training data) is kept in memory between the two passes if it fits in
``cache_mb``, else recomputed chunk by chunk. Chunk sizes follow from a memory budget
(:func:`chunk_size`, :func:`item_bytes`). Training views in time order (``fit``) get the second
moments of their samples and of their time differences from one set of Gram matrices
(:meth:`~sfa_gym.sfa._moments.Moments.add_sequence`: about 1.07 products per sample instead of
2); for the rotation shortcut, the second moments of expanded data are gathered from its
distinct fourth moments (:class:`~sfa_gym.sfa._moments.QuadraticGram`) where the BLAS kernels
make that faster.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace
from functools import partial

import numpy as np
from numpy.typing import NDArray
from tqdm.auto import tqdm

from sfa_gym.sfa._fourth import fourth_moments_pay_off
from sfa_gym.sfa._layers import LayerParams
from sfa_gym.sfa._moments import Moments
from sfa_gym.sfa._sources import Pass, Source, features_first, reduce_and_expand
from sfa_gym.sfa._weights import node_grid, solve_layer
from sfa_gym.sfa.expansion import n_quadratic_features
from sfa_gym.sfa.spec import LayerSpec

__all__ = ["chunk_size", "item_bytes", "layer_clips", "train_layers"]


def chunk_size(batch_size: int | None, memory_mb: float, per_item_bytes: float) -> int:
    """Items per chunk: ``batch_size`` if given, else as many as fit in ``memory_mb``."""
    if batch_size is not None:
        return int(batch_size)
    return max(1, int(memory_mb * 2**20 // max(per_item_bytes, 1.0)))


def item_bytes(
    layers: Sequence[LayerSpec],
    grids: Sequence[tuple[int, int]],
    upto: int,
    itemsize: int,
    n_cols: int | None = None,
) -> float:
    """Rough bytes of working arrays per frame when training (or running) layer ``upto``
    (``n_cols`` node columns per layer on the dense rotation grid, else the layer's own)."""
    channels, worst = 3, 0.0
    for spec, (r, c) in zip(layers[: upto + 1], grids, strict=False):
        cols = c if n_cols is None else n_cols
        f = spec.field[0] * spec.field[1] * channels
        e = n_quadratic_features(min(spec.reduce_dim, f))
        worst = max(worst, r * cols * (2 * f + 3 * e + spec.out_dim) * itemsize)
        channels = spec.node_out_dim
    return worst


def layer_clips(clip: float | None, n_layers: int) -> list[float | None]:
    """The clip of each layer's outputs: ``clip`` below the top, none at the top."""
    return [None if i == n_layers - 1 else clip for i in range(n_layers)]


def train_layers(
    source: Source,
    layers: Sequence[LayerSpec],
    grids: Sequence[tuple[int, int]],
    *,
    sharing: str,
    dtype: type[np.floating],
    rank_tol: float,
    clip: float | None,
    batch_size: int | None,
    memory_mb: float,
    cache_mb: float,
    workers: int,
    progress: bool,
) -> list[LayerParams]:
    """Fit every layer on ``source`` (see the module docstring); returns their parameters."""
    params: list[LayerParams] = []
    channels = 3
    n_layers = len(layers)
    clips = layer_clips(clip, n_layers)
    itemsize = np.dtype(dtype).itemsize
    cache: NDArray[np.floating] | None = None
    cache_level = 0

    def bar(desc: str, job: Pass) -> tqdm:
        total = source.n_blocks(job.batch)
        return tqdm(total=total, desc=desc, disable=not progress, leave=False)

    for li, (spec, grid) in enumerate(zip(layers, grids, strict=True)):
        f = spec.field[0] * spec.field[1] * channels
        groups = int(np.prod(node_grid(sharing, grid) or (1, 1)))
        quadratic = spec.expansion == "quadratic"
        red_dim = min(spec.reduce_dim, f) if quadratic else min(spec.node_out_dim, f)
        ctx = f"layer {li + 1}"
        per_item = item_bytes(layers, grids, li, itemsize, source.dense_cols)
        job = Pass(
            params=list(params),
            clips=clips[:li],
            sharing=sharing,
            dtype=dtype,
            # the chunk size follows layer 1 throughout: float32 products are summed over
            # a chunk, and larger chunks at the top (cached inputs would allow them) made
            # the slowest outputs measurably noisier
            batch=chunk_size(batch_size, memory_mb, per_item),
            workers=workers,
            cache=cache,
            cache_level=cache_level,
        )
        desc = f"SFA layer {li + 1}/{n_layers}"
        if li > 0 and job.cache_level < li and _cache_fits(source, job, cache_mb):
            # store this layer's input once instead of recomputing it in both passes
            with bar(f"{desc} input", job) as b:
                cache = source.outputs(job, b)
            cache_level = li
            job = replace(job, cache=cache, cache_level=li)
        # raw pixels sit far from zero and need centring before float32 products; the
        # outputs of SFA nodes (and their expansion) are centred and white already
        moments = Moments(f, groups, center=li == 0)
        with bar(f"{desc} linear", job) as b:
            source.accumulate(job, spec, grid, features_first, moments, b)
        reduce = solve_layer(moments, red_dim, rank_tol, f"{ctx} linear SFA", grid, sharing)
        expand = None
        if quadratic:
            k = reduce.out_dim
            # frames in time order get both Gram matrices from one set of products
            # (Moments.add_sequence), which saves more than the fourth moments would
            dense = source.dense_cols is not None
            fourth = sharing == "layer" and dense and fourth_moments_pay_off()
            moments = Moments(
                n_quadratic_features(k), groups, center=False, quadratic=k if fourth else None
            )
            with bar(f"{desc} expanded", job) as b:
                expanded = partial(reduce_and_expand, reduce)
                source.accumulate(job, spec, grid, expanded, moments, b)
            expand = solve_layer(
                moments, spec.out_dim, rank_tol, f"{ctx} expanded SFA", grid, sharing
            )
        params.append(LayerParams(spec, grid, reduce, expand))
        channels = params[-1].out_dim
    return params


def _cache_fits(source: Source, job: Pass, cache_mb: float) -> bool:
    """Whether the input of the next layer, for all training items, fits in ``cache_mb``."""
    probe = source.layer_input(job, 0, 1)
    return probe.nbytes * source.n_items <= cache_mb * 2**20
