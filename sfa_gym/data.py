"""Where the data that travels with sfa-gym is found: world specs, baseline plug-ins, track files
and the published result files.

One rule for all of them. In a checkout of the repository (the package's parent folder holds a
``pyproject.toml`` of the ``sfa-gym`` project) the checkout's folder is used, so that an edit
there is what runs. Installed from a wheel, the package carries the same files inside itself
(``pyproject.toml``'s force-include): ``sfa_gym/envs_data`` and so on. A folder of the same name
that another distribution put next to the package in ``site-packages`` is never looked at.
"""

from __future__ import annotations

import tomllib
from pathlib import Path
from typing import Literal

__all__ = [
    "DATA_FOLDERS",
    "DataKind",
    "PROJECT_NAME",
    "checkout_root",
    "data_folder",
    "packaged_path",
]

PROJECT_NAME = "sfa-gym"
"""The ``[project] name`` in the repository's ``pyproject.toml``."""

DataKind = Literal["envs", "baselines", "tracks", "published"]

DATA_FOLDERS: dict[str, tuple[str, str]] = {
    "envs": ("envs", "envs_data"),
    "baselines": ("baselines", "plugins_data"),
    "tracks": ("tracks", "tracks_data"),
    "published": ("published", "published_data"),
}
"""Each kind of data: its folder in a checkout and its folder inside the installed package."""


def _package_dir() -> Path:
    return Path(__file__).resolve().parent


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


def data_folder(kind: DataKind, package_dir: Path | None = None) -> Path:
    """The folder of ``kind`` (see :data:`DATA_FOLDERS`): the checkout's in a checkout, else
    the copy inside the installed package.

    Raises:
        ValueError: ``kind`` is not one of :data:`DATA_FOLDERS`.
        FileNotFoundError: neither folder exists (an incomplete installation).
    """
    if kind not in DATA_FOLDERS:
        raise ValueError(f"data kind must be one of {sorted(DATA_FOLDERS)}, got {kind!r}")
    in_checkout, shipped = DATA_FOLDERS[kind]
    return packaged_path(f"sfa_gym's {kind} data", in_checkout, shipped, package_dir)


def packaged_path(
    what: str, in_checkout: str, shipped: str, package_dir: Path | None = None, folder: bool = True
) -> Path:
    """``in_checkout`` of the checkout in a checkout, else ``shipped`` inside the installed
    package (``package_dir``): the first that is a folder (``folder=False``: a file).

    Raises:
        FileNotFoundError: neither exists (an incomplete installation); the message names
            ``what``.
    """
    package_dir = package_dir or _package_dir()
    root = checkout_root(package_dir)
    candidates = ([root / in_checkout] if root is not None else []) + [package_dir / shipped]
    for path in candidates:
        if path.is_dir() if folder else path.is_file():
            return path
    raise FileNotFoundError(
        f"{what} is missing: none of {', '.join(map(str, candidates))} exists; reinstall the "
        "package"
    )
