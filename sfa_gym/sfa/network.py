"""Hierarchical SFA: a converging network of SFA nodes on 2-d grids (Franzius et al. 2007,
Metka et al. 2013).

Nodes. Every node maps its input vector (its receptive field in the layer below, flattened in
(row, column, channel) order) through: linear SFA to ``reduce_dim`` outputs (centred, whitened,
ordered by slowness) -> quadratic expansion (degree 1 and 2 monomials) -> SFA to ``out_dim``
outputs -> clipping to ``[-clip, clip]`` (every layer except the top). The clip bounds the
outputs of intermediate nodes on data unlike the training data, which the next quadratic
expansion would otherwise amplify; on training data the outputs have unit variance, so with the
default ``clip=4`` it rarely acts. No noise is added anywhere: training is deterministic.

Training is layer-wise and streamed: for each layer, one pass over the data gathers the
statistics of its linear SFA, a second pass those of its expanded SFA. The layer's input (the
output of the fitted layers below, for all training data) is kept in memory between the two
passes if it fits in ``cache_mb``, else recomputed chunk by chunk. Expanded data never exists
beyond one chunk; covariances are summed in float64. Training views in time order (``fit``)
get the second moments of their samples and of their time differences from one set of Gram
matrices (:meth:`~sfa_gym.sfa._moments.Moments.add_sequence`: about 1.07 products per sample
instead of 2); for the rotation shortcut, the second moments of expanded data are gathered from
its distinct fourth moments (:class:`~sfa_gym.sfa._moments.QuadraticGram`) where the BLAS
kernels make that faster.

Threads. Chunks are processed ``n_jobs`` at a time by a thread pool with BLAS single-threaded
(see :mod:`sfa_gym.sfa._parallel`: multi-threaded BLAS collapses on a machine shared with other
processes). Each chunk's statistics are kept apart and added in chunk order, so a model does
not depend on the number of threads, bit for bit; the same input gives the same output.

Sign convention: every node output, and so every returned feature, is signed so that it rises
on average over the training sequence (positive covariance with the index of the training
view; see :mod:`sfa_gym.sfa.linear`), which makes features comparable between runs.

Weight sharing (default, as in the paper): one node per layer, trained on the inputs of all its
grid positions pooled, then replicated. With ``weight_sharing="rows"`` the nodes of one grid row
share a node and every row learns its own: rows see different parts of the scene (sky, horizon,
ground), while along the periodic width all positions see the same statistics once every
rotation is trained on (a node trained on one column would see the patches of every column of
its row), so this is what individually learned nodes converge to under simulated rotation, at
the cost of one node per row. Without sharing (False) every position learns its own node
(statistics memory: nodes x 2 x dim^2 x 8 bytes per layer, e.g. 2.4 GB for 490 layer-1 nodes
of expanded dimension 560: use it with small layers).

Time differences are formed per node position between consecutive frames of a sequence.

Rotation shortcut (:meth:`HierarchicalSFA.fit_rotations`): with weight sharing (per layer or per
row) and a rotation step that is a multiple of layer 1's column stride ``s1``, rotating a
panorama by one step moves every layer-1 patch onto another layer-1 patch. Run on the *dense*
periodic grid (all ``n1 = W / s1`` column offsets, layer ``l`` reading layer ``l-1`` at column
spacing ``P_{l-1}`` = product of the column strides of layers 2..l-1), each layer is executed
once per location, and node ``j`` of layer ``l`` in view ``k`` is dense column
``(j P_l + k m) mod n1`` (``m = step / s1``). The statistics over all views are then weighted
statistics over the dense grid (the weight of a column = how many (view, node) pairs land on
it), plus the differences between consecutive views (columns ``o -> o + m``) and across
locations. This gives the same model as training on every rotated view (tested), at a fraction
of the cost. On the dense grid the inputs of neighbouring nodes of layers 2, 3, ... overlap, and
the second moments of their linear SFA are assembled from cross-correlations of the layer input,
each product of two input values formed once (:mod:`sfa_gym.sfa._periodic`).
"""

from __future__ import annotations

import json
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from functools import partial
from typing import Any

import numpy as np
from numpy.typing import NDArray
from tqdm.auto import tqdm

from sfa_gym.sfa._layers import Affine, LayerParams, layer_patches
from sfa_gym.sfa._moments import Moments, fourth_moments_pay_off, sequence_block
from sfa_gym.sfa._parallel import n_workers, ordered_map, single_threaded_blas
from sfa_gym.sfa._periodic import plan_weighted_gram
from sfa_gym.sfa.expansion import n_quadratic_features, quadratic_expand
from sfa_gym.sfa.linear import NotFittedError, RankDeficiencyWarning, sequence_starts, solve_sfa
from sfa_gym.sfa.spec import LayerSpec, layer_grids

__all__ = ["HierarchicalSFA", "shortcut_applies"]

Featurize = Callable[[NDArray[np.floating]], NDArray[np.floating]]

DEFAULT_RANK_TOL = {"float32": 1e-6, "float64": 1e-9}
"""Relative variance below which node input directions are dropped, per compute dtype
(float32 products carry ~1e-7 relative round-off, which must stay below the threshold)."""


def _check_views(views: Any, name: str = "views") -> NDArray[np.uint8]:
    if not isinstance(views, np.ndarray):
        raise TypeError(f"{name} must be a numpy array (N, H, W, 3) uint8, got {type(views)}")
    if views.dtype != np.uint8:
        raise TypeError(
            f"{name} must be uint8 RGB images (N, H, W, 3), got dtype {views.dtype}; "
            "convert with np.clip(x, 0, 255).astype(np.uint8) if they are float images in 0..255"
        )
    if views.ndim != 4 or views.shape[3] != 3:
        raise ValueError(f"{name} must have shape (N, H, W, 3), got {views.shape}")
    return views


class HierarchicalSFA:
    """Hierarchical SFA network for panoramic views (see the module docstring).

    Args:
        layers: the architecture, bottom layer first (see :mod:`sfa_gym.sfa.presets`). The last
            layer must have a single node covering the whole grid below.
        n_outputs: number of slowest top-node outputs returned by :meth:`transform`.
        weight_sharing: one node per layer replicated over the grid (True, the paper's
            choice), one node per grid row replicated along it (``"rows"``), or one node per
            grid position (False).
        clip: clip intermediate node outputs to ``[-clip, clip]`` (None: no clipping).
        dtype: ``"float32"`` (default: twice as fast; covariances still summed in float64) or
            ``"float64"`` for the layer activations and per-chunk products.
        rank_tol: relative covariance eigenvalue threshold below which node input directions
            are dropped (None: 1e-6 for float32, 1e-9 for float64).
        batch_size: frames (or panoramas, for the rotation shortcut) per chunk; None picks it
            from ``memory_mb``.
        memory_mb: target size of the working arrays of one chunk, in MB (up to ``n_jobs``
            chunks are processed at a time).
        cache_mb: while training layer ``l``, keep the output of layer ``l-1`` for all training
            data in memory if it fits in this many MB (it is read twice: by the linear and the
            expanded pass; otherwise it is recomputed from the lower layers each time).
        progress: show tqdm progress bars while training.
        n_jobs: threads for training and inference (None: all CPUs available to the process).
            Chunks of data are processed in parallel and their statistics combined in a fixed
            order, so the result is the same, bit for bit, for any ``n_jobs``; BLAS runs
            single-threaded meanwhile (see :mod:`sfa_gym.sfa._parallel` for why).

    Attributes (after fitting):
        input_shape_: ``(H, W, 3)`` of the training views.
        grids_: ``[(rows, cols)]`` node grid of every layer.
        layer_params_: fitted :class:`~sfa_gym.sfa._layers.LayerParams` per layer.
        delta_values_: ``(n_outputs,)`` delta values of the returned top outputs.
        fit_method_: ``"views"``, ``"rotations-shortcut"`` or ``"rotations-brute-force"``.
        n_training_views_: number of training views (rotated views count individually).
    """

    def __init__(
        self,
        layers: Sequence[LayerSpec],
        n_outputs: int = 8,
        weight_sharing: bool | str = True,
        *,
        clip: float | None = 4.0,
        dtype: str = "float32",
        rank_tol: float | None = None,
        batch_size: int | None = None,
        memory_mb: float = 256.0,
        cache_mb: float = 2048.0,
        progress: bool = True,
        n_jobs: int | None = None,
    ) -> None:
        self.layers = layers
        self.n_outputs = n_outputs
        self.weight_sharing = weight_sharing
        self.clip = clip
        self.dtype = dtype
        self.rank_tol = rank_tol
        self.batch_size = batch_size
        self.memory_mb = memory_mb
        self.cache_mb = cache_mb
        self.progress = progress
        self.n_jobs = n_jobs

    # -- parameters and geometry ------------------------------------------------------------
    def _validated_layers(self) -> list[LayerSpec]:
        layers = list(self.layers)
        if not layers:
            raise ValueError("layers must be a non-empty sequence of LayerSpec")
        for i, spec in enumerate(layers, start=1):
            if not isinstance(spec, LayerSpec):
                raise TypeError(f"layers[{i - 1}] must be a LayerSpec, got {type(spec).__name__}")
        k = self.n_outputs
        if isinstance(k, bool) or not isinstance(k, int | np.integer) or k < 1:
            raise ValueError(f"n_outputs must be a positive int, got {k!r}")
        if k > layers[-1].node_out_dim:
            raise ValueError(
                f"n_outputs={k} exceeds the top layer's output dimension {layers[-1].node_out_dim}"
            )
        if not (isinstance(self.weight_sharing, bool | np.bool_) or self.weight_sharing == "rows"):
            raise ValueError(
                f"weight_sharing must be True, False or 'rows', got {self.weight_sharing!r}"
            )
        if self.clip is not None and not (
            isinstance(self.clip, float | int) and not isinstance(self.clip, bool) and self.clip > 0
        ):
            raise ValueError(f"clip must be a positive number or None, got {self.clip!r}")
        if self.dtype not in DEFAULT_RANK_TOL:
            raise ValueError(f"dtype must be 'float32' or 'float64', got {self.dtype!r}")
        if self.rank_tol is not None and not (0 <= self.rank_tol < 1):
            raise ValueError(f"rank_tol must be in [0, 1) or None, got {self.rank_tol!r}")
        b = self.batch_size
        if b is not None and (isinstance(b, bool) or not isinstance(b, int | np.integer) or b < 1):
            raise ValueError(f"batch_size must be a positive int or None, got {b!r}")
        if not self.memory_mb > 0:
            raise ValueError(f"memory_mb must be positive, got {self.memory_mb!r}")
        if not self.cache_mb >= 0:
            raise ValueError(f"cache_mb must be >= 0, got {self.cache_mb!r}")
        j = self.n_jobs
        if j is not None and (isinstance(j, bool) or not isinstance(j, int | np.integer) or j < 1):
            raise ValueError(f"n_jobs must be a positive int or None, got {j!r}")
        return layers

    def _grids(self, layers: list[LayerSpec], height: int, width: int) -> list[tuple[int, int]]:
        grids = layer_grids(layers, height, width)
        if grids[-1] != (1, 1):
            raise ValueError(
                f"the top layer must have a single node, but for {height} x {width} input it "
                f"has a {grids[-1][0]} x {grids[-1][1]} grid; make its field cover the whole "
                f"grid of the layer below ({grids[-2] if len(grids) > 1 else (height, width)})"
            )
        return grids

    @property
    def _sharing(self) -> str:
        """``"layer"``, ``"rows"`` or ``"none"``."""
        if isinstance(self.weight_sharing, str):
            return "rows"
        return "layer" if self.weight_sharing else "none"

    @property
    def _np_dtype(self) -> type[np.floating]:
        return np.float32 if self.dtype == "float32" else np.float64

    def _workers(self) -> int:
        return n_workers(getattr(self, "n_jobs", None))

    def _layer_clip(self, index: int, n_layers: int) -> float | None:
        return None if index == n_layers - 1 else self.clip

    def _batch(self, per_item_bytes: float) -> int:
        if self.batch_size is not None:
            return int(self.batch_size)
        return max(1, int(self.memory_mb * 2**20 // max(per_item_bytes, 1.0)))

    def _item_bytes(self, layers: list[LayerSpec], grids, upto: int, n_cols=None) -> float:
        """Rough bytes of working arrays per frame when training layer ``upto``."""
        size = np.dtype(self._np_dtype).itemsize
        channels, worst = 3, 0.0
        for spec, (r, c) in zip(layers[: upto + 1], grids, strict=False):
            cols = c if n_cols is None else n_cols
            f = spec.field[0] * spec.field[1] * channels
            e = n_quadratic_features(min(spec.reduce_dim, f))
            worst = max(worst, r * cols * (2 * f + 3 * e + spec.out_dim) * size)
            channels = spec.node_out_dim
        return worst

    # -- training ---------------------------------------------------------------------------
    def fit(self, views: NDArray[np.uint8], sequence_ids: Any = None) -> HierarchicalSFA:
        """Train on ``views`` ``(N, H, W, 3)`` uint8, rows in time order.

        Args:
            views: training views (a ``np.memmap`` works: chunks are read as needed).
            sequence_ids: optional ``(N,)`` labels; no time difference is formed between
                consecutive rows whose labels differ (separate runs).
        """
        layers = self._validated_layers()
        views = _check_views(views)
        n, h, w, _ = views.shape
        if n < 2:
            raise ValueError(f"need at least 2 training views, got {n}")
        grids = self._grids(layers, h, w)
        starts = (
            np.zeros(n, dtype=bool) if sequence_ids is None else sequence_starts(sequence_ids, n)
        )
        starts[0] = True
        source = _ViewSource(lambda i0, i1: views[i0:i1], n, starts)
        self._train(layers, grids, (h, w, 3), source)
        self.fit_method_ = "views"
        self.n_training_views_ = int(n)
        return self

    def fit_rotations(
        self,
        panoramas: NDArray[np.uint8],
        step: int = 5,
        window: int | None = None,
        method: str = "auto",
    ) -> HierarchicalSFA:
        """Train on all simulated rotations of each panorama, in the paper's order.

        The training sequence is views ``k = 0 .. K-1`` of location 0, then of location 1, ...
        (one continuous sequence), view ``k`` being ``np.roll(p, -k * step, axis=1)`` cropped to
        its first ``window`` columns, ``K = W // step``.

        Args:
            panoramas: ``(L, H, W, 3)`` uint8, periodic in width.
            step: rotation step in columns; must divide ``W``.
            window: view width in columns (None: full 360 degree views).
            method: ``"auto"`` (the shortcut when it applies, see :func:`shortcut_applies`),
                ``"shortcut"`` (error if it does not apply) or ``"brute-force"`` (materialise
                every view chunk by chunk).
        """
        layers = self._validated_layers()
        panoramas = _check_views(panoramas, "panoramas")
        n_loc, h, w, _ = panoramas.shape
        if isinstance(step, bool) or not isinstance(step, int | np.integer) or not 1 <= step <= w:
            raise ValueError(f"step must be an int in [1, {w}] (columns), got {step!r}")
        if w % step:
            raise ValueError(
                f"the panorama width {w} is not a multiple of step {step}: the rotated views "
                "would not be periodic"
            )
        if window is None:
            window = w
        if isinstance(window, bool) or not isinstance(window, int | np.integer):
            raise ValueError(f"window must be an int (columns) or None, got {window!r}")
        if not 1 <= window <= w:
            raise ValueError(f"window must lie in [1, {w}], got {window}")
        if method not in ("auto", "shortcut", "brute-force"):
            raise ValueError(f"method must be 'auto', 'shortcut' or 'brute-force', got {method!r}")
        n_rot = w // step
        if n_loc * n_rot < 2:
            raise ValueError("need at least 2 training views (panoramas x rotations)")
        grids = self._grids(layers, h, window)
        why_not = _shortcut_obstacle(layers, w, step, window, self._sharing != "none")
        if method == "shortcut" and why_not:
            raise ValueError(f"the rotation shortcut does not apply: {why_not}")
        if method == "brute-force" or why_not:
            n = n_loc * n_rot

            def get(i0: int, i1: int) -> NDArray[np.uint8]:
                idx = np.arange(i0, i1)
                loc, k = idx // n_rot, idx % n_rot
                cols = (k[:, None] * step + np.arange(window)[None, :]) % w
                return panoramas[loc[:, None], :, cols].transpose(0, 2, 1, 3)

            starts = np.zeros(n, dtype=bool)
            starts[0] = True
            source: _Source = _ViewSource(get, n, starts)
            fit_method = "rotations-brute-force"
        else:
            source = _DenseRotationSource(panoramas, step, layers)
            fit_method = "rotations-shortcut"
        self._train(layers, grids, (h, window, 3), source)
        self.fit_method_ = fit_method
        self.n_training_views_ = int(n_loc * n_rot)
        return self

    def _train(
        self,
        layers: list[LayerSpec],
        grids: list[tuple[int, int]],
        input_shape: tuple[int, int, int],
        source: _Source,
    ) -> None:
        with single_threaded_blas():
            self._train_layers(layers, grids, input_shape, source)

    def _train_layers(
        self,
        layers: list[LayerSpec],
        grids: list[tuple[int, int]],
        input_shape: tuple[int, int, int],
        source: _Source,
    ) -> None:
        dtype = self._np_dtype
        workers = self._workers()
        tol = DEFAULT_RANK_TOL[self.dtype] if self.rank_tol is None else float(self.rank_tol)
        sharing = self._sharing
        params: list[LayerParams] = []
        channels = 3
        n_layers = len(layers)
        cache: NDArray[np.floating] | None = None
        cache_level = 0
        for li, (spec, grid) in enumerate(zip(layers, grids, strict=True)):
            f = spec.field[0] * spec.field[1] * channels
            groups = int(np.prod(node_grid(sharing, grid) or (1, 1)))
            quadratic = spec.expansion == "quadratic"
            red_dim = min(spec.reduce_dim, f) if quadratic else min(spec.node_out_dim, f)
            ctx = f"layer {li + 1}"
            job = _Pass(
                params=list(params),
                clips=[self._layer_clip(i, n_layers) for i in range(li)],
                sharing=sharing,
                dtype=dtype,
                # the chunk size follows layer 1 throughout: float32 products are summed over
                # a chunk, and larger chunks at the top (cached inputs would allow them) made
                # the slowest outputs measurably noisier
                batch=self._batch(self._item_bytes(layers, grids, li, source.dense_cols)),
                workers=workers,
                cache=cache,
                cache_level=cache_level,
            )
            desc = f"SFA layer {li + 1}/{n_layers}"
            if li > 0 and job.cache_level < li and self._cache_fits(source, job):
                # store this layer's input once instead of recomputing it in both passes
                with self._bar(f"{desc} input", source.n_blocks(job.batch)) as bar:
                    cache = source.outputs(job, bar)
                cache_level = li
                job = replace(job, cache=cache, cache_level=li)
            # raw pixels sit far from zero and need centring before float32 products; the
            # outputs of SFA nodes (and their expansion) are centred and white already
            moments = Moments(f, groups, center=li == 0)
            with self._bar(f"{desc} linear", source.n_blocks(job.batch)) as bar:
                source.accumulate(job, spec, grid, _features_first, moments, bar)
            reduce = _solve_layer(moments, red_dim, tol, f"{ctx} linear SFA", grid, sharing)
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
                with self._bar(f"{desc} expanded", source.n_blocks(job.batch)) as bar:
                    expanded = partial(_reduce_and_expand, reduce)
                    source.accumulate(job, spec, grid, expanded, moments, bar)
                expand = _solve_layer(
                    moments, spec.out_dim, tol, f"{ctx} expanded SFA", grid, sharing
                )
            params.append(LayerParams(spec, grid, reduce, expand))
            channels = params[-1].out_dim
        del cache
        if params[-1].out_dim < self.n_outputs:
            raise ValueError(
                f"the top node has only {params[-1].out_dim} non-degenerate outputs, fewer than "
                f"n_outputs={self.n_outputs}: train on more (or more varied) views"
            )
        self.layer_params_ = params
        self.grids_ = [tuple(g) for g in grids]
        self.input_shape_ = tuple(int(v) for v in input_shape)
        top = params[-1].expand or params[-1].reduce
        self.delta_values_ = np.asarray(top.delta, np.float64).reshape(-1)[: self.n_outputs]

    def _cache_fits(self, source: _Source, job: _Pass) -> bool:
        """Whether the input of the next layer, for all training items, fits in ``cache_mb``."""
        probe = source.layer_input(job, 0, 1)
        return probe.nbytes * source.n_items <= self.cache_mb * 2**20

    def _bar(self, desc: str, total: int) -> tqdm:
        return tqdm(total=total, desc=desc, disable=not self.progress, leave=False)

    # -- inference --------------------------------------------------------------------------
    def _check_fitted(self) -> list[LayerParams]:
        params = getattr(self, "layer_params_", None)
        if params is None:
            raise NotFittedError(
                "this HierarchicalSFA is not fitted yet: call fit, fit_rotations or load"
            )
        return params

    def transform(self, views: NDArray[np.uint8]) -> NDArray[np.float64]:
        """Slow features of ``views`` ``(N, H, W, 3)`` uint8 -> ``(N, n_outputs)`` float64."""
        params = self._check_fitted()
        views = _check_views(views)
        if tuple(views.shape[1:]) != self.input_shape_:
            raise ValueError(
                f"views have shape {tuple(views.shape[1:])} per frame, but the model was "
                f"trained on {self.input_shape_}"
            )
        n = views.shape[0]
        out = np.empty((n, self.n_outputs), dtype=np.float64)
        layers = [p.spec for p in params]
        batch = self._batch(self._item_bytes(layers, self.grids_, len(layers) - 1) / 2)
        # at least two chunks for threads to share, unless the batch is small; the split does not
        # depend on the number of threads, so neither do the results
        batch = max(min(batch, -(-n // 2)), min(n, 8), 1)
        workers = self._workers()

        def run(i0: int) -> None:
            a = self._forward(params, views[i0 : i0 + batch])
            out[i0 : i0 + a.shape[0]] = a[:, 0, 0, : self.n_outputs]

        with single_threaded_blas():
            for _ in ordered_map(run, range(0, n, batch), workers):
                pass
        return out

    def transform_rotations(
        self, panoramas: NDArray[np.uint8], step: int = 5
    ) -> NDArray[np.float64]:
        """Slow features of every simulated rotation of every panorama.

        Equal to ``transform`` of the views ``np.roll(p, -k * step, axis=1)[:, :W_model]`` for
        ``k < K = W // step``, but with the rotation shortcut (see the module docstring) when it
        applies: the layers below the top run once per panorama on the dense grid, the top node
        once per view. The paper averages estimates over these views.

        Args:
            panoramas: ``(L, H, W, 3)`` uint8 with ``H`` the model's input height and ``W`` at
                least its input width (``W`` itself for a model of 360 degree views).
            step: rotation step in columns; must divide ``W``.

        Returns:
            ``(L, K, n_outputs)`` float64.
        """
        params = self._check_fitted()
        panoramas = _check_views(panoramas, "panoramas")
        n_loc, h, w, _ = panoramas.shape
        window = self.input_shape_[1]
        if h != self.input_shape_[0] or w < window:
            raise ValueError(
                f"panoramas of shape {panoramas.shape[1:]} do not fit a model of input shape "
                f"{self.input_shape_}: need the same height and at least {window} columns"
            )
        if isinstance(step, bool) or not isinstance(step, int | np.integer) or not 1 <= step <= w:
            raise ValueError(f"step must be an int in [1, {w}] (columns), got {step!r}")
        if w % step:
            raise ValueError(f"the panorama width {w} is not a multiple of step {step}")
        n_rot = w // step
        out = np.empty((n_loc, n_rot, self.n_outputs))
        specs = [p.spec for p in params]
        if _shortcut_obstacle(specs, w, step, window, self._sharing != "none"):
            k = np.arange(n_rot)
            for i in range(n_loc):
                cols = (k[:, None] * step + np.arange(window)[None, :]) % w
                views = np.ascontiguousarray(panoramas[i][:, cols].transpose(1, 0, 2, 3))
                out[i] = self.transform(views)
            return out
        source = _DenseRotationSource(panoramas, step, specs)
        n_layers = len(params)
        job = _Pass(
            params=params[:-1],
            clips=[self._layer_clip(i, n_layers) for i in range(n_layers - 1)],
            sharing=self._sharing,
            dtype=self._np_dtype,
            batch=self._batch(self._item_bytes(specs, self.grids_, n_layers - 1, source.n1) / 2),
        )
        top = params[-1]
        cols = (np.arange(n_rot) * source.m) % source.n1  # dense column of the top node, view k
        workers = self._workers()
        batch = max(min(job.batch, -(-n_loc // 2)), 1)

        def run(chunk: tuple[int, int]) -> None:
            l0, l1 = chunk
            a = source.layer_input(job, l0, l1)
            x = source.node_inputs(n_layers - 1, top.spec, top.grid, a)[:, :, cols]
            out[l0:l1] = top.nodes(x, None)[:, 0, :, : self.n_outputs]

        with single_threaded_blas():
            for _ in ordered_map(run, source.chunks(batch), workers):
                pass
        return out

    def forward(self, views: NDArray[np.uint8], n_layers: int | None = None) -> NDArray[Any]:
        """Outputs of the first ``n_layers`` layers (all by default) for one batch of views.

        Returns the ``(N, R, C, D)`` output grid of the last layer computed (unclipped for the
        top layer), in the model's dtype; all top outputs, not only the first ``n_outputs``.
        """
        params = self._check_fitted()
        with single_threaded_blas():
            return self._forward(params, views, n_layers)

    def _forward(
        self, params: list[LayerParams], views: NDArray[Any], n_layers: int | None = None
    ) -> NDArray[Any]:
        a = np.asarray(views).astype(self._np_dtype)
        total = len(params)
        for i, p in enumerate(params[: total if n_layers is None else n_layers]):
            a = p.forward(a, self._layer_clip(i, total))
        return a

    # -- persistence ------------------------------------------------------------------------
    def save(self, path: Any) -> None:
        """Write the fitted model to one ``.npz`` file (see :mod:`sfa_gym.sfa.io`)."""
        from sfa_gym.sfa.io import save_model

        save_model(self, path)

    @classmethod
    def load(cls, path: Any, expected_input_shape: Sequence[int] | None = None) -> HierarchicalSFA:
        """Read a model written by :meth:`save` (see :func:`sfa_gym.sfa.io.load_model`)."""
        from sfa_gym.sfa.io import load_model

        return load_model(path, expected_input_shape=expected_input_shape)

    def __repr__(self) -> str:
        return (
            f"HierarchicalSFA({len(list(self.layers))} layers, n_outputs={self.n_outputs}, "
            f"weight_sharing={self.weight_sharing}, clip={self.clip}, dtype={self.dtype!r})"
        )

    def architecture(self) -> dict[str, Any]:
        """JSON-able description of the parameters (what :meth:`save` writes in its header)."""
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
                for s in self.layers
            ],
            "n_outputs": int(self.n_outputs),
            "weight_sharing": "rows" if self._sharing == "rows" else bool(self.weight_sharing),
            "clip": None if self.clip is None else float(self.clip),
            "dtype": self.dtype,
        }

    def __str__(self) -> str:
        return json.dumps(self.architecture())


def _features_first(x: NDArray[np.floating]) -> NDArray[np.floating]:
    """Node inputs ``(n, R, C, F)`` as a feature-major view ``(F, n, R, C)``."""
    return np.moveaxis(x, -1, 0)


def _reduce_and_expand(reduce: Affine, x: NDArray[np.floating]) -> NDArray[np.floating]:
    """Expanded linear-SFA outputs of node inputs ``(n, R, C, F)``: ``(E, n, R, C)``."""
    return quadratic_expand(reduce.apply(x), axis=0)


def _solve_layer(
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


# -- data sources -----------------------------------------------------------------------------
@dataclass(frozen=True)
class _Pass:
    """What one pass over the training data needs to know.

    The input of the layer being trained is the output of ``params`` (the fitted layers below)
    applied to the raw data; the first ``cache_level`` of them may already have been applied
    and stored in ``cache`` (one entry per frame or location).
    """

    params: list[LayerParams]
    clips: list[float | None]
    sharing: str  # "layer", "rows" or "none" (see HierarchicalSFA._sharing)
    dtype: type[np.floating]
    batch: int
    workers: int = 1
    cache: NDArray[np.floating] | None = None
    cache_level: int = 0


class _Source:
    """Streams training data through the fitted layers, chunk by chunk."""

    n_items: int
    dense_cols: int | None = None

    def n_blocks(self, batch: int) -> int:
        return -(-self.n_items // batch)

    def raw(self, i0: int, i1: int, dtype: type[np.floating]) -> NDArray[np.floating]:
        """Layer-1 input of items ``i0:i1`` as floats ``(n, H, W, 3)``."""
        raise NotImplementedError

    def run_layer(
        self, index: int, p: LayerParams, clip: float | None, a: NDArray[np.floating]
    ) -> NDArray[np.floating]:
        """Output of layer ``index`` on this source's grid."""
        return p.forward(a, clip)

    def node_inputs(
        self, index: int, spec: LayerSpec, grid: tuple[int, int], a: NDArray[np.floating]
    ) -> NDArray[np.floating]:
        """Node input vectors ``(n, R, C, F)`` of layer ``index`` for its input ``a``."""
        return layer_patches(spec, grid, a)

    def layer_input(self, job: _Pass, i0: int, i1: int) -> NDArray[np.floating]:
        """Input of the layer above ``job.params`` for items ``i0:i1``."""
        if job.cache is not None:
            a = job.cache[i0:i1]
        else:
            a = self.raw(i0, i1, job.dtype)
        for i in range(job.cache_level if job.cache is not None else 0, len(job.params)):
            a = self.run_layer(i, job.params[i], job.clips[i], a)
        return a

    def chunks(self, batch: int) -> list[tuple[int, int]]:
        """``[(i0, i1)]`` item ranges of at most ``batch`` items, in order."""
        return [(i0, min(i0 + batch, self.n_items)) for i0 in range(0, self.n_items, batch)]

    def outputs(self, job: _Pass, bar: tqdm) -> NDArray[np.floating]:
        """The input of the next layer for every item, stacked (to cache it)."""
        chunks = self.chunks(job.batch)
        first = self.layer_input(job, *chunks[0])
        out = np.empty((self.n_items, *first.shape[1:]), dtype=first.dtype)
        out[: len(first)] = first
        bar.update()

        def fill(chunk: tuple[int, int]) -> None:  # chunks write disjoint slices
            out[chunk[0] : chunk[1]] = self.layer_input(job, *chunk)

        for _ in ordered_map(fill, chunks[1:], job.workers):
            bar.update()
        return out

    def _accumulate_chunks(
        self,
        job: _Pass,
        moments: Moments,
        work: Callable[[tuple[int, int], Moments], tuple[Moments, Any, Any]],
        continues: Callable[[int], bool],
        bar: tqdm,
    ) -> None:
        """Run ``work(chunk, into)`` over all chunks and add the boundary differences.

        ``work`` adds a chunk's samples and inner differences to ``into`` and returns
        ``(into, head, tail)``: the features ``(F, 1, R, C)`` of its first and last item (the
        last view of a location for the rotation source). Unless the origin of ``moments`` is
        set already, the first chunk goes straight into ``moments`` (and sets it); the chunks
        run ``job.workers`` at a time on empty copies that are merged in chunk order, so the
        sums do not depend on the number of workers. The difference from one chunk's tail to
        the next chunk's head is added after the merge if ``continues(i0)`` (the next chunk
        continues the sequence; a ``work`` that adds that difference itself returns None for
        head and tail and passes a ``continues`` that is always False).
        """
        chunks = self.chunks(job.batch)
        if moments.shift is None:
            _, _, tail = work(chunks[0], moments)
            bar.update()
            chunks = chunks[1:]
        # statistics of many nodes (e.g. no weight sharing) are too large to copy per chunk:
        # those go straight into ``moments``, one chunk at a time
        separate = moments.n_groups * moments.n_features**2 * 16 <= _PARTIAL_BYTES
        workers = job.workers if separate else 1

        def task(chunk: tuple[int, int]) -> tuple[Moments, Any, Any]:
            return work(chunk, moments.partial() if separate else moments)

        for chunk, (part, head, new_tail) in zip(
            chunks, ordered_map(task, chunks, workers), strict=True
        ):
            if part is not moments:
                moments.merge(part)
            if continues(chunk[0]):
                moments.add_differences(_groups(head - tail, job.sharing))
            tail = new_tail
            bar.update()

    def accumulate(
        self,
        job: _Pass,
        spec: LayerSpec,
        grid: tuple[int, int],
        featurize: Featurize,
        moments: Moments,
        bar: tqdm,
    ) -> None:
        """Add the statistics of ``featurize(node inputs)`` of the layer above ``job.params``."""
        raise NotImplementedError


def _groups(x: NDArray[np.floating], sharing: str) -> NDArray[np.floating]:
    """``(F, n, R, C)`` -> ``(1, F, n*R*C)`` (one node per layer), ``(R, F, n*C)`` (one per
    row) or ``(R*C, F, n)`` (one per position), samples of a group in (n, C) order."""
    f, n, r, c = x.shape
    if sharing == "layer":
        return x.reshape(1, f, n * r * c)
    if sharing == "rows":
        return x.transpose(2, 0, 1, 3).reshape(r, f, n * c)
    return x.reshape(f, n, r * c).transpose(2, 0, 1)


def node_grid(sharing: str, grid: Sequence[int]) -> tuple[int, int] | None:
    """The distinct nodes of a layer whose node grid is ``grid``: None for one node per layer
    (``"layer"``), ``(R, 1)`` for one per row (``"rows"``), ``(R, C)`` for one per position
    (``"none"``). These are the leading axes of the layer's :class:`Affine` arrays."""
    rows, cols = int(grid[0]), int(grid[1])
    return {"layer": None, "rows": (rows, 1), "none": (rows, cols)}[sharing]


class _ViewSource(_Source):
    """Frames in time order (real or materialised rotated views), split into sequences."""

    def __init__(
        self, get: Callable[[int, int], NDArray[np.uint8]], n: int, starts: NDArray[np.bool_]
    ) -> None:
        self.get, self.n_items, self.starts = get, n, starts

    def raw(self, i0: int, i1: int, dtype: type[np.floating]) -> NDArray[np.floating]:
        return np.asarray(self.get(i0, i1)).astype(dtype)

    def accumulate(self, job, spec, grid, featurize, moments, bar) -> None:
        sharing = job.sharing
        li = len(job.params)

        def features(i0: int, i1: int) -> tuple[NDArray[np.floating], NDArray[np.floating]]:
            a = self.layer_input(job, i0, i1)
            return a, featurize(self.node_inputs(li, spec, grid, a))

        def work(chunk: tuple[int, int], into: Moments) -> tuple[Moments, Any, Any]:
            i0, i1 = chunk
            # the difference into this chunk from the frame before it is formed here, by the
            # worker, rather than after the merge (a serial step)
            before = features(i0 - 1, i0)[1].copy() if i0 and not self.starts[i0] else None
            a, x = features(i0, i1)
            f, n, r, c = x.shape
            if before is not None:
                into.add_differences(_groups(x[:, :1] - before, sharing))
            if into.n_groups == 1 and into.quadratic is None and sequence_block(n, r * c) > 1:
                # samples and differences of each run of one sequence from shared products
                samples_first = np.moveaxis(x, 0, -1).flags.c_contiguous
                if not (samples_first or x.flags.c_contiguous):
                    x = np.moveaxis(np.ascontiguousarray(np.moveaxis(x, 0, -1)), -1, 0)
                    samples_first = True
                own = not np.may_share_memory(x, a)  # a fresh array, not the cached input
                cuts = [0, *(np.flatnonzero(self.starts[i0 + 1 : i1]) + 1), n]
                for s0, s1 in zip(cuts[:-1], cuts[1:], strict=True):
                    if samples_first:
                        run = np.moveaxis(x[:, s0:s1], 0, -1).reshape(s1 - s0, r * c, f)
                    else:
                        run = x[:, s0:s1].reshape(f, s1 - s0, r * c)
                    into.add_sequence(run, float(i0 + s0), samples_first, overwrite=own)
                return into, None, None
            t = np.arange(i0, i1, dtype=np.float64)
            # every group takes the same number of samples from each frame
            into.add_samples(_groups(x, sharing), np.repeat(t, r * c // into.n_groups))
            inner = ~self.starts[i0 + 1 : i1]
            if inner.all():
                into.add_differences(_groups(x[:, 1:] - x[:, :-1], sharing))
            elif inner.any():
                into.add_differences(_groups(x[:, 1:][:, inner] - x[:, :-1][:, inner], sharing))
            return into, None, None

        # the origin from the first chunk up front, so that it too runs in parallel
        i0, i1 = self.chunks(job.batch)[0]
        x = _groups(features(i0, i1)[1], sharing) if moments.center else None
        per_frame = int(np.prod(grid)) // moments.n_groups  # samples of a group per frame
        moments.set_origin(x, np.repeat(np.arange(i0, i1, dtype=np.float64), per_frame))
        del x
        self._accumulate_chunks(job, moments, work, lambda i0: False, bar)


class _DenseRotationSource(_Source):
    """All rotated views of each panorama via the dense periodic grid (module docstring)."""

    def __init__(self, panoramas: NDArray[np.uint8], step: int, layers: list[LayerSpec]) -> None:
        w = panoramas.shape[2]
        s1 = layers[0].stride[1]
        self.panoramas = panoramas
        self.n_items = panoramas.shape[0]
        self.n1 = w // s1
        self.m = step // s1
        self.n_rot = w // step
        self.dense_cols = self.n1
        # column spacing, in layer-1 units, of neighbouring nodes of each layer
        self.unit = [int(u) for u in np.cumprod([1] + [s.stride[1] for s in layers[1:]])]

    def raw(self, i0: int, i1: int, dtype: type[np.floating]) -> NDArray[np.floating]:
        return self.panoramas[i0:i1].astype(dtype)

    def _geometry(self, index: int) -> dict[str, int]:
        if index == 0:
            return {"n_cols": self.n1}
        return {"n_cols": self.n1, "col_stride": 1, "col_dilation": self.unit[index - 1]}

    def run_layer(self, index, p, clip, a):
        return p.forward(a, clip, **self._geometry(index))

    def node_inputs(self, index, spec, grid, a):
        return layer_patches(spec, grid, a, **self._geometry(index))

    def accumulate(self, job, spec, grid, featurize, moments, bar) -> None:
        li = len(job.params)
        n1, m, n_rot = self.n1, self.m, self.n_rot
        k = np.arange(n_rot)[:, None]
        cols = (np.arange(grid[1])[None, :] * self.unit[li] + k * m) % n1  # (K, C): view k, node j
        kk = np.broadcast_to(k, cols.shape).astype(np.float64)
        w = np.bincount(cols.ravel(), minlength=n1).astype(np.float64)
        tk = np.bincount(cols.ravel(), weights=kk.ravel(), minlength=n1)
        tk2 = np.bincount(cols.ravel(), weights=(kk**2).ravel(), minlength=n1)
        pairs = np.bincount(cols[:-1].ravel(), minlength=n1).astype(np.float64)
        first, last = cols[0], cols[-1]
        # linear SFA of layers 2, 3, ...: products from cross-correlations of the layer input
        sharing = job.sharing
        plans = None
        if featurize is _features_first and li > 0 and sharing == "layer":
            geometry = {
                "rows_in": job.params[-1].grid[0],
                "channels": job.params[-1].out_dim,
                "field": spec.field,
                "row_stride": spec.stride[0],
                "n_rows": grid[0],
                "dilation": self.unit[li - 1],
            }
            plans = (plan_weighted_gram(w, **geometry), plan_weighted_gram(pairs, **geometry))
            if None in plans:
                plans = None

        def work(chunk: tuple[int, int], into: Moments) -> tuple[Moments, Any, Any]:
            l0, l1 = chunk
            a = self.layer_input(job, l0, l1)
            x = featurize(self.node_inputs(li, spec, grid, a))
            f, n_l, r, _ = x.shape  # (F, L, R, n1)
            # view k = location * K + k is the time index of every node of that view
            base = (np.arange(l0, l1, dtype=np.float64) * n_rot)[:, None, None]
            shape = (n_l, r // into.n_groups, n1)  # the samples of one group
            into.add_samples(
                _groups(x, sharing),
                times=np.broadcast_to(base * w + tk, shape).ravel(),
                weights=np.broadcast_to(w, shape).ravel(),
                times_sq=np.broadcast_to(base**2 * w + 2 * base * tk + tk2, shape).ravel(),
                outer=None if plans is None else plans[0].gram(a, lambda c: x[..., c])[None],
            )
            # consecutive views: dense column o -> o + m, weighted by how many node pairs
            if plans is None:
                d = np.empty_like(x)
                np.subtract(x[..., m:], x[..., : n1 - m], out=d[..., : n1 - m])
                np.subtract(x[..., :m], x[..., n1 - m :], out=d[..., n1 - m :])
                into.add_differences(_groups(d, sharing), np.broadcast_to(pairs, shape).ravel())
                del d
            else:
                # the node inputs of the difference field are the differences of node inputs
                da = np.take(a, (np.arange(n1) + m) % n1, axis=2) - a
                outer = plans[1].gram(da, lambda c: x[..., (c + m) % n1] - x[..., c])
                into.add_difference_moments(outer[None], n_l * r * float(pairs.sum()))
            # from the last view of one location to the first view of the next
            if n_l > 1:
                d = _take_cols(x[:, 1:], first) - _take_cols(x[:, :-1], last)
                into.add_differences(_groups(d, sharing))
            # copies: a view would keep the whole chunk alive until it is merged
            return into, _take_cols(x[:, :1], first).copy(), _take_cols(x[:, -1:], last).copy()

        self._accumulate_chunks(job, moments, work, lambda i0: True, bar)


def _take_cols(x: NDArray[np.floating], idx: NDArray[np.intp]) -> NDArray[np.floating]:
    """``x[..., idx]`` for ``idx`` made of a few increasing arithmetic runs, via slices
    (gathering element by element along the contiguous last axis is several times slower)."""
    parts: list[NDArray[np.floating]] = []
    i, n = 0, len(idx)
    while i < n:
        j = i + 1
        step = int(idx[j] - idx[i]) if j < n else 1
        if step <= 0:
            step, j = 1, i + 1  # a run of one
        else:
            while j < n and idx[j] - idx[j - 1] == step:
                j += 1
        parts.append(x[..., idx[i] : idx[j - 1] + 1 : step])
        if len(parts) > 4:
            return x[..., idx]
        i = j
    return parts[0] if len(parts) == 1 else np.concatenate(parts, axis=-1)


_PARTIAL_BYTES = 256 << 20
"""Largest statistics (all groups) copied per chunk so that chunks run in parallel."""


def _shortcut_obstacle(
    layers: Sequence[LayerSpec], width: int, step: int, window: int, weight_sharing: bool
) -> str:
    """Why the rotation shortcut cannot be used ('' if it can)."""
    s1 = layers[0].stride[1]
    if not weight_sharing:
        return "it needs weight sharing (individual nodes differ between grid positions)"
    if width % s1:
        return f"the panorama width {width} is not a multiple of layer 1's column stride {s1}"
    if step % s1:
        return f"the rotation step {step} is not a multiple of layer 1's column stride {s1}"
    if window < width and any(s.wrap for s in layers):
        return (
            f"the views are cropped to {window} of {width} columns but a layer wraps around "
            "(wrap=True): a cropped window is not periodic"
        )
    return ""


def shortcut_applies(
    layers: Sequence[LayerSpec],
    width: int,
    step: int = 5,
    window: int | None = None,
    weight_sharing: bool | str = True,
) -> bool:
    """Whether :meth:`HierarchicalSFA.fit_rotations` can use the dense rotation shortcut."""
    window = width if window is None else window
    return not _shortcut_obstacle(layers, width, step, window, weight_sharing is not False)
