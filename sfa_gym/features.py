"""Features of rotated views, the one way every protocol fits a feature method and reads its
features, and rotation averages: what a feature model says about a place, whichever way the
rover faces.

A method (the plug-in contract, :mod:`sfa_gym.plugins`) is fitted on all rotated views of the
training panoramas in visiting order and transforms a few thousand views at a time. A method
that declares ``rotation_invariant`` (:class:`~sfa_gym.capabilities.Capabilities`: column
statistics) is fitted on and transforms each panorama once when the views are full width.

The package's own models have fast paths, used where they are present (not part of the plug-in
contract): ``fit_rotations(panoramas, appearances=1)`` fits on every rotation of each panorama
with the model's own ``rotation`` (hierarchical SFA computes its lower layers once per
panorama), and ``transform_rotations(panoramas, step, indices=None) -> (L, K', k)`` gives the
features of the rotations ``indices`` (all by default) of each panorama at once (hierarchical
SFA exploits that a rotation permutes its layer-1 patches; the raw-pixel baseline computes only
the rotations asked for).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from sfa_gym.capabilities import get_capabilities
from sfa_gym.phases import phase
from sfa_gym.rotation import (
    Rotation,
    check_indices,
    count_places,
    rotated_views,
    rotation_sequence,
)

__all__ = [
    "VIEWS_PER_BLOCK",
    "EmbeddedFeatures",
    "averages_view_by_view",
    "fit_method",
    "fit_on_views",
    "fits_on_panoramas",
    "fitted_features",
    "full_width",
    "invariance_entry",
    "method_regressors",
    "rotation_averaged_features",
    "training_views",
    "view_features",
]

# Views transformed at once: bounds the memory of a block of rotated views.
VIEWS_PER_BLOCK = 4096


def _fast(model: Any, name: str) -> Any:
    """The model's fast path ``name`` (module docstring), or None."""
    found = getattr(model, name, None)
    return found if callable(found) else None


@phase("features")
def view_features(
    method: Any,
    panoramas: NDArray[np.uint8],
    rotation: Rotation,
    indices: NDArray[np.intp] | None = None,
    desc: str = "features",
    progress: bool = True,
) -> NDArray[np.float64]:
    """Features ``(L, K', k)`` of the rotated views ``indices`` (all ``K`` by default) of each
    panorama ``(L, H, W, 3)``, a few thousand views at a time (``transform_rotations`` where
    the model has it, each panorama once where it is ``rotation_invariant`` and the views are
    full width, otherwise ``transform`` of every view asked for)."""
    from tqdm.auto import tqdm

    width = panoramas.shape[2]
    n_views = rotation.n_views(width) if indices is None else len(indices)
    fast = _fast(method, "transform_rotations")
    if get_capabilities(method).rotation_invariant and full_width(rotation, panoramas):
        out = [
            np.asarray(method.transform(np.asarray(panoramas[i : i + VIEWS_PER_BLOCK])))
            for i in tqdm(
                range(0, len(panoramas), VIEWS_PER_BLOCK), desc=desc, disable=not progress
            )
        ]
        features = np.concatenate(out).astype(np.float64)
        return np.repeat(features[:, None], n_views, axis=1)
    per_block = max(1, VIEWS_PER_BLOCK // (rotation.n_views(width) if fast else n_views))
    out = []
    for i in tqdm(range(0, len(panoramas), per_block), desc=desc, disable=not progress):
        block = np.asarray(panoramas[i : i + per_block])
        if fast:
            features = fast(block, rotation.step, indices)
        else:
            views = rotation.views(block, indices)[0]  # (L', K', H, W', 3)
            features = method.transform(views.reshape(-1, *views.shape[2:]))
        out.append(np.asarray(features, dtype=np.float64).reshape(len(block), n_views, -1))
    return np.concatenate(out)


def fits_on_panoramas(method: Any, rotation: Rotation, panoramas: NDArray[np.uint8]) -> bool:
    """Whether :func:`fit_method` fits ``method`` on the panoramas themselves rather than on
    their rotated views: it has ``fit_rotations``, or it is ``rotation_invariant`` and the views
    are full width."""
    invariant = get_capabilities(method).rotation_invariant and full_width(rotation, panoramas)
    return invariant or _fast(method, "fit_rotations") is not None


@phase("fit")
def fit_method(
    method: Any, panoramas: NDArray[np.uint8], rotation: Rotation, appearances: int = 1
) -> Any:
    """Fit ``method`` on every rotated view of ``panoramas (L, H, W, 3)``: all views of the first
    location, then of the next, ... (``fit_rotations`` where the model has it: it fits with its
    own ``rotation``, which must be ``rotation``). With ``appearances = A > 1`` each run of
    ``A`` consecutive panoramas is one location under ``A`` appearances, seen in the order of
    :func:`training_views`."""
    fast = _fast(method, "fit_rotations")
    if fast:
        own = method.rotation
        if own != rotation:
            raise ValueError(f"{method.name} was set up for {own}, asked to fit on {rotation}")
        return fast(panoramas, appearances=appearances)
    if fits_on_panoramas(method, rotation, panoramas):
        return method.fit(np.asarray(panoramas))  # every full-width view is alike
    return fit_on_views(method, panoramas, rotation, appearances)


def fit_on_views(
    method: Any,
    panoramas: NDArray[np.uint8],
    rotation: Rotation,
    appearances: int = 1,
    indices: NDArray[np.intp] | None = None,
) -> Any:
    """``method.fit(training_views(panoramas, rotation, appearances, indices))``."""
    return method.fit(training_views(panoramas, rotation, appearances, indices))


def training_views(
    panoramas: NDArray[np.uint8],
    rotation: Rotation,
    appearances: int = 1,
    indices: NDArray[np.intp] | None = None,
) -> NDArray[np.uint8]:
    """The rotated views ``indices`` (all by default) of ``panoramas (L, H, W, 3)`` as one
    training sequence ``(N, H, W', 3)``: location by location, and within a location in the
    order of :func:`~sfa_gym.rotation.rotation_sequence` over its ``appearances``
    consecutive panoramas (the rotations in order for one)."""
    n_places = count_places(len(panoramas), appearances)
    if appearances == 1:  # already in order: no second copy of every view (GiB on a track)
        views = rotation.views(panoramas, indices)[0]  # (L, K', H, W', 3)
        return views.reshape(-1, *views.shape[2:])
    # place by place into one array: one copy of every view, not two
    _, height, width, channels = panoramas.shape
    k, a = rotation_sequence(len(check_indices(width, rotation.step, indices)), appearances)
    n = len(k)  # views of one place
    out = np.empty((n_places * n, height, rotation.view_width(width), channels), panoramas.dtype)
    for place in range(n_places):
        runs = np.asarray(panoramas[place * appearances : (place + 1) * appearances])
        out[place * n : (place + 1) * n] = rotation.views(runs, indices)[0][a, k]
    return out


def fitted_features(
    method: Any,
    fit_panoramas: NDArray[np.uint8],
    rotation: Rotation,
    train: NDArray[np.uint8],
    test: NDArray[np.uint8],
    indices: NDArray[np.intp] | None = None,
    progress: bool = False,
) -> tuple[Any, NDArray[np.float64], NDArray[np.float64]]:
    """``method`` fitted on every rotated view of ``fit_panoramas`` (:func:`fit_method`) and its
    features of the views ``indices`` of the ``train`` and the ``test`` panoramas
    (:func:`view_features`): ``(fitted, (L, K', k), (M, K', k))``."""
    fitted = fit_method(method, fit_panoramas, rotation)
    label = getattr(method, "name", type(method).__name__)
    f_train = view_features(fitted, train, rotation, indices, f"{label} train", progress)
    f_test = view_features(fitted, test, rotation, indices, f"{label} test", progress)
    return fitted, f_train, f_test


def full_width(rotation: Rotation, panoramas: NDArray[np.uint8]) -> bool:
    """Whether the views of ``rotation`` span the whole width of ``panoramas (L, H, W, 3)``."""
    return rotation.view_width(panoramas.shape[2]) == panoramas.shape[2]


def invariance_entry(train_features: NDArray[np.float64]) -> dict[str, Any]:
    """eta_r, eta_phi per output and the feature count, from ``(L, K, k)`` training features."""
    from sfa_gym.localization import eta_phi, eta_r

    return {
        "eta_r": np.round(eta_r(train_features), 4).tolist(),
        "eta_phi": np.round(eta_phi(train_features), 4).tolist(),
        "n_features": int(train_features.shape[2]),
    }


def method_regressors(method: Any, regressors: Sequence[str] | None) -> list[str]:
    """The regressions a method is scored with: ``regressors`` without repeats, or, when None,
    the method's own ``regressor`` (default linear)."""
    if regressors is None:
        return [get_capabilities(method).regressor]
    names = list(dict.fromkeys(regressors))
    if not names:
        raise ValueError(f"{getattr(method, 'name', method)!r}: no regression to score it with")
    return names


@phase("features")
def rotation_averaged_features(
    model: Any, panoramas: NDArray[np.uint8], step: int = 1, window: int | None = None
) -> NDArray[np.float64]:
    """Mean features over the simulated rotations of each panorama.

    Args:
        model: a fitted feature model: ``transform(views (N, H, w, 3) uint8) -> (N, k)``, with
            the fast path ``transform_rotations`` where it has one, or an
            :class:`EmbeddedFeatures`; a ``rotation_invariant`` one transforms each full-width
            panorama once.
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
    if isinstance(model, EmbeddedFeatures):
        return model.rotation_averaged(panoramas, step, window)
    fast = _fast(model, "transform_rotations")
    if fast:
        return np.asarray(fast(panoramas, step), np.float64).mean(1)
    window = _view_width(model, panoramas.shape[2], window)
    if not averages_view_by_view(model, panoramas.shape[2], window):
        # a full-width rotated view has the panorama's own features (a column statistic): the
        # mean over the rotations is the panorama's features, computed once instead of W / step
        # times (equal up to the round-off of summing the columns in another order)
        return np.asarray(model.transform(panoramas), np.float64).reshape(len(panoramas), -1)
    out = []
    for panorama in panoramas:
        views, _ = rotated_views(panorama, step=step, window=window)
        out.append(np.asarray(model.transform(views), np.float64).mean(axis=0))
    return np.stack(out) if out else np.empty((0, 0))


def _view_width(model: Any, width: int, window: int | None) -> int:
    """``window``, or the width of the views ``model`` was fitted on, or ``width``."""
    if window is None:
        shape = getattr(model, "input_shape_", None)
        window = width if shape is None else int(shape[1])
    return window


def averages_view_by_view(model: Any, width: int, window: int | None = None) -> bool:
    """Whether :func:`rotation_averaged_features` transforms each rotated view of a
    ``width``-column panorama on its own: ``model`` has no fast path ``transform_rotations``
    and is not ``rotation_invariant`` at full width (an :class:`EmbeddedFeatures`: its base)."""
    if isinstance(model, EmbeddedFeatures):
        return averages_view_by_view(model.base, width, window)
    invariant = get_capabilities(model).rotation_invariant
    full = _view_width(model, width, window) == width
    return _fast(model, "transform_rotations") is None and not (invariant and full)


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
