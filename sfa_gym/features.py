"""Rotation-averaged features: what a feature model says about a place, whichever way the rover
faces.

The paper averages its estimates over the simulated rotations of one location; navigation
compares such averages between the current and the goal panorama. Numpy only.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from sfa_gym.capabilities import Capabilities, get_capabilities
from sfa_gym.phases import phase
from sfa_gym.rotation import rotated_views

__all__ = ["EmbeddedFeatures", "rotation_averaged_features"]


@phase("features")
def rotation_averaged_features(
    model: Any, panoramas: NDArray[np.uint8], step: int = 1, window: int | None = None
) -> NDArray[np.float64]:
    """Mean features over the simulated rotations of each panorama.

    Args:
        model: a fitted feature model: ``transform(views (N, H, w, 3) uint8) -> (N, k)``, and
            optionally (declared in its :class:`~sfa_gym.capabilities.Capabilities`)
            ``transform_rotations(panoramas, step) -> (L, K, k)`` (hierarchical SFA computes
            all rotations at once, its lower layers only once per panorama), or
            ``rotation_averaged(panoramas, step, window) -> (L, k)`` (a model whose features
            are a function of another model's averages: :class:`EmbeddedFeatures`), or that
            it is ``rotation_invariant`` (its features of a full-width rotated view are the
            panorama's: each panorama is transformed once).
        panoramas: ``(L, H, W, 3)`` uint8.
        step: shift between rotations in columns; must divide ``W``. ``step=1`` averages over
            every column, which makes the average invariant to turning by whole columns.
        window: width of the rotated views the model takes (its ``input_shape_[1]``); ``None``
            reads ``model.input_shape_`` when it has one, else uses the full width.

    Returns:
        ``(L, k)`` float64.
    """
    panoramas = np.asarray(panoramas)
    if panoramas.ndim != 4 or panoramas.shape[3] != 3 or panoramas.dtype != np.uint8:
        raise ValueError(
            f"panoramas must be (L, H, W, 3) uint8, got shape {panoramas.shape} "
            f"and dtype {panoramas.dtype}"
        )
    capabilities = get_capabilities(model)
    if capabilities.rotation_averaged:
        return np.asarray(model.rotation_averaged(panoramas, step, window), np.float64)
    if capabilities.transform_rotations:
        from sfa_gym.sandbox import IsolatedMethod  # here: the envs' start-up needs no sandbox

        if isinstance(model, IsolatedMethod):
            # averaged in the plug-in's worker: the (L, K, k) features of every rotation (GiB
            # for a batch of a field's panoramas at one column per rotation) stay there
            return model.mean_over_rotations(panoramas, step)
        return np.asarray(model.transform_rotations(panoramas, step=step), np.float64).mean(1)
    if window is None:
        shape = getattr(model, "input_shape_", None)
        window = panoramas.shape[2] if shape is None else int(shape[1])
    if capabilities.rotation_invariant and window == panoramas.shape[2]:
        # a full-width rotated view has the panorama's own features (a column statistic): the
        # mean over the rotations is the panorama's features, computed once instead of W / step
        # times (equal up to the round-off of summing the columns in another order)
        return np.asarray(model.transform(panoramas), np.float64).reshape(len(panoramas), -1)
    out = []
    for panorama in panoramas:
        views, _ = rotated_views(panorama, step=step, window=window)
        out.append(np.asarray(model.transform(views), np.float64).mean(axis=0))
    return np.stack(out) if out else np.empty((0, 0))


class EmbeddedFeatures:
    """A feature model's rotation-averaged features mapped by an embedding fitted on them, e.g.
    hierarchical SFA followed by :class:`~sfa_gym.sfa.graph.WalkGraphEmbedding`: what
    :func:`rotation_averaged_features` (and so the feature fields and the navigation wrappers)
    gives for it is ``embedding.transform`` of the base model's averages.

    Args:
        base: a fitted feature model (see :func:`rotation_averaged_features`).
        embedding: a fitted ``transform((n, k) base features) -> (n, m)``.
        name: the features' name in results and figures.
    """

    capabilities = Capabilities(rotation_averaged=True)

    def __init__(self, base: Any, embedding: Any, name: str = "embedded") -> None:
        self.base = base
        self.embedding = embedding
        self.name = name

    @property
    def input_shape_(self) -> tuple[int, ...] | None:
        return getattr(self.base, "input_shape_", None)

    def rotation_averaged(
        self, panoramas: NDArray[np.uint8], step: int = 1, window: int | None = None
    ) -> NDArray[np.float64]:
        """``(L, m)``: the embedding of the base model's rotation-averaged features."""
        averages = rotation_averaged_features(self.base, panoramas, step, window)
        return np.asarray(self.embedding.transform(averages), np.float64)

    def transform(self, views: NDArray[np.uint8]) -> NDArray[np.float64]:
        """``(N, m)``: the embedding of the base model's features of single views."""
        return np.asarray(self.embedding.transform(self.base.transform(views)), np.float64)
