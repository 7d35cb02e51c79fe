"""Which plug-in folder ``sfa-gym localize`` loads feature methods from, and loading them.

``sfa_gym`` never imports from a folder the user did not name, with one exception that the user
did set up: in a checkout of the repository (the package's parent folder holds a
``pyproject.toml`` of the ``sfa-gym`` project and a ``baselines/`` folder) the checkout's
``baselines/`` are the default. Installed from a wheel, the package ships the same files as
``sfa_gym/plugins_data/``; a ``baselines`` folder that another distribution put next to the
package in ``site-packages`` is never looked at.
"""

from __future__ import annotations

import sys
import tomllib
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import sfa_gym
from sfa_gym.localization.methods import FeatureMethod, list_method_files, load_method_file

__all__ = ["PROJECT_NAME", "checkout_root", "default_plugin_folder", "load_plugins"]

PROJECT_NAME = "sfa-gym"
"""The ``[project] name`` in the repository's ``pyproject.toml``."""

SHIPPED_FOLDER = "plugins_data"
"""The folder inside the installed package that holds the shipped plug-ins."""


def _package_dir() -> Path:
    return Path(sfa_gym.__file__).resolve().parent


def checkout_root(package_dir: Path | None = None) -> Path | None:
    """The repository folder if ``package_dir`` (default: the imported ``sfa_gym``) lies in a
    checkout of this project, else None."""
    root = (package_dir or _package_dir()).parent
    try:
        with open(root / "pyproject.toml", "rb") as file:
            name = tomllib.load(file).get("project", {}).get("name")
    except (OSError, tomllib.TOMLDecodeError):
        return None
    return root if name == PROJECT_NAME else None


def default_plugin_folder(package_dir: Path | None = None) -> tuple[Path | None, str]:
    """The plug-in folder to use when none is named, and a sentence saying where it comes from.

    The checkout's ``baselines/`` in a checkout; otherwise the plug-ins shipped inside the
    package; otherwise none.
    """
    package_dir = package_dir or _package_dir()
    root = checkout_root(package_dir)
    if root is not None and (root / "baselines").is_dir():
        return root / "baselines", f"baselines of the checkout {root}"
    shipped = package_dir / SHIPPED_FOLDER
    if shipped.is_dir():
        return (
            shipped,
            f"the baselines shipped with sfa-gym ({shipped}); name another folder with --baselines",
        )
    return (
        None,
        "no baselines: not run from a checkout and none shipped; name a folder with --baselines",
    )


def load_plugins(
    folder: Path | None, *, use_default: bool = True, package_dir: Path | None = None
) -> list[tuple[FeatureMethod, tuple[str, ...]]]:
    """The feature methods of the plug-in files in ``folder``, each with the regressions it is
    evaluated with: the linear one, the one it is paired with (``regressor``) and those it
    lists in ``extra_regressors``.

    Args:
        folder: the folder the user named, or None.
        use_default: with ``folder=None``, load the :func:`default_plugin_folder` (saying on
            stderr which one when it is not the checkout's); without it, load nothing.
        package_dir: where ``sfa_gym`` is installed (for tests).

    Raises:
        ValueError: ``folder`` is not a folder.
    """
    if folder is not None:
        if not Path(folder).is_dir():
            raise ValueError(f"--baselines {str(folder)!r} is not a folder")
    elif use_default:
        folder, origin = default_plugin_folder(package_dir)
        if folder is None or checkout_root(package_dir) is None:
            print(f"sfa-gym: {origin}", file=sys.stderr)
    methods: list[tuple[FeatureMethod, tuple[str, ...]]] = []
    if folder is None:
        return methods
    for path in list_method_files(folder):
        method: Any = load_method_file(path)()
        regressors: Sequence[str] = ("linear", getattr(method, "regressor", "linear"))
        methods.append((method, (*regressors, *getattr(method, "extra_regressors", ()))))
    return methods
