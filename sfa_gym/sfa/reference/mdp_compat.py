"""Importing MDP 3.6 on numpy 2 and scipy >= 1.14: the compatibility shim.

MDP predates numpy 2 and scipy 1.14 and no longer imports as released. :func:`import_mdp`
applies the smallest shim that makes it work, confined to MDP's own namespace as far as
possible; its docstring lists each patch and why. Used by :mod:`sfa_gym.sfa.reference.mdp`.
"""

from __future__ import annotations

import importlib
import importlib.util
import sys
import types
import warnings
from typing import Any

import numpy as np

__all__ = ["MDP_INSTALL_HINT", "import_mdp"]

MDP_INSTALL_HINT = (
    "MDP is not installed: `pip install 'mdp>=3.6'` (or `pip install 'sfa-gym[mdp]'`)"
)

_SHIM_MARK = "_sfa_gym_shim_applied"
_NUMPY_NAMES_MDP_READS_FROM_SCIPY = ("pi", "inf", "newaxis", "mgrid", "typecodes")


def _old_eigh_namespace(linalg: types.ModuleType) -> types.SimpleNamespace:
    """``scipy.linalg`` as MDP's ``wrap_eigh`` expects it (scipy < 1.14).

    scipy 1.14 removed ``eigh``'s ``eigvals=(lo, hi)`` (0-based, inclusive) and ``turbo`` keywords.
    ``eigvals`` maps one-to-one onto ``subset_by_index=[lo, hi]``. ``turbo=True`` selected the
    divide-and-conquer driver for full generalized problems, which is scipy's default driver there
    now (and with a subset, old and new scipy both use the expert driver), so it is dropped.
    """

    def eigh(a: Any, b: Any = None, *, eigvals: Any = None, turbo: bool = True, **kwargs: Any):
        del turbo  # see the docstring: the default driver choice is the old turbo choice
        if eigvals is not None:
            kwargs["subset_by_index"] = [int(eigvals[0]), int(eigvals[1])]
        return linalg.eigh(a, b, **kwargs)

    return types.SimpleNamespace(eigh=eigh, LinAlgError=linalg.LinAlgError)


def import_mdp() -> types.ModuleType:
    """Import MDP 3.6 on numpy 2 / scipy >= 1.14 and return the ``mdp`` module.

    Idempotent: the shim is applied once per process. What it patches, and why:

    1. ``typeDict`` (removed in numpy 1.24; MDP reads it once, at import, from its array
       namespace, which is the ``scipy`` module, to list float types) is set on ``scipy`` to
       ``numpy.sctypeDict`` *during the import only*, then removed again.
    2. ``scipy.random`` (removed from scipy; MDP imports it as its random backend and, failing,
       silently falls back to a numpy backend without generalized eigensolvers) is provided as
       ``numpy.random`` through ``sys.modules`` during the import only, never as an attribute.
    3. MDP uses the ``scipy`` module as its numpy namespace and, on any scipy >= 1.4, copies ~500
       numpy names into it. It also reads numpy constants that scipy no longer re-exports
       (``pi``, ``inf``, ``newaxis``, ``mgrid``, ``typecodes``): these are added to ``scipy`` for
       good, as MDP needs them at run time. Two of MDP's copies shadow scipy's own attributes
       (``scipy.test``, ``scipy.show_config``): those are restored. No existing scipy attribute
       changes, so code that uses scipy normally is unaffected.
    4. ``mdp.utils.symeig``: MDP picks its LAPACK-backed ``wrap_eigh`` only when
       ``scipy.linalg.eigh`` has more than 4 positional parameters; scipy made them keyword-only,
       so MDP falls back to ``_symeig_fake`` (whitening by a full eigendecomposition). We restore
       ``wrap_eigh`` (what MDP ran on the scipy it was written for) in MDP's modules that bound
       the name, and give ``wrap_eigh`` -- in its own module's namespace only -- an ``eigh``
       with the old signature (``eigvals=(lo, hi)`` -> ``subset_by_index=[lo, hi]``).
       ``scipy.linalg`` itself is untouched.

    Raises:
        ImportError: MDP is not installed (the message says how to install it).
    """
    loaded = sys.modules.get("mdp")
    if loaded is not None and getattr(loaded, _SHIM_MARK, False):
        return loaded
    if importlib.util.find_spec("mdp") is None:
        raise ImportError(MDP_INSTALL_HINT)

    import scipy
    import scipy.linalg

    scipy_own = {
        name: getattr(scipy, name) for name in ("test", "show_config") if name in vars(scipy)
    }
    added_typedict = "typeDict" not in vars(scipy)
    added_random = "scipy.random" not in sys.modules
    for name in _NUMPY_NAMES_MDP_READS_FROM_SCIPY:
        if name not in vars(scipy):
            setattr(scipy, name, getattr(np, name))
    if added_typedict:
        scipy.typeDict = np.sctypeDict
    if added_random:
        sys.modules["scipy.random"] = np.random
    try:
        with warnings.catch_warnings():
            # MDP copies every numpy name it knows, deprecated ones included
            warnings.simplefilter("ignore", DeprecationWarning)
            mdp = importlib.import_module("mdp")
    finally:
        if added_typedict:
            del scipy.typeDict
        if added_random:
            del sys.modules["scipy.random"]
        for name, value in scipy_own.items():
            setattr(scipy, name, value)

    from mdp.utils import _symeig

    if mdp.numx_description != "scipy":
        raise ImportError(f"MDP chose the {mdp.numx_description!r} backend; expected 'scipy'")
    _symeig.numx_linalg = _old_eigh_namespace(scipy.linalg)
    mdp.utils.symeig = _symeig.wrap_eigh
    for module_name in ("sfa_nodes", "gsfa_nodes", "lle_nodes", "pca_nodes"):
        module = sys.modules.get(f"mdp.nodes.{module_name}")
        if module is not None and hasattr(module, "symeig"):
            module.symeig = _symeig.wrap_eigh
    mdp.config.ExternalDepFound("symeig", "scipy.linalg.eigh")
    setattr(mdp, _SHIM_MARK, True)
    return mdp
