"""What a feature method or a navigation controller declares beyond the plug-in contract, read
by one function.

A method or a controller declares its properties in a class attribute ``capabilities``, a
:class:`Capabilities` (a property where a parameter decides it, as the baselines' ``regressor``
does); :func:`get_capabilities` reads it, the defaults for one that declares none.

These are estimator tags in the sense of scikit-learn's ``__sklearn_tags__``, kept in an
attribute of their own: scikit-learn's ``Tags`` has a fixed set of fields, none of these.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

__all__ = ["Capabilities", "get_capabilities"]


@dataclass(frozen=True)
class Capabilities:
    """The declared properties of a feature method or a controller."""

    rotation_invariant: bool = False
    """a full-width rotated view (a circular shift of the panorama's columns) has the panorama's
    own features (column statistics): each panorama is fitted on and transformed once instead
    of every view"""
    regressor: str = "linear"
    """the regression the features are paired with (a name for
    :func:`~sfa_gym.localization.regression.make_regressor`)"""
    extra_regressors: tuple[str, ...] = ()
    """regressions reported besides ``linear`` and ``regressor`` by ``sfa-gym localize``"""
    panoramas: bool = False
    """a navigation controller that acts on panoramas: the episode runner renders the current
    panorama at every step and the goal's once at the start of the episode and adds them to
    ``obs`` as ``"panorama"`` and ``"goal_panorama"``
    (:func:`~sfa_gym.navigation.evaluate.run_episode`; about ten times slower steps)"""


def get_capabilities(method: Any) -> Capabilities:
    """The :class:`Capabilities` ``method`` declares (the defaults when it declares none).

    Raises:
        TypeError: ``capabilities`` is not a :class:`Capabilities` (the message names both).
    """
    declared = getattr(method, "capabilities", None)
    if declared is None:
        return Capabilities()
    if not isinstance(declared, Capabilities):
        name = getattr(method, "name", type(method).__name__)
        raise TypeError(
            f"{name}: capabilities must be a sfa_gym.capabilities.Capabilities, got {declared!r}"
        )
    return declared
