"""Features of rotated views, the one way every protocol fits a feature method and reads its
features: all rotated views of the training panoramas in visiting order, a few thousand views at a
time, with the shortcuts a method declares in its :class:`~sfa_gym.capabilities.Capabilities`
(``fit_rotations``/``transform_rotations``, column statistics that are ``rotation_invariant``)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray
from tqdm.auto import tqdm

from sfa_gym.capabilities import get_capabilities
from sfa_gym.localization import eta_phi, eta_r
from sfa_gym.phases import phase
from sfa_gym.plugins import FeatureMethod
from sfa_gym.rotation import Rotation, check_indices, count_places, rotation_sequence

__all__ = [
    "VIEWS_PER_BLOCK",
    "fit_method",
    "fit_on_views",
    "fitted_features",
    "full_width",
    "invariance_entry",
    "method_regressors",
    "training_views",
    "view_features",
]

# Views transformed at once: bounds the memory of a block of rotated views.
VIEWS_PER_BLOCK = 4096


@phase("features")
def view_features(
    method: FeatureMethod,
    panoramas: NDArray[np.uint8],
    rotation: Rotation,
    indices: NDArray[np.intp] | None = None,
    desc: str = "features",
    progress: bool = True,
) -> NDArray[np.float64]:
    """Features ``(L, K', k)`` of the rotated views ``indices`` (all ``K`` by default) of each
    panorama ``(L, H, W, 3)``, a few thousand views at a time.

    A method with the capability ``transform_rotations`` computes all views itself
    (hierarchical SFA exploits that a rotation permutes its layer-1 patches, so all 120 views
    of a 600 px panorama cost less than 24 views transformed one by one) and the ``indices``
    are picked from them; with the capability ``rotation_indices`` it computes only those. A
    method with the capability ``rotation_invariant`` (a column statistic: the features of a
    circular shift of the whole panorama are its own) transforms each panorama once when the
    views are full width. Otherwise the method transforms every view asked for.
    """
    width = panoramas.shape[2]
    n_views = rotation.n_views(width) if indices is None else len(indices)
    capabilities = get_capabilities(method)
    if capabilities.rotation_invariant and full_width(rotation, panoramas):
        out = [
            np.asarray(method.transform(np.asarray(panoramas[i : i + VIEWS_PER_BLOCK])))
            for i in tqdm(
                range(0, len(panoramas), VIEWS_PER_BLOCK), desc=desc, disable=not progress
            )
        ]
        features = np.concatenate(out).astype(np.float64)
        return np.repeat(features[:, None], n_views, axis=1)
    shortcut = capabilities.transform_rotations
    picks = indices is not None and capabilities.rotation_indices
    computed = rotation.n_views(width) if shortcut and not picks else n_views
    per_block = max(1, VIEWS_PER_BLOCK // computed)
    out = []
    for i in tqdm(range(0, len(panoramas), per_block), desc=desc, disable=not progress):
        block = np.asarray(panoramas[i : i + per_block])
        if picks:
            features = method.transform_rotations(block, rotation.step, indices)
        elif shortcut:
            features = method.transform_rotations(block, rotation.step)
            if indices is not None:
                features = np.asarray(features)[:, indices]
        else:
            views = rotation.views(block, indices)[0]  # (L', K', H, W', 3)
            features = method.transform(views.reshape(-1, *views.shape[2:]))
        out.append(np.asarray(features, dtype=np.float64).reshape(len(block), n_views, -1))
    return np.concatenate(out)


@phase("fit")
def fit_method(
    method: FeatureMethod,
    panoramas: NDArray[np.uint8],
    rotation: Rotation,
    appearances: int = 1,
) -> FeatureMethod:
    """Fit ``method`` on every rotated view of ``panoramas (L, H, W, 3)``: all views of the first
    location, then of the next, ... (``fit_rotations`` if the method has that capability: it
    fits with its own ``rotation``, which must be ``rotation``). With ``appearances = A > 1``
    each run of ``A`` consecutive panoramas is one location under ``A`` appearances, seen in
    the order of :func:`training_views` (``fit_rotations(panoramas, appearances=A)``)."""
    capabilities = get_capabilities(method)
    if capabilities.fit_rotations:
        own = method.rotation  # type: ignore[attr-defined]
        if own != rotation:
            raise ValueError(f"{method.name} was set up for {own}, asked to fit on {rotation}")
        if appearances == 1:  # the one-argument call every plug-in with the capability takes
            return method.fit_rotations(panoramas)
        return method.fit_rotations(panoramas, appearances=appearances)
    if capabilities.rotation_invariant and full_width(rotation, panoramas):
        return method.fit(np.asarray(panoramas))  # every full-width view is alike
    return fit_on_views(method, panoramas, rotation, appearances)


def fit_on_views(
    method: FeatureMethod,
    panoramas: NDArray[np.uint8],
    rotation: Rotation,
    appearances: int = 1,
    indices: NDArray[np.intp] | None = None,
) -> FeatureMethod:
    """``method.fit(training_views(panoramas, rotation, appearances, indices))``. A plug-in in
    its own worker process (:class:`~sfa_gym.sandbox.IsolatedMethod`) builds the views there
    from the panoramas it is sent: the evaluator then never holds every view of a track (GiB),
    only the panoramas; the views, and so the fit, are the same."""
    from sfa_gym.sandbox import IsolatedMethod  # here: the experiments' start-up needs no sandbox

    if isinstance(method, IsolatedMethod):
        return method.fit_training_views(panoramas, rotation, appearances, indices)
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
    method: FeatureMethod,
    fit_panoramas: NDArray[np.uint8],
    rotation: Rotation,
    train: NDArray[np.uint8],
    test: NDArray[np.uint8],
    indices: NDArray[np.intp] | None = None,
    progress: bool = False,
) -> tuple[FeatureMethod, NDArray[np.float64], NDArray[np.float64]]:
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
    return {
        "eta_r": np.round(eta_r(train_features), 4).tolist(),
        "eta_phi": np.round(eta_phi(train_features), 4).tolist(),
        "n_features": int(train_features.shape[2]),
    }


def method_regressors(method: FeatureMethod, regressors: Sequence[str] | None) -> list[str]:
    """The regressions a method is scored with: ``regressors`` without repeats, or, when None,
    the method's own ``regressor`` (default linear)."""
    if regressors is None:
        return [get_capabilities(method).regressor]
    names = list(dict.fromkeys(regressors))
    if not names:
        raise ValueError(f"{getattr(method, 'name', method)!r}: no regression to score it with")
    return names
