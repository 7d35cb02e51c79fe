"""Feature methods for the localization leaderboard, and loading them from plug-in files.

A *feature method* turns panoramic views into feature vectors; a regression from
:mod:`sfa_gym.localization.regression` then maps the features to metres. It is any object with

- ``name: str``: the leaderboard label;
- ``fit(views (N, H, W, 3) uint8, sequence_ids=None) -> self``: unsupervised fit; the row order
  of ``views`` is the time order of the training run (what SFA learns from); ``sequence_ids``
  ``(N,)`` optionally marks separate sequences, for methods that care;
- ``transform(views (N, H, W, 3) uint8) -> (N, k) float``;

and, optionally, ``regressor: str``, the regression it is meant to be paired with (a name for
:func:`~sfa_gym.localization.regression.make_regressor`), and after ``fit`` ``input_shape_``
``(H, W, 3)``, which makes a fitted method usable as a feature model in
:class:`sfa_gym.wrappers.SlowFeatureObservation`.

Methods live in plug-in files (the repository's ``baselines/*.py``), loaded by path with
:func:`load_method_file`, so that ``sfa_gym`` never imports them as a package. A plug-in file
defines at module level either ``make_method(**kwargs)`` or ``METHOD`` (a class called with the
keyword arguments), and, by convention, a frozen dataclass ``Args`` of its arguments with a
docstring under each field. ``Args`` is read the way the ``sfa-gym`` command line reads its
settings (with tyro): :meth:`MethodFactory.arguments` lists its fields with their docstrings, and
:meth:`MethodFactory.from_command_line` builds a method from options such as ``--n-bands 4``.
A file that does not follow this protocol raises :class:`PluginError`, naming the file.
"""

from __future__ import annotations

import dataclasses
import hashlib
import importlib.util
import sys
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType
from typing import Any, Protocol, runtime_checkable

import numpy as np
from numpy.typing import NDArray

from sfa_gym._types import check_views

__all__ = [
    "Argument",
    "FeatureMethod",
    "MethodFactory",
    "PluginError",
    "check_made",
    "check_views",
    "import_plugin_file",
    "iter_chunks",
    "list_method_files",
    "load_method_file",
    "plugin_arguments",
    "plugin_path",
]


@runtime_checkable
class FeatureMethod(Protocol):
    """Panoramic views in, feature vectors out (see the module docstring)."""

    name: str

    def fit(
        self, views: NDArray[np.uint8], sequence_ids: NDArray[np.integer] | None = None
    ) -> FeatureMethod: ...

    def transform(self, views: NDArray[np.uint8]) -> NDArray[np.floating]: ...


class PluginError(TypeError):
    """A plug-in file that does not follow the feature-method protocol (the message names the
    file and what is wrong)."""


def iter_chunks(n: int, chunk: int) -> Iterator[slice]:
    """Slices ``[0, chunk), [chunk, 2 chunk), ...`` covering ``range(n)``."""
    for start in range(0, n, chunk):
        yield slice(start, min(start + chunk, n))


@dataclass(frozen=True)
class Argument:
    """One field of a method's ``Args`` dataclass: its type (as written), default and docstring."""

    name: str
    type: str
    default: Any
    doc: str


@dataclass(frozen=True)
class MethodFactory:
    """A loaded plug-in file: call it with keyword arguments to get a fresh feature method.

    Attributes:
        name: The file's stem (e.g. ``"band_means"``).
        path: The plug-in file.
        make: The file's ``make_method`` (or ``METHOD``).
        args_type: The file's ``Args`` dataclass, or None if it has none.
    """

    name: str
    path: Path
    make: Callable[..., Any]
    args_type: type | None

    def __call__(self, **kwargs: Any) -> FeatureMethod:
        method = self.make(**kwargs)
        check_made(self.path, method, ("fit", "transform"), "a feature method", "fit(views)")
        return method

    def arguments(self) -> list[Argument]:
        """The fields of ``Args`` with their docstrings (empty without an ``Args`` dataclass),
        read with the parser that gives the command line its help text."""
        if self.args_type is None:
            return []
        import docstring_parser  # tyro's docstring reader

        docs = {
            param.arg_name: " ".join((param.description or "").split())
            for param in docstring_parser.parse_from_object(self.args_type).params
        }
        out = []
        for field in dataclasses.fields(self.args_type):
            if field.default is not dataclasses.MISSING:
                default = field.default
            elif field.default_factory is not dataclasses.MISSING:
                default = field.default_factory()
            else:
                default = dataclasses.MISSING
            out.append(Argument(field.name, str(field.type), default, docs.get(field.name, "")))
        return out

    def from_command_line(self, argv: Sequence[str]) -> FeatureMethod:
        """A fresh method with ``Args`` read from options (``--n-bands 4``; ``--help`` lists the
        fields with their docstrings and exits), as ``sfa-gym`` reads its settings."""
        import tyro

        if self.args_type is None:
            if list(argv):
                raise PluginError(f"{self.path} has no Args dataclass: it takes no options")
            return self()
        args = tyro.cli(self.args_type, args=list(argv), prog=self.name)
        return self(**{f.name: getattr(args, f.name) for f in dataclasses.fields(args)})


def check_made(path: Path, made: Any, methods: tuple[str, ...], kind: str, usage: str) -> None:
    """Refuse what a plug-in file made unless it has ``name: str`` and callable ``methods``.

    Raises:
        PluginError: naming the file, ``kind`` (e.g. ``"a feature method"``), an example call
            ``usage`` and what is missing or wrong.
    """
    wrong = [a for a in methods if not callable(getattr(made, a, None))]
    if not isinstance(getattr(made, "name", None), str):
        wrong.insert(0, "name")
    if wrong:
        raise PluginError(
            f"{path} made {made!r}, which is not {kind}: it needs name: str and "
            f"{', '.join(methods)} (e.g. {usage}) (missing or wrong: {wrong})"
        )


def plugin_path(path: str | Path, kind: str) -> Path:
    """``path`` resolved, checked to be an existing ``.py`` file (``kind`` names it in errors).

    Raises:
        FileNotFoundError: no such file. ValueError: not a ``.py`` file.
    """
    path = Path(path).resolve()
    if not path.is_file():
        raise FileNotFoundError(f"no {kind} file at {path}")
    if path.suffix != ".py":
        raise ValueError(f"a {kind} file must be a .py file, got {path}")
    return path


def import_plugin_file(path: Path) -> ModuleType:
    """Execute the file at ``path`` as a module of its own (not its folder as a package, no
    ``sys.path`` change); a failure to import is a :class:`PluginError` naming the file."""
    # A name unique per file keeps two plug-ins with the same stem (or a plug-in named like an
    # installed module) from replacing each other in sys.modules.
    digest = hashlib.sha1(str(path).encode()).hexdigest()[:10]
    module_name = f"sfa_gym_plugin_{path.stem}_{digest}"
    spec = importlib.util.spec_from_file_location(module_name, path)
    if spec is None or spec.loader is None:
        raise PluginError(f"cannot load {path} as a Python module")
    module = importlib.util.module_from_spec(spec)
    # Registered before executing: dataclasses look their module up in sys.modules.
    sys.modules[module_name] = module
    try:
        spec.loader.exec_module(module)
    except Exception as error:
        del sys.modules[module_name]
        raise PluginError(
            f"the plug-in file {path} failed to import: {type(error).__name__}: {error}"
        ) from error
    except BaseException:
        del sys.modules[module_name]
        raise
    return module


def load_method_file(path: str | Path) -> MethodFactory:
    """Load a feature-method plug-in file by path (e.g. ``baselines/band_means.py``).

    Returns a :class:`MethodFactory`; ``factory(**kwargs)`` builds a fresh method.

    Raises:
        FileNotFoundError: no such file.
        ValueError: not a ``.py`` file.
        PluginError: the file fails to import or does not follow the protocol.
    """
    path = plugin_path(path, "feature-method")
    module = import_plugin_file(path)
    make = getattr(module, "make_method", None) or getattr(module, "METHOD", None)
    if make is None or not callable(make):
        raise PluginError(
            f"{path} defines neither make_method(**kwargs) nor a METHOD class at module level"
        )
    args_type = getattr(module, "Args", None)
    if args_type is not None and not (
        isinstance(args_type, type) and dataclasses.is_dataclass(args_type)
    ):
        raise PluginError(
            f"{path}: Args must be a dataclass of the method's arguments, got {args_type!r}"
        )
    return MethodFactory(name=path.stem, path=path, make=make, args_type=args_type)


def plugin_arguments(path: Path, args_type: type, args: Mapping[str, Any]) -> dict[str, Any]:
    """Every field of a plug-in's ``Args`` dataclass ``args_type`` with ``args`` applied, as a
    dict (the defaults filled in: what a result records); ``path`` names the file in errors.

    Raises:
        ValueError: a key of ``args`` is not a field of ``Args``, or ``Args`` refuses a value.
    """
    names = [f.name for f in dataclasses.fields(args_type)]
    unknown = sorted(set(args) - set(names))
    if unknown:
        raise ValueError(f"{path}: unknown argument {unknown[0]!r}; its Args fields are {names}")
    try:
        filled = args_type(**dict(args))
    except (TypeError, ValueError) as error:
        raise ValueError(f"{path}: bad arguments {dict(args)!r}: {error}") from None
    return {name: getattr(filled, name) for name in names}


def list_method_files(directory: str | Path) -> list[Path]:
    """The plug-in files of a directory: ``*.py`` not starting with ``_``, sorted by name."""
    directory = Path(directory)
    if not directory.is_dir():
        raise FileNotFoundError(f"no directory {directory}")
    return sorted(p for p in directory.glob("*.py") if not p.name.startswith("_"))
