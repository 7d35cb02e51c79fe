"""Loading a method for the leaderboard: the plug-in protocol of
:mod:`sfa_gym.localization.methods`, plus what a citable result needs.

A leaderboard method is a plug-in file (``baselines/band_means.py``) that defines, at module
level, ``make_method(**kwargs)`` (or a ``METHOD`` class) and ``Args``, a dataclass of its
arguments with a docstring under each field; the method it makes has ``name``, ``fit`` and
``transform``. ``Args`` is required here (the protocol itself only recommends it): a result
records the method's arguments, and only a dataclass says which arguments there are and their
defaults. Only the named file is executed: not its folder as a package, not its neighbours,
and nothing is added to ``sys.path``.
"""

from __future__ import annotations

import hashlib
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from sfa_gym.localization.methods import (
    FeatureMethod,
    MethodFactory,
    PluginError,
    load_method_file,
    plugin_arguments,
)

__all__ = ["PluginError", "file_sha256", "load_factory", "load_method", "method_arguments"]


def load_factory(path: str | os.PathLike[str]) -> MethodFactory:
    """The plug-in file at ``path``, checked for the leaderboard's protocol.

    Raises:
        FileNotFoundError: no such file.
        PluginError: the file fails to import, or lacks ``make_method``/``METHOD`` or ``Args``;
            the message names the file and what is missing.
    """
    factory = load_method_file(path)
    if factory.args_type is None:
        raise PluginError(
            f"{factory.path} defines no Args dataclass: a leaderboard method needs "
            "`@dataclass(frozen=True) class Args` listing its arguments (with defaults), so "
            "that results can record them"
        )
    return factory


def method_arguments(factory: MethodFactory, args: Mapping[str, Any]) -> dict[str, Any]:
    """All fields of the method's ``Args`` with ``args`` applied, as a dict (the defaults
    filled in: what a result records).

    Raises:
        ValueError: a key of ``args`` is not a field of ``Args``, or ``Args`` refuses a value.
    """
    assert factory.args_type is not None
    return plugin_arguments(factory.path, factory.args_type, args)


def load_method(
    path: str | os.PathLike[str], args: Mapping[str, Any] | None = None
) -> FeatureMethod:
    """A fresh, unfitted method from the plug-in file at ``path`` with ``args``.

    Raises:
        FileNotFoundError, PluginError, ValueError: see :func:`load_factory` and
            :func:`method_arguments`; PluginError also when what ``make_method`` returns lacks
            ``name``, ``fit`` or ``transform`` (named).
    """
    factory = load_factory(path)
    return factory(**method_arguments(factory, args or {}))


def file_sha256(path: str | os.PathLike[str]) -> str:
    """SHA-256 (hex) of a file: identifies the exact method a result was made with."""
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()
