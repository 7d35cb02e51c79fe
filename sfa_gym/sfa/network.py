"""Hierarchical SFA: a converging network of SFA nodes on 2-d grids (Franzius et al. 2007,
Metka et al. 2013).

Nodes. Every node maps its input vector (its receptive field in the layer below, flattened in
(row, column, channel) order) through: linear SFA to ``reduce_dim`` outputs (centred, whitened,
ordered by slowness) -> quadratic expansion (degree 1 and 2 monomials) -> SFA to ``out_dim``
outputs -> clipping to ``[-clip, clip]`` (every layer except the top). The clip bounds the
outputs of intermediate nodes on data unlike the training data, which the next quadratic
expansion would otherwise amplify; on training data the outputs have unit variance, so with the
default ``clip=4`` it rarely acts. No noise is added anywhere: training is deterministic.

Training is layer-wise and streamed (:mod:`sfa_gym.sfa._training`): for each layer, one pass
over the data gathers the statistics of its linear SFA, a second pass those of its expanded
SFA; expanded data never exists beyond one chunk, covariances are summed in float64. The data
is streamed by the sources of :mod:`sfa_gym.sfa._sources`.

Threads (``n_jobs``) share the chunks; each chunk's statistics are added in chunk order, so a
model does not depend on the number of threads, bit for bit. Every feature rises on average
over the training sequence (the sign convention of :mod:`sfa_gym.sfa.linear`).

Weight sharing (``weight_sharing="layer"``, the default, as in the paper): one node per layer,
trained on the inputs of all its grid positions pooled, then replicated. With ``"rows"`` the
nodes of one grid row share a node and every row learns its own: rows see different parts of
the scene (sky, horizon, ground), while along the periodic width all positions see the same
statistics once every rotation is trained on (a node trained on one column would see the
patches of every column of its row), so this is what individually learned nodes converge to
under simulated rotation, at the cost of one node per row. Without sharing (``"none"``) every
position learns its own node (statistics memory: nodes x 2 x dim^2 x 8 bytes per layer, e.g.
2.4 GB for 490 layer-1 nodes of expanded dimension 560: use it with small layers). Time
differences are formed per node position between consecutive frames of a sequence.

The estimator is a scikit-learn transformer (``clone``, ``Pipeline`` and ``GridSearchCV``
work) whose input is images ``(N, H, W, 3)`` uint8 rather than a 2-d ``X``. Saving and loading:
:mod:`sfa_gym.sfa.io`, through :attr:`HierarchicalSFA.layer_params_` and
:meth:`HierarchicalSFA.from_layer_params`.

Rotation shortcut (:meth:`HierarchicalSFA.fit_rotations` and ``transform_rotations``): with
weight sharing (per layer or per row) and a rotation step that is a multiple of layer 1's column
stride, every rotated view of a panorama is covered by running each layer once per panorama on
a dense periodic grid (:mod:`sfa_gym.sfa._rotation_source`). It gives the same model as training on
every rotated view (tested), at a fraction of the cost.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from sklearn.base import BaseEstimator, TransformerMixin
from sklearn.utils import Tags
from sklearn.utils.validation import check_is_fitted

from sfa_gym._checks import check_positive_int
from sfa_gym._types import check_panoramas, check_views
from sfa_gym.rotation import (
    check_window,
    count_places,
    n_rotations,
    rotation_columns,
    rotation_sequence,
)
from sfa_gym.sfa._heap import kept_heap
from sfa_gym.sfa._layers import LayerParams
from sfa_gym.sfa._parallel import n_workers, ordered_map, single_threaded_blas
from sfa_gym.sfa._rotation_source import (
    DenseRotationSource,
    shortcut_applies,
    shortcut_obstacle,
)
from sfa_gym.sfa._sources import Pass, Source, ViewSource
from sfa_gym.sfa._training import chunk_size, item_bytes, layer_clips, train_layers
from sfa_gym.sfa._weights import (
    WEIGHT_SHARING,
    WeightSharing,
    check_weight_sharing,
    check_weights,
    layer_specs,
)
from sfa_gym.sfa.linear import sequence_starts
from sfa_gym.sfa.spec import LayerSpec, layer_grids

__all__ = [
    "HierarchicalSFA",
    "WEIGHT_SHARING",
    "WeightSharing",
    "check_weight_sharing",
    "shortcut_applies",
]

DEFAULT_RANK_TOL = {"float32": 1e-6, "float64": 1e-9}
"""Relative variance below which node input directions are dropped, per compute dtype
(float32 products carry ~1e-7 relative round-off, which must stay below the threshold)."""

FIT_METHODS = ("views", "rotations-shortcut", "rotations-brute-force")


class HierarchicalSFA(TransformerMixin, BaseEstimator):
    """Hierarchical SFA network for panoramic views (see the module docstring).

    A scikit-learn transformer of images: ``fit(views)`` and ``transform(views)`` take
    ``(N, H, W, 3)`` uint8 arrays; ``y`` is ignored (the network learns without labels), so it
    can stand in a ``Pipeline`` before a regressor.

    Args:
        layers: the architecture, bottom layer first (see :mod:`sfa_gym.sfa.presets`). The last
            layer must have a single node covering the whole grid below.
        n_outputs: number of slowest top-node outputs returned by :meth:`transform`.
        weight_sharing: ``"layer"``: one node per layer replicated over the grid (the paper's
            choice); ``"rows"``: one node per grid row replicated along it; ``"none"``: one
            node per grid position.
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
        n_jobs: threads for training and inference (None: all CPUs available to the process);
            the result is the same for any ``n_jobs``, bit for bit; BLAS runs single-threaded
            meanwhile (:mod:`sfa_gym.sfa._parallel` says why).

    Attributes (after fitting):
        input_shape_: ``(H, W, 3)`` of the training views.
        grids_: ``[(rows, cols)]`` node grid of every layer.
        layer_params_: fitted :class:`~sfa_gym.sfa._layers.LayerParams` per layer (the
            weights a model file holds; :meth:`from_layer_params` builds a model from them).
        delta_values_: ``(n_outputs,)`` delta values of the returned top outputs.
        fit_method_: ``"views"``, ``"rotations-shortcut"`` or ``"rotations-brute-force"``
            (None for a model built from weights whose training is unknown).
        n_training_views_: number of training views (rotated views count individually).
    """

    def __init__(
        self,
        layers: Sequence[LayerSpec],
        n_outputs: int = 8,
        weight_sharing: str = "layer",
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
        k = check_positive_int("n_outputs", self.n_outputs)
        if k > layers[-1].node_out_dim:
            raise ValueError(
                f"n_outputs={k} exceeds the top layer's output dimension {layers[-1].node_out_dim}"
            )
        check_weight_sharing(self.weight_sharing)
        if self.clip is not None and not (
            isinstance(self.clip, float | int) and not isinstance(self.clip, bool) and self.clip > 0
        ):
            raise ValueError(f"clip must be a positive number or None, got {self.clip!r}")
        if self.dtype not in DEFAULT_RANK_TOL:
            raise ValueError(f"dtype must be 'float32' or 'float64', got {self.dtype!r}")
        if self.rank_tol is not None and not (0 <= self.rank_tol < 1):
            raise ValueError(f"rank_tol must be in [0, 1) or None, got {self.rank_tol!r}")
        check_positive_int("batch_size", self.batch_size, none=True)
        if not self.memory_mb > 0:
            raise ValueError(f"memory_mb must be positive, got {self.memory_mb!r}")
        if not self.cache_mb >= 0:
            raise ValueError(f"cache_mb must be >= 0, got {self.cache_mb!r}")
        check_positive_int("n_jobs", self.n_jobs, none=True)
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
    def _np_dtype(self) -> type[np.floating]:
        return np.float32 if self.dtype == "float32" else np.float64

    def _workers(self) -> int:
        return n_workers(getattr(self, "n_jobs", None))

    def _batch(self, layers: list[LayerSpec], grids, upto: int, n_cols=None) -> int:
        """Items per chunk for running the layers up to ``upto`` (half the training budget:
        inference keeps fewer arrays per item)."""
        per_item = item_bytes(layers, grids, upto, np.dtype(self._np_dtype).itemsize, n_cols)
        return chunk_size(self.batch_size, self.memory_mb, per_item / 2)

    def __sklearn_tags__(self) -> Tags:
        tags = super().__sklearn_tags__()
        # images, not a 2-d X: tests/test_sfa_sklearn.py declares the checks that cannot apply
        tags.transformer_tags.preserves_dtype = []
        return tags

    # -- training ---------------------------------------------------------------------------
    def fit(
        self, views: NDArray[np.uint8], y: Any = None, sequence_ids: Any = None
    ) -> HierarchicalSFA:
        """Train on ``views`` ``(N, H, W, 3)`` uint8, rows in time order.

        Args:
            views: training views (a ``np.memmap`` works: chunks are read as needed).
            y: ignored (unsupervised); accepted for scikit-learn pipelines.
            sequence_ids: optional ``(N,)`` labels; no time difference is formed between
                consecutive rows whose labels differ (separate runs). Pass it by keyword.
        """
        del y
        layers = self._validated_layers()
        views = check_views(views, min_views=0)
        n, h, w, _ = views.shape
        if n < 2:
            raise ValueError(f"need at least 2 training views, got {n}")
        grids = self._grids(layers, h, w)
        starts = (
            np.zeros(n, dtype=bool) if sequence_ids is None else sequence_starts(sequence_ids, n)
        )
        starts[0] = True
        source = ViewSource(lambda i0, i1: views[i0:i1], n, starts)
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
        appearances: int = 1,
    ) -> HierarchicalSFA:
        """Train on all simulated rotations of each panorama, in the paper's order.

        The training sequence is views ``k = 0 .. K-1`` of location 0, then of location 1, ...
        (one continuous sequence), view ``k`` being ``np.roll(p, -k * step, axis=1)`` cropped to
        its first ``window`` columns, ``K = W // step`` (:mod:`sfa_gym.rotation`). With
        ``appearances = A > 1``, each run of ``A`` consecutive panoramas is one location seen
        under ``A`` appearances (runs recorded at other times, interleaved frame by frame), and
        each rotation of the location is seen under every appearance before the next
        rotation (:func:`~sfa_gym.rotation.rotation_sequence`): the appearance changes inside
        the location's rotation sequence, faster than the rotation.

        Args:
            panoramas: ``(L, H, W, 3)`` uint8, periodic in width.
            step: rotation step in columns; must divide ``W``.
            window: view width in columns (None: full 360 degree views).
            method: ``"auto"`` (the shortcut when it applies, see :func:`shortcut_applies`),
                ``"shortcut"`` (error if it does not apply) or ``"brute-force"`` (materialise
                every view chunk by chunk).
            appearances: how many consecutive panoramas show one location (at least 1; it
                must divide their number).
        """
        layers = self._validated_layers()
        panoramas = check_views(panoramas, "panoramas", min_views=0)
        n_loc, h, w, _ = panoramas.shape
        n_rot = n_rotations(w, step)
        window = check_window(w, window)
        if method not in ("auto", "shortcut", "brute-force"):
            raise ValueError(f"method must be 'auto', 'shortcut' or 'brute-force', got {method!r}")
        count_places(n_loc, appearances)
        if n_loc * n_rot < 2:
            raise ValueError("need at least 2 training views (panoramas x rotations)")
        grids = self._grids(layers, h, window)
        why_not = shortcut_obstacle(layers, w, step, window, self.weight_sharing)
        if method == "shortcut" and why_not:
            raise ValueError(f"the rotation shortcut does not apply: {why_not}")
        if method == "brute-force" or why_not:
            n = n_loc * n_rot
            columns = rotation_columns(w, step, window)  # (K, window)
            order_k, order_a = rotation_sequence(n_rot, appearances)

            def get(i0: int, i1: int) -> NDArray[np.uint8]:
                idx = np.arange(i0, i1)
                place, j = idx // len(order_k), idx % len(order_k)
                panorama = place * appearances + order_a[j]
                return panoramas[panorama[:, None], :, columns[order_k[j]]].transpose(0, 2, 1, 3)

            starts = np.zeros(n, dtype=bool)
            starts[0] = True
            source: Source = ViewSource(get, n, starts)
            fit_method = "rotations-brute-force"
        else:
            source = DenseRotationSource(panoramas, step, layers, appearances)
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
        source: Source,
    ) -> None:
        tol = DEFAULT_RANK_TOL[self.dtype] if self.rank_tol is None else float(self.rank_tol)
        with single_threaded_blas(), kept_heap():
            params = train_layers(
                source,
                layers,
                grids,
                sharing=self.weight_sharing,
                dtype=self._np_dtype,
                rank_tol=tol,
                clip=self.clip,
                batch_size=self.batch_size,
                memory_mb=self.memory_mb,
                cache_mb=self.cache_mb,
                workers=self._workers(),
                progress=self.progress,
            )
        self._set_fitted(params, grids, input_shape)

    def _set_fitted(
        self,
        params: list[LayerParams],
        grids: Sequence[tuple[int, int]],
        input_shape: tuple[int, int, int],
    ) -> None:
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

    # -- a fitted model from its weights ----------------------------------------------------
    @classmethod
    def from_layer_params(
        cls,
        layer_params: Sequence[LayerParams],
        input_shape: Sequence[int],
        *,
        n_outputs: int = 8,
        weight_sharing: str = "layer",
        clip: float | None = 4.0,
        dtype: str = "float32",
        fit_method: str | None = None,
        n_training_views: int | None = None,
        progress: bool = True,
        n_jobs: int | None = None,
    ) -> HierarchicalSFA:
        """A fitted model from fitted layers (e.g. those of a model file, see
        :func:`sfa_gym.sfa.io.load_model`), after checking that they make a working network.

        Args:
            layer_params: per layer, its spec, node grid and weights (the ``layers`` parameter
                of the model is their specs).
            input_shape: ``(H, W, 3)`` of the views the model takes.
            n_outputs: this and ``weight_sharing``, ``clip``, ``dtype``, ``progress``,
                ``n_jobs``: as for the constructor.
            fit_method: how the weights were trained, if known.
            n_training_views: how many views they were trained on, if known.

        Raises:
            ValueError: the layers do not fit the architecture or each other, an array is not
                finite, or some input would make a computed value overflow ``dtype`` (see
                :mod:`sfa_gym.sfa._weights`); the message names the layer and the array.
        """
        params = list(layer_params)
        model = cls(
            layer_specs(params),
            n_outputs=n_outputs,
            weight_sharing=weight_sharing,
            clip=clip,
            dtype=dtype,
            progress=progress,
            n_jobs=n_jobs,
        )
        layers = model._validated_layers()
        shape = tuple(int(v) for v in input_shape)
        if len(shape) != 3 or shape[2] != 3 or min(shape) < 1:
            raise ValueError(f"input_shape must be (H, W, 3), got {tuple(input_shape)}")
        grids = model._grids(layers, shape[0], shape[1])
        if fit_method is not None and fit_method not in FIT_METHODS:
            raise ValueError(f"fit_method must be one of {FIT_METHODS} or None, got {fit_method!r}")
        check_weights(params, grids, weight_sharing, clip, model._np_dtype, shape)
        model._set_fitted(params, grids, shape)
        model.fit_method_ = fit_method
        model.n_training_views_ = None if n_training_views is None else int(n_training_views)
        return model

    # -- inference --------------------------------------------------------------------------
    def _check_fitted(self) -> list[LayerParams]:
        why = "this HierarchicalSFA is not fitted yet: call fit or fit_rotations, or load_model"
        check_is_fitted(self, "layer_params_", msg=why)
        return self.layer_params_

    def transform(self, views: NDArray[np.uint8]) -> NDArray[np.float64]:
        """Slow features of ``views`` ``(N, H, W, 3)`` uint8 -> ``(N, n_outputs)`` float64."""
        params = self._check_fitted()
        views = check_views(views, min_views=0)
        if tuple(views.shape[1:]) != self.input_shape_:
            raise ValueError(
                f"views have shape {tuple(views.shape[1:])} per frame, but the model was "
                f"trained on {self.input_shape_}"
            )
        n = views.shape[0]
        out = np.empty((n, self.n_outputs), dtype=np.float64)
        layers = [p.spec for p in params]
        batch = self._batch(layers, self.grids_, len(layers) - 1)
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
        self, panoramas: NDArray[np.uint8], step: int = 5, indices: ArrayLike | None = None
    ) -> NDArray[np.float64]:
        """Slow features of every simulated rotation of every panorama.

        Equal to ``transform`` of the views ``np.roll(p, -k * step, axis=1)[:, :W_model]`` for
        ``k < K = W // step`` (:mod:`sfa_gym.rotation`), but with the rotation shortcut (see
        the module docstring) when it applies: the layers below the top run once per panorama
        on the dense grid, the top node once per view. A step finer than layer 1's column
        stride (``step=1``: every column) runs the shortcut once per phase of the stride. The
        paper averages estimates over these views; an average over every column is invariant
        to turning the rover by whole columns.

        Args:
            panoramas: ``(L, H, W, 3)`` uint8 with ``H`` the model's input height and ``W`` at
                least its input width (``W`` itself for a model of 360 degree views).
            step: rotation step in columns; must divide ``W``.
            indices: the rotations returned (None: all), picked from all of them.

        Returns:
            ``(L, K, n_outputs)`` float64 (``K = len(indices)`` when given).
        """
        if indices is not None:
            return self.transform_rotations(panoramas, step)[:, indices]
        params = self._check_fitted()
        panoramas = check_panoramas(panoramas, self.input_shape_, "HierarchicalSFA")
        n_loc, h, w, _ = panoramas.shape
        window = self.input_shape_[1]
        n_rot = n_rotations(w, step)
        out = np.empty((n_loc, n_rot, self.n_outputs))
        specs = [p.spec for p in params]
        obstacle = shortcut_obstacle(specs, w, step, window, self.weight_sharing)
        coarse = math.lcm(step, specs[0].stride[1])
        if (
            obstacle
            and w % coarse == 0
            and not shortcut_obstacle(specs, w, coarse, window, self.weight_sharing)
        ):
            # rotation k = j + i * per is rotation i of the panoramas turned by j steps
            per = coarse // step
            for j in range(per):
                turned = np.roll(panoramas, -j * step, axis=2)
                out[:, j::per] = self.transform_rotations(turned, coarse)
            return out
        if obstacle:
            columns = rotation_columns(w, step, window)
            for i in range(n_loc):
                views = np.ascontiguousarray(panoramas[i][:, columns].transpose(1, 0, 2, 3))
                out[i] = self.transform(views)
            return out
        source = DenseRotationSource(panoramas, step, specs)
        n_layers = len(params)
        job = Pass(
            params=params[:-1],
            clips=layer_clips(self.clip, n_layers)[:-1],
            sharing=self.weight_sharing,
            dtype=self._np_dtype,
            batch=self._batch(specs, self.grids_, n_layers - 1, source.n1),
            workers=self._workers(),
        )
        with single_threaded_blas():
            source.top_outputs(job, params[-1], out)
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
        clips = layer_clips(self.clip, len(params))
        for p, clip in list(zip(params, clips, strict=True))[:n_layers]:
            a = p.forward(a, clip)
        return a
