"""What a feature method or a navigation controller can do or needs beyond the plug-in contract,
declared once and read by one function.

A method (or any feature model the library transforms with: a hierarchical SFA network, an
:class:`~sfa_gym.features.EmbeddedFeatures`) or a controller declares its optional capabilities
in a class attribute ``capabilities``, a :class:`Capabilities`; a plug-in whose capabilities
depend on its parameters (the baselines' ``regressor``) makes ``capabilities`` a property. The
library asks :func:`get_capabilities` and never probes for methods with ``hasattr``: an
undeclared method is not used, and a declared one that is missing is an error naming the
method.

These are estimator tags in the sense of scikit-learn's ``__sklearn_tags__``, kept in an
attribute of their own: scikit-learn's ``Tags`` has a fixed set of fields, none of these, and a
plug-in that is not a scikit-learn estimator would have to build all of them.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

__all__ = ["Capabilities", "get_capabilities"]


@dataclass(frozen=True)
class Capabilities:
    """The optional capabilities of a feature method or a controller (all off by default)."""

    fit_rotations: bool = False
    """has ``fit_rotations(panoramas (L, H, W, 3)) -> self``: fits on every simulated rotation of
    each panorama, in visiting order, with the rotation of its own ``rotation`` attribute (a
    :class:`~sfa_gym.rotation.Rotation`); hierarchical SFA computes its lower layers once per
    panorama that way. A protocol that trains on several appearances of each location inside
    its rotation sequence calls ``fit_rotations(panoramas, appearances=A)`` (runs of ``A``
    consecutive panoramas: one location; :func:`~sfa_gym.rotation.rotation_sequence`)"""
    transform_rotations: bool = False
    """has ``transform_rotations(panoramas (L, H, W, 3), step) -> (L, W // step, k)``: the
    features of every ``step``-column rotation of each panorama, all at once"""
    rotation_indices: bool = False
    """its ``transform_rotations`` also takes ``indices`` (1-d ints in ``[0, W // step)``) and
    returns only those rotations, ``(L, len(indices), k)``, the same values as picking them from
    all: a method that computes each rotation on its own (the raw-pixel baseline) is
    then asked only for the rotations a protocol scores (24 of 120 on the outdoor tracks)"""
    rotation_averaged: bool = False
    """has ``rotation_averaged(panoramas, step, window) -> (L, k)``: its features of a place are a
    function of another model's rotation averages (:class:`~sfa_gym.features.EmbeddedFeatures`)"""
    rotation_invariant: bool = False
    """a full-width rotated view (a circular shift of the panorama's columns) has the panorama's
    own features (column statistics): each panorama is transformed once instead of every view"""
    regressor: str = "linear"
    """the regression the features are paired with (a name for
    :func:`~sfa_gym.localization.regression.make_regressor`)"""
    extra_regressors: tuple[str, ...] = ()
    """regressions reported besides ``linear`` and ``regressor`` by ``sfa-gym localize``"""
    panoramas: bool = False
    """a navigation controller that acts on panoramas: the episode runner renders the current
    panorama at every step and the goal's once at the start of the episode (real renders, not
    the feature field) and adds them to ``obs`` as ``"panorama"`` and ``"goal_panorama"``
    (:func:`~sfa_gym.navigation.evaluate.run_episode`); an episode's steps then take about ten
    times as long as on the field (docs/notes/2026-11-27-homing.md)"""


# The method each capability promises, checked when the capabilities are read.
_PROMISED = {
    "fit_rotations": "fit_rotations",
    "transform_rotations": "transform_rotations",
    "rotation_averaged": "rotation_averaged",
}


def get_capabilities(method: Any) -> Capabilities:
    """The :class:`Capabilities` ``method`` declares (the defaults when it declares none).

    Raises:
        TypeError: ``capabilities`` is not a :class:`Capabilities`, or it promises a method
            (e.g. ``transform_rotations``) that ``method`` lacks; the message names both.
    """
    declared = getattr(method, "capabilities", None)
    if declared is None:
        return Capabilities()
    name = getattr(method, "name", type(method).__name__)
    if not isinstance(declared, Capabilities):
        raise TypeError(
            f"{name}: capabilities must be a sfa_gym.capabilities.Capabilities, got {declared!r}"
        )
    if declared.rotation_indices and not declared.transform_rotations:
        raise TypeError(
            f"{name} declares the capability rotation_indices without transform_rotations"
        )
    for field in dataclasses.fields(declared):
        promised = _PROMISED.get(field.name)
        if (
            promised
            and getattr(declared, field.name)
            and not callable(getattr(method, promised, None))
        ):
            raise TypeError(
                f"{name} declares the capability {field.name} but has no {promised}() method"
            )
    return declared
