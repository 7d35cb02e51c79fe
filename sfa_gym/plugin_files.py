"""Where plug-in files are: the built-in ones (a checkout's ``baselines/`` or the copy shipped in
the package), a folder's plug-in files, and the file a name or path stands for; and the error of
a file that does not follow the contract. Both sides of a plug-in's isolation use them: the
evaluator finds the file, the worker process imports it (:mod:`sfa_gym.plugins`,
:mod:`sfa_gym.sandbox`)."""

from __future__ import annotations

import os
import re
import sys
from collections.abc import Mapping
from pathlib import Path
from typing import Literal

from sfa_gym.data import checkout_root, data_folder

__all__ = [
    "KIND_NAMES",
    "Kind",
    "OPT_IN_BUILTINS",
    "PluginError",
    "builtin",
    "default_baseline_files",
    "default_plugin_folder",
    "list_plugin_files",
    "missing_extra",
    "resolve_plugin",
]

Kind = Literal["method", "controller"]

KIND_NAMES: Mapping[str, str] = {"method": "feature-method", "controller": "controller"}
"""How errors name a plug-in file of each kind (``no feature-method file at ...``)."""


class PluginError(TypeError):
    """A plug-in file that does not follow the contract (the message names the file and what is
    wrong)."""


# ---------------------------------------------------------------------------------------------
# Where the built-in plug-ins are


def default_plugin_folder(package_dir: Path | None = None) -> tuple[Path | None, str]:
    """The folder of the built-in plug-ins, and a sentence saying where it comes from.

    In a checkout of the repository (the package's parent folder holds this project's
    ``pyproject.toml`` and a ``baselines/`` folder) the checkout's ``baselines/``; otherwise the
    plug-ins shipped inside the package; otherwise none. A ``baselines`` folder that another
    distribution put next to the package in ``site-packages`` is never looked at.
    """
    try:
        folder = data_folder("baselines", package_dir)
    except FileNotFoundError:
        return (
            None,
            "no baselines: not run from a checkout and none shipped; name a folder with "
            "--baselines",
        )
    root = checkout_root(package_dir)
    if root is not None and folder == root / "baselines":
        return folder, f"baselines of the checkout {root}"
    return (
        folder,
        f"the baselines shipped with sfa-gym ({folder}); name another folder with --baselines",
    )


def list_plugin_files(directory: str | Path) -> list[Path]:
    """The plug-in files of a directory: ``*.py`` not starting with ``_``, sorted by name."""
    directory = Path(directory)
    if not directory.is_dir():
        raise FileNotFoundError(f"no directory {directory}")
    return sorted(p for p in directory.glob("*.py") if not p.name.startswith("_"))


def resolve_plugin(source: str | os.PathLike[str], kind: Kind = "method") -> Path:
    """The plug-in file of ``source``: a built-in name (``"band_means"``, a Python identifier)
    or a path to a ``.py`` file.

    Raises:
        FileNotFoundError: no such file, or no built-in plug-in of that name (the message lists
            the built-in ones).
        ValueError: a path that is not a ``.py`` file.
    """
    what = KIND_NAMES[kind]
    if isinstance(source, str) and source.isidentifier():
        folder, _ = default_plugin_folder()
        if folder is not None and kind == "controller":
            folder = folder / "controllers"
        path = None if folder is None else folder / f"{source}.py"
        if path is None or not path.is_file():
            known = [] if folder is None or not folder.is_dir() else list_plugin_files(folder)
            raise FileNotFoundError(
                f"no built-in {what} {source!r}; the built-in ones are {[p.stem for p in known]} "
                f"(in {folder}); or give the path of a .py file"
            )
        return path.resolve()
    path = Path(source).resolve()
    if not path.is_file():
        raise FileNotFoundError(f"no {what} file at {path}")
    if path.suffix != ".py":
        raise ValueError(f"a {what} file must be a .py file, got {path}")
    return path


def builtin(source: str | os.PathLike[str], kind: Kind = "method") -> bool:
    """Whether the plug-in ``source`` is one of the package's own files (its resolved path lies
    in the built-in folder of its kind: :func:`default_plugin_folder`)."""
    folder, _ = default_plugin_folder()
    if folder is None:
        return False
    home = folder / "controllers" if kind == "controller" else folder
    return resolve_plugin(source, kind).parent == home.resolve()


def missing_extra(error: BaseException) -> str | None:
    """The optional dependencies (``"deep"``) whose absence made a plug-in file fail to import,
    read from the hint ``pip install 'sfa-gym[EXTRA]'`` its error gives (the built-in files that
    need an extra say so that way); None for any other failure."""
    found = re.search(r"pip install 'sfa-gym\[(\w+)\]'", str(error))
    return None if found is None else found.group(1)


OPT_IN_BUILTINS = ("contrastive", "deep_sfa")
"""Built-in methods that the command line's protocols run only when ``--baselines`` names a
folder that holds them: they train for minutes (gradient descent on the training views), the
other baselines in seconds."""


def default_baseline_files(folder: str | Path) -> list[Path]:
    """The plug-in files of the default baselines folder that the command line's protocols run:
    all but :data:`OPT_IN_BUILTINS`, whose names are said on stderr."""
    files = list_plugin_files(folder)
    left_out = [p.name for p in files if p.stem in OPT_IN_BUILTINS]
    if left_out:
        print(
            f"sfa-gym: {', '.join(left_out)} left out (minutes of training each); "
            "name a --baselines folder that holds them to include them",
            file=sys.stderr,
        )
    return [p for p in files if p.stem not in OPT_IN_BUILTINS]
