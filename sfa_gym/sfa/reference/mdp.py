"""MDP 3.6 as a reference implementation of (hierarchical) SFA.

MDP (the Modular toolkit for Data Processing) is the toolkit the paper's networks were built
with. It predates numpy 2 and scipy 1.14 and no longer imports as released;
:func:`~sfa_gym.sfa.reference.mdp_compat.import_mdp` applies the smallest compatibility shim that
makes it work, confined to MDP's own namespace as far as possible. On top of it this module
builds the MDP network (``Rectangular2dSwitchboard`` + ``CloneLayer`` of ``FlowNode`` nodes) that
corresponds to a :class:`~sfa_gym.sfa.HierarchicalSFA` architecture, so that our engine can be
checked and benchmarked against it.

MDP is optional: nothing else in ``sfa_gym`` imports this module.
"""

from __future__ import annotations

import types
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray
from sklearn.exceptions import NotFittedError

from sfa_gym._types import check_views
from sfa_gym.rotation import check_window, n_rotations, rotation_columns
from sfa_gym.sfa._weights import check_weight_sharing
from sfa_gym.sfa.reference.mdp_compat import MDP_INSTALL_HINT, import_mdp
from sfa_gym.sfa.spec import LayerSpec, layer_grids

__all__ = [
    "MDPHierarchicalSFA",
    "MDP_INSTALL_HINT",
    "build_mdp_network",
    "execute_mdp_network",
    "import_mdp",
    "mdp_linear_sfa",
    "train_mdp_network",
]


def mdp_linear_sfa(
    x: NDArray[np.floating], n_components: int
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Linear SFA of a time series with ``mdp.nodes.SFANode`` (the reference).

    Args:
        x: ``(T, D)`` time series, rows in time order.
        n_components: number of slowest outputs, ``1 <= n_components <= D``.

    Returns:
        ``(y, delta)``: outputs ``(T, n_components)`` (zero mean, unit variance, slowest first)
        and the generalized eigenvalues ``(n_components,)`` (MDP's ``d``: the mean squared time
        derivative of each output, per time step).
    """
    x = np.asarray(x, dtype=np.float64)
    if x.ndim != 2 or x.shape[0] < 2:
        raise ValueError(f"x must be a (T >= 2, D) time series, got shape {x.shape}")
    if not 1 <= n_components <= x.shape[1]:
        raise ValueError(f"n_components must be in [1, {x.shape[1]}], got {n_components}")
    mdp = import_mdp()
    node = mdp.nodes.SFANode(output_dim=n_components, dtype="float64")
    node.train(x)
    node.stop_training()
    return node.execute(x), np.asarray(node.d, dtype=np.float64)


# -- the hierarchical network -------------------------------------------------------------------
def _column_map(rows: int, cols_in: int, channels: int, cols_out: int) -> NDArray[np.int64]:
    """Input index of every output connection of a (rows, cols_out, channels) grid whose column
    ``c`` is column ``c mod cols_in`` of the (rows, cols_in, channels) input grid."""
    r = np.arange(rows)[:, None, None]
    c = (np.arange(cols_out) % cols_in)[None, :, None]
    k = np.arange(channels)[None, None, :]
    return ((r * cols_in + c) * channels + k).reshape(-1)


def _relative_rank_symeig(mdp: types.ModuleType, rank_tol: float) -> Any:
    """A semidefinite solver for ``SFANode`` with our engine's rank rule, from MDP's primitives.

    It follows ``mdp.utils.symeig_semidefinite_pca`` (diagonalise the covariance ``B`` with
    ``mdp.utils.symeig``, drop the null directions, whiten, diagonalise the whitened derivative
    covariance ``A``) with two differences: directions are dropped below ``rank_tol`` times the
    *largest* variance (MDP: an absolute threshold), and MDP's "blank column" pre-check is
    left out. That check (``_find_blank_data_idx``) removes every input whose covariance with
    the other inputs is near zero -- which is the case for the decorrelated outputs of an SFA
    node, so behind the quadratic expansion it drops the slowest linear term of every node.
    """

    def symeig(A, B, eigenvectors=True, turbo="on", range=None, type=1, overwrite=False,
               rank_threshold=None, dfc_out=None):  # fmt: skip
        # SFANode's call signature; eigenvectors are always wanted, MDP's absolute
        # rank_threshold is replaced by the relative rule, and the inputs are not overwritten
        del eigenvectors, overwrite, rank_threshold
        var, basis = mdp.utils.symeig(B, None, True, turbo, None, type, False)
        keep = var > rank_tol * var[-1]
        if dfc_out is not None:
            dfc_out.rank_deficit = int((~keep).sum())
        whiten = basis[:, keep] / np.sqrt(var[keep])
        white = whiten.T @ A @ whiten
        delta, vectors = mdp.utils.symeig(0.5 * (white + white.T), None, True, turbo, range)
        return delta, whiten @ vectors

    return symeig


def _sfa_node(mdp: types.ModuleType, output_dim: int, rdm: str, rank_tol: float | None) -> Any:
    node = mdp.nodes.SFANode(output_dim=output_dim, rank_deficit_method=rdm)
    if rank_tol is not None:
        node._symeig = _relative_rank_symeig(mdp, rank_tol)
    return node


def _node_flow(
    mdp: types.ModuleType,
    spec: LayerSpec,
    in_dim: int,
    clip: float | None,
    rdm: str,
    rank_tol: float | None,
) -> Any:
    """One node as an MDP ``FlowNode``: SFA -> quadratic expansion -> SFA (-> cutoff)."""
    if spec.expansion == "quadratic":
        nodes = [
            _sfa_node(mdp, min(spec.reduce_dim, in_dim), rdm, rank_tol),
            mdp.nodes.QuadraticExpansionNode(),
            _sfa_node(mdp, spec.out_dim, rdm, rank_tol),
        ]
    else:
        nodes = [_sfa_node(mdp, min(spec.node_out_dim, in_dim), rdm, rank_tol)]
    if clip is not None:
        nodes.append(mdp.nodes.CutoffNode(lower_bound=-clip, upper_bound=clip))
    return mdp.hinet.FlowNode(mdp.Flow(nodes), input_dim=in_dim, dtype="float64")


def build_mdp_network(
    layers: Sequence[LayerSpec],
    input_shape: tuple[int, int, int],
    n_outputs: int = 8,
    *,
    weight_sharing: str = "layer",
    clip: float | None = 4.0,
    rank_deficit_method: str = "none",
    rank_tol: float | None = None,
) -> Any:
    """The MDP network equivalent to ``HierarchicalSFA(layers, n_outputs, weight_sharing, clip)``.

    Per layer: a column ``Switchboard`` that appends the first columns of the grid below at its
    right end when the layer wraps (MDP's ``Rectangular2dSwitchboard`` does not wrap around; with
    the padding its fields read exactly columns ``(j * stride + c) mod C_in``), then a
    ``Rectangular2dSwitchboard`` (fields in (row, column, channel) order, node grid row-major,
    like :mod:`sfa_gym.sfa.spec`), then a ``CloneLayer`` (weight sharing) or ``Layer`` of
    ``FlowNode(SFANode(reduce_dim) -> QuadraticExpansionNode -> SFANode(out_dim) ->
    CutoffNode(-clip, clip))``; the top node is not clipped. A final ``Switchboard`` keeps the
    top node's ``n_outputs`` slowest outputs.

    Args:
        layers: the architecture (bottom first); the top layer must have a single node.
        input_shape: ``(H, W, 3)`` of the views.
        n_outputs: number of slowest top outputs.
        weight_sharing: ``"layer"``: one node per layer (``CloneLayer``); ``"none"``: one per
            position (``Layer``). MDP has no layer whose nodes are shared along grid rows.
        clip: clipping of intermediate node outputs, as in ``HierarchicalSFA`` (None: none).
        rank_deficit_method: passed to every ``SFANode`` (``"none"`` is MDP's default; see
            ``mdp.nodes.SFANode`` for ``"pca"``, ``"reg"``, ... on rank-deficient data).
        rank_tol: if set, every ``SFANode`` drops the input directions whose variance is below
            ``rank_tol`` times the largest, as ``HierarchicalSFA(rank_tol=...)`` does (MDP's
            PCA-based solver with a relative threshold; ``rank_deficit_method`` is then
            unused). Which near-null directions a node keeps changes the features of the layers
            above it, so a comparison with our engine on rank-deficient data needs the same rule.

    Returns:
        An untrained ``mdp.Flow`` taking views flattened to ``(N, H * W * 3)`` float64
        (see :func:`train_mdp_network` and :func:`execute_mdp_network`).
    """
    if check_weight_sharing(weight_sharing) == "rows":
        raise ValueError(
            "weight_sharing must be 'layer' or 'none' for an MDP network, got 'rows' "
            "(MDP has no layer whose nodes are shared along grid rows)"
        )
    mdp = import_mdp()
    h, w, c = (int(v) for v in input_shape)
    if c != 3:
        raise ValueError(f"input_shape must be (H, W, 3), got {tuple(input_shape)}")
    layers = list(layers)
    grids = layer_grids(layers, h, w)
    if grids[-1] != (1, 1):
        raise ValueError(f"the top layer must have a single node, got a {grids[-1]} grid")
    if not 1 <= n_outputs <= layers[-1].node_out_dim:
        raise ValueError(f"n_outputs must be in [1, {layers[-1].node_out_dim}], got {n_outputs}")
    flow_nodes = []
    rows_in, cols_in, channels = h, w, 3
    for i, (spec, (rows, cols)) in enumerate(zip(layers, grids, strict=True)):
        fr, fc = spec.field
        sr, sc = spec.stride
        need = (cols - 1) * sc + fc  # input columns the layer's fields span
        if need != cols_in:
            flow_nodes.append(
                mdp.hinet.Switchboard(
                    input_dim=rows_in * cols_in * channels,
                    connections=_column_map(rows_in, cols_in, channels, need),
                )
            )
        board = mdp.hinet.Rectangular2dSwitchboard(
            in_channels_xy=(need, rows_in),
            field_channels_xy=(fc, fr),
            field_spacing_xy=(sc, sr),
            in_channel_dim=channels,
            ignore_cover=True,
        )
        if board.out_channels_xy != (cols, rows):
            raise AssertionError(f"switchboard grid {board.out_channels_xy} != {(cols, rows)}")
        flow_nodes.append(board)
        node_clip = None if i == len(layers) - 1 else clip
        in_dim = board.out_channel_dim
        if weight_sharing == "layer":
            layer = mdp.hinet.CloneLayer(
                _node_flow(mdp, spec, in_dim, node_clip, rank_deficit_method, rank_tol),
                n_nodes=rows * cols,
            )
        else:
            layer = mdp.hinet.Layer(
                [
                    _node_flow(mdp, spec, in_dim, node_clip, rank_deficit_method, rank_tol)
                    for _ in range(rows * cols)
                ]
            )
        flow_nodes.append(layer)
        rows_in, cols_in, channels = rows, cols, spec.node_out_dim
    flow_nodes.append(mdp.hinet.Switchboard(input_dim=channels, connections=np.arange(n_outputs)))
    return mdp.Flow(flow_nodes)


class _Chunks:
    """Re-iterable training data for an MDP flow: ``(x, include_last_sample)`` items.

    MDP's ``SFANode`` forms time differences only inside one ``train`` call. To train on a
    long sequence in chunks without losing the differences across chunk boundaries, each chunk
    repeats the first row of the next one and excludes it from the covariance
    (``include_last_sample=False``); the chunk that ends a sequence includes its last row. The
    statistics are then exactly those of one call per sequence. Chunks never span two
    sequences, so no difference is formed between sequences (as in ``HierarchicalSFA.fit``).
    """

    def __init__(self, get: Any, bounds: list[tuple[int, int, bool]], progress: bool, desc: str):
        self.get, self.bounds, self.progress, self.desc = get, bounds, progress, desc

    def __iter__(self):
        from tqdm.auto import tqdm

        for i0, i1, last in tqdm(
            self.bounds, desc=self.desc, disable=not self.progress, leave=False
        ):
            x = np.asarray(self.get(i0, i1))
            yield x.reshape(x.shape[0], -1).astype(np.float64), last


def _chunk_bounds(starts: NDArray[np.bool_], batch: int) -> list[tuple[int, int, bool]]:
    n = starts.shape[0]
    seq_starts = list(np.flatnonzero(starts)) + [n]
    bounds = []
    for s, e in zip(seq_starts[:-1], seq_starts[1:], strict=True):
        if e - s < 2:
            raise ValueError(
                f"the sequence starting at row {s} has a single frame; MDP's SFANode needs at "
                "least 2 frames per sequence (drop it or merge it with its neighbour)"
            )
        a = s
        while True:
            b = min(a + batch, e)
            if b >= e - 1:  # the rest fits; never leave a one-row final chunk
                bounds.append((a, e, True))
                break
            bounds.append((a, b + 1, False))
            a = b
    return bounds


def train_mdp_network(
    flow: Any,
    views: NDArray[np.uint8],
    sequence_ids: Any = None,
    *,
    batch_size: int = 500,
    progress: bool = False,
    get: Any = None,
) -> Any:
    """Train an MDP flow from :func:`build_mdp_network` on views in time order (in place).

    Args:
        flow: the untrained flow.
        views: ``(N, H, W, 3)`` training views, rows in time order (pixel values 0..255 are fed
            unscaled, as ``HierarchicalSFA`` does). Ignored for the data if ``get`` is given,
            but still gives ``N`` (a ``(N, 0)`` placeholder works).
        sequence_ids: optional ``(N,)`` labels; no time difference across a change of label.
        batch_size: frames per chunk; memory grows with it, the result does not depend on it.
        progress: a tqdm bar per pass over the data (MDP makes one pass per node training
            phase, re-executing the trained layers below every time).
        get: optional ``get(i0, i1) -> views[i0:i1]`` to produce the frames lazily.

    Returns:
        ``flow``, trained.
    """
    n = int(np.shape(views)[0])
    if n < 2:
        raise ValueError(f"need at least 2 training views, got {n}")
    if (
        isinstance(batch_size, bool)
        or not isinstance(batch_size, int | np.integer)
        or batch_size < 1
    ):
        raise ValueError(f"batch_size must be a positive int, got {batch_size!r}")
    if sequence_ids is None:
        starts = np.zeros(n, dtype=bool)
    else:
        ids = np.asarray(sequence_ids)
        if ids.shape != (n,):
            raise ValueError(f"sequence_ids must have shape ({n},), got {ids.shape}")
        starts = np.ones(n, dtype=bool)
        starts[1:] = ids[1:] != ids[:-1]
    starts[0] = True
    bounds = _chunk_bounds(starts, int(batch_size))
    getter = get if get is not None else (lambda i0, i1: views[i0:i1])
    data = []
    for i, node in enumerate(flow):
        desc = f"MDP node {i + 1}/{len(flow)}"
        data.append(_Chunks(getter, bounds, progress, desc) if node.is_trainable() else None)
    flow.train(data)
    # MDP leaves a node's last training phase open until its first execution; close it so that
    # the training time includes the top node's eigenproblem and the model can be inspected
    for node in flow:
        if node.is_training():
            node.stop_training()
    return flow


def execute_mdp_network(
    flow: Any, views: NDArray[np.uint8], *, batch_size: int = 500
) -> NDArray[np.float64]:
    """Outputs of a trained MDP flow for ``views`` ``(N, H, W, 3)`` -> ``(N, n_outputs)``."""
    n = views.shape[0]
    out = []
    for i0 in range(0, n, batch_size):
        x = views[i0 : i0 + batch_size]
        out.append(flow.execute(x.reshape(x.shape[0], -1).astype(np.float64)))
    return np.concatenate(out, axis=0) if out else np.empty((0, flow[-1].output_dim))


class MDPHierarchicalSFA:
    """:class:`~sfa_gym.sfa.HierarchicalSFA`'s interface backed by MDP 3.6 (the reference).

    Same architecture and node functions (see :func:`build_mdp_network`), MDP's numerics
    (float64, generalized symmetric eigensolver). Much slower and hungrier than our engine:
    for checking and benchmarking. A "feature model" (``input_shape_``, ``transform``).

    Args:
        layers: this and ``n_outputs``, ``weight_sharing``, ``clip``: as for
            ``HierarchicalSFA``.
        rank_deficit_method: this and ``rank_tol``: see :func:`build_mdp_network`. To reproduce a
            ``HierarchicalSFA`` on rank-deficient data, pass its rank tolerance (1e-6 for its
            default float32, 1e-9 for float64).
        batch_size: frames per training / execution chunk.
        progress: tqdm bars while training.

    Attributes (after fitting): ``flow_`` (the trained ``mdp.Flow``), ``input_shape_``,
    ``grids_`` (node grid per layer), ``delta_values_`` ``(n_outputs,)`` (the top SFA node's
    eigenvalues), ``n_training_views_``.
    """

    def __init__(
        self,
        layers: Sequence[LayerSpec],
        n_outputs: int = 8,
        weight_sharing: str = "layer",
        *,
        clip: float | None = 4.0,
        rank_deficit_method: str = "none",
        rank_tol: float | None = None,
        batch_size: int = 500,
        progress: bool = True,
    ) -> None:
        self.layers = layers
        self.n_outputs = n_outputs
        self.weight_sharing = weight_sharing
        self.clip = clip
        self.rank_deficit_method = rank_deficit_method
        self.rank_tol = rank_tol
        self.batch_size = batch_size
        self.progress = progress

    def _fit(self, shape: tuple[int, int, int], n: int, get: Any, sequence_ids: Any) -> None:
        flow = build_mdp_network(
            self.layers,
            shape,
            self.n_outputs,
            weight_sharing=self.weight_sharing,
            clip=self.clip,
            rank_deficit_method=self.rank_deficit_method,
            rank_tol=self.rank_tol,
        )
        placeholder = np.empty((n, 0), dtype=np.uint8)
        train_mdp_network(
            flow,
            placeholder,
            sequence_ids,
            batch_size=self.batch_size,
            progress=self.progress,
            get=get,
        )
        self.flow_ = flow
        self.input_shape_ = tuple(int(v) for v in shape)
        self.grids_ = layer_grids(list(self.layers), shape[0], shape[1])
        # the top layer is flow[-2] (before the output selection); its last node is the SFA
        top_sfa = flow[-2].nodes[0]._flow[-1]
        self.delta_values_ = np.asarray(top_sfa.d, dtype=np.float64)[: self.n_outputs]
        self.n_training_views_ = int(n)

    def fit(
        self, views: NDArray[np.uint8], y: Any = None, sequence_ids: Any = None
    ) -> MDPHierarchicalSFA:
        """Train on ``views`` ``(N, H, W, 3)`` uint8 in time order (see ``HierarchicalSFA.fit``;
        ``y`` is ignored)."""
        del y
        views = check_views(views, min_views=0)
        self._fit(views.shape[1:], views.shape[0], lambda i0, i1: views[i0:i1], sequence_ids)
        return self

    def fit_rotations(
        self, panoramas: NDArray[np.uint8], step: int = 5, window: int | None = None
    ) -> MDPHierarchicalSFA:
        """Train on all rotated views of each panorama, location by location (paper order),
        materialising the views chunk by chunk (MDP has no rotation shortcut)."""
        panoramas = check_views(panoramas, "panoramas", min_views=0)
        n_loc, h, w, _ = panoramas.shape
        n_rot = n_rotations(w, step)
        window = check_window(w, window)
        columns = rotation_columns(w, step, window)  # (K, window)

        def get(i0: int, i1: int) -> NDArray[np.uint8]:
            idx = np.arange(i0, i1)
            loc, k = idx // n_rot, idx % n_rot
            return panoramas[loc[:, None], :, columns[k]].transpose(0, 2, 1, 3)

        self._fit((h, window, 3), n_loc * n_rot, get, None)
        return self

    def transform(self, views: NDArray[np.uint8]) -> NDArray[np.float64]:
        """Slow features ``(N, n_outputs)`` of ``views`` ``(N, H, W, 3)`` uint8."""
        flow = getattr(self, "flow_", None)
        if flow is None:
            raise NotFittedError("this MDPHierarchicalSFA is not fitted yet: call fit first")
        views = check_views(views, min_views=0)
        if tuple(views.shape[1:]) != self.input_shape_:
            raise ValueError(
                f"views have shape {tuple(views.shape[1:])} per frame, but the model was "
                f"trained on {self.input_shape_}"
            )
        return execute_mdp_network(flow, views, batch_size=self.batch_size)

    def forward(self, views: NDArray[np.uint8], n_layers: int | None = None) -> NDArray[Any]:
        """Output grid ``(N, R, C, D)`` of layer ``n_layers`` (default: the top layer, all its
        outputs), as ``HierarchicalSFA.forward``: for comparing the networks layer by layer."""
        mdp = import_mdp()
        self.transform(views[:0])  # fitted and shape checks
        layer_ends = [i for i, node in enumerate(self.flow_) if isinstance(node, mdp.hinet.Layer)]
        n_layers = len(layer_ends) if n_layers is None else int(n_layers)
        if not 1 <= n_layers <= len(layer_ends):
            raise ValueError(f"n_layers must be in [1, {len(layer_ends)}], got {n_layers}")
        x = views.reshape(views.shape[0], -1).astype(np.float64)
        y = self.flow_[: layer_ends[n_layers - 1] + 1].execute(x)
        rows, cols = self.grids_[n_layers - 1]
        return y.reshape(views.shape[0], rows, cols, -1)
