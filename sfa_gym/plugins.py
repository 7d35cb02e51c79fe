"""Plug-ins: feature methods and navigation controllers loaded from Python files.

A plug-in is one readable Python file, loaded by path (``my_method.py``) or, for the built-in
ones, by name (``band_means``, ``sfa``; controllers: ``run_and_tumble``). The built-in files are
the repository's ``baselines/`` (controllers in ``baselines/controllers/``); installed from a
wheel, the package carries the same files as ``sfa_gym/plugins_data/``. Only the named file is
executed: not its folder as a package, not its neighbours, and nothing is added to ``sys.path``.

**Where it runs.** :func:`~sfa_gym.sandbox.isolation` decides, for every loader
(:func:`load_method`, :func:`load_controller`, :func:`describe`, :func:`load_plugins`): the
package's own files run in the evaluator's process (:class:`~sfa_gym.sandbox.InProcess`, with
one BLAS thread as a worker has); any other file is untrusted code and runs in a worker process
of its own (:mod:`sfa_gym.sandbox`), whose proxy looks like the method or controller:

- the worker is sent only what the protocol gives a plug-in: views without their poses; for a
  controller its observation and the rover's own sensors. The env, poses and the evaluator's
  objects never enter its address space, and scoring happens in the evaluator;
- what comes back is JSON-type values and arrays of numbers only, never unpickled objects;
  features are checked (shape, finite, bounded);
- every call has a wall-clock limit (:class:`~sfa_gym.sandbox.Limits`: ``fit`` 30 min, one
  ``transform`` 10 min, ``act`` 1 s, ...); past it the worker is killed and
  :class:`~sfa_gym.sandbox.PluginTimeout` names the plug-in, the call and the limit; a worker
  that dies raises :class:`~sfa_gym.sandbox.PluginCrashed` with its exit code;
- a sweep plans its tasks from the worker's report of the file's ``Args`` (:func:`describe`);
- the worker's address space has a memory limit (``Limits.memory_mb``: else
  :class:`~sfa_gym.sandbox.PluginOutOfMemory`);
- where bubblewrap (``bwrap``) works, the worker sees a read-only filesystem with only its
  scratch folder writable, the render cache hidden, no network and its own PID namespace;
  elsewhere it is a plain child process in a scratch folder (said once on stderr).

:func:`load_method_plugin` and :func:`load_controller_plugin` import a file into the calling
process, with its full rights: for files you trust.

**The contract.** Every plug-in file defines at module level ``Args``: a dataclass (frozen, by
convention) of its arguments, each with a default, a type and a docstring under the field. The
loader builds ``Args`` from JSON-type keyword arguments (``--method-args n_bands=4``, a result
file's ``args``), refusing unknown names and values of the wrong type with a
:class:`ValueError` naming the file, the field and the value; ``--help`` lists the fields.

A **feature method** file also defines ``make_method(**args)`` (or ``METHOD``, a class called
with the arguments), which returns an unfitted method with

- ``name: str``: the leaderboard label;
- ``fit(views (N, H, W, 3) uint8, sequence_ids=None) -> self``: unsupervised fit; the row order
  of ``views`` is the time order of the training run; ``sequence_ids`` ``(N,)`` optionally
  marks separate sequences;
- ``transform(views (N, H, W, 3) uint8) -> (N, k) float``;
- optionally ``capabilities``, a :class:`~sfa_gym.capabilities.Capabilities` (a property when
  a parameter decides it): ``rotation_invariant`` (column statistics: each full-width panorama
  is fitted on and transformed once), ``regressor`` (the regression it pairs with, default
  ``"linear"``) and ``extra_regressors`` (reported besides by ``sfa-gym localize``).

Methods follow scikit-learn's estimator conventions (subclass ``BaseEstimator`` and
``TransformerMixin``; the fitted state ends in ``_``, ``input_shape_`` among it).

A **controller** file also defines ``make_controller(rover, weights, **args)``: a fresh
controller for a :class:`~sfa_gym.navigation.sensors.Rover` and the cost weights of the features
``(k,)``, with ``name: str``, ``reset(obs, info)`` at the start of an episode and ``act(obs,
info) -> (3,) float32`` (forward speed m/s, yaw rate rad/s, stop if > 0) every step. ``obs``
holds ``"features"`` and ``"goal_features"``; ``info`` only the rover's own sensors
(:class:`~sfa_gym.navigation.sensors.SensorsOnly`). One that declares
``capabilities = Capabilities(panoramas=True)`` also gets ``"panorama"`` and
``"goal_panorama"`` (``(H, W, 3)`` uint8, rendered; column ``c`` looks at ``heading +
2*pi*c/W``), at about ten times the cost per step.

A file that does not follow this contract raises :class:`PluginError`, naming the file and what
is missing.
"""

from __future__ import annotations

import dataclasses
import hashlib
import importlib.util
import os
import sys
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType
from typing import Any, ClassVar, Protocol, runtime_checkable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sfa_gym._json_types import dataclass_from_json
from sfa_gym._types import check_panoramas, check_views
from sfa_gym.capabilities import Capabilities, get_capabilities
from sfa_gym.data import checkout_root
from sfa_gym.plugin_files import (
    KIND_NAMES,
    Kind,
    PluginError,
    default_baseline_files,
    default_plugin_folder,
    list_plugin_files,
    missing_extra,
    resolve_plugin,
)

__all__ = [
    "Argument",
    "Capabilities",
    "ControllerPlugin",
    "FeatureMethod",
    "MethodPlugin",
    "Plugin",
    "PluginError",
    "checkout_root",
    "check_panoramas",
    "check_views",
    "close_plugins",
    "default_plugin_folder",
    "describe",
    "file_sha256",
    "get_capabilities",
    "iter_chunks",
    "list_plugin_files",
    "load_controller",
    "load_controller_plugin",
    "load_method",
    "load_method_plugin",
    "load_plugin",
    "load_plugins",
    "resolve_plugin",
]


@runtime_checkable
class FeatureMethod(Protocol):
    """Panoramic views in, feature vectors out (see the module docstring)."""

    name: str

    def fit(
        self, views: NDArray[np.uint8], sequence_ids: NDArray[np.integer] | None = None
    ) -> FeatureMethod: ...

    def transform(self, views: NDArray[np.uint8]) -> NDArray[np.floating]: ...


def iter_chunks(n: int, chunk: int) -> Iterator[slice]:
    """Slices ``[0, chunk), [chunk, 2 chunk), ...`` covering ``range(n)``."""
    for start in range(0, n, chunk):
        yield slice(start, min(start + chunk, n))


def file_sha256(path: str | os.PathLike[str]) -> str:
    """SHA-256 (hex) of a file: identifies the exact plug-in a result was made with."""
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


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


@dataclass(frozen=True)
class Argument:
    """One field of a plug-in's ``Args``: its type (as written), default and docstring."""

    name: str
    type: str
    default: Any
    doc: str


@dataclass(frozen=True)
class Plugin:
    """A loaded plug-in file (see the module docstring); call it to make a fresh method or
    controller.

    Attributes:
        name: the file's stem (e.g. ``"band_means"``): the label results use.
        path: the plug-in file.
        make: the file's ``make_method`` (or ``METHOD``) or ``make_controller``.
        args_type: the file's ``Args`` dataclass.
    """

    kind: ClassVar[Kind]
    factories: ClassVar[tuple[str, ...]]
    """the module-level names a file of this kind may define its factory under"""
    missing: ClassVar[str]
    """how an error says that the factory is missing"""
    name: str
    path: Path
    make: Callable[..., Any]
    args_type: type

    def parse(self, args: Mapping[str, Any] | None = None) -> Any:
        """``Args`` built from JSON-type keyword arguments ``args`` (the defaults for the rest).

        Raises:
            ValueError: a key that is not a field of ``Args``, a value of the wrong type, or a
                value ``Args`` refuses; the message names the file, the field and the value.
        """
        return dataclass_from_json(self.args_type, args or {}, str(self.path))

    def arguments(self, args: Mapping[str, Any] | None = None) -> dict[str, Any]:
        """Every field of ``Args`` with ``args`` applied, as a dict (the defaults filled in: what
        a result records). Raises as :meth:`parse`."""
        filled = self.parse(args)
        return {f.name: getattr(filled, f.name) for f in dataclasses.fields(self.args_type)}

    def describe(
        self, args: Mapping[str, Any] | None = None, *, make: bool = False
    ) -> dict[str, Any]:
        """What a sweep records of this plug-in with ``args``, in JSON types: ``kind``, ``name``,
        ``path``, ``arguments`` (every field of ``Args``, the defaults filled in) and
        ``defaults`` (the fields that have one). The worker process reports this for the
        evaluator, which never imports the file (:func:`sfa_gym.sandbox.describe_plugin`).

        Args:
            make: a method is also made once (and dropped), so that the checks of its factory
                run too: a worker does, where the factory's side effects stay in the worker.

        Raises:
            ValueError: see :meth:`parse`, or a value the factory refuses (the message names
                the file). PluginError: a value that is not a JSON type, or what the factory
                made does not follow the contract.
        """
        arguments = self.arguments(args)
        if make and isinstance(self, MethodPlugin):
            try:
                self(**dict(args or {}))
            except (TypeError, ValueError) as error:
                if isinstance(error, PluginError) or str(self.path) in str(error):
                    raise
                raise ValueError(
                    f"{self.path}: bad arguments {dict(args or {})!r}: {error}"
                ) from None
        defaults = {
            a.name: a.default for a in self._defaults() if a.default is not dataclasses.MISSING
        }
        return {
            "kind": self.kind,
            "name": self.name,
            "path": str(self.path),
            "arguments": {
                k: _json_value(v, f"{self.path}: argument {k}") for k, v in arguments.items()
            },
            "defaults": {
                k: _json_value(v, f"{self.path}: default of {k}") for k, v in defaults.items()
            },
        }

    def _defaults(self) -> list[Argument]:
        """The fields of ``Args`` with their defaults (``MISSING``: none), without docstrings."""
        out = []
        for field in dataclasses.fields(self.args_type):
            default = field.default
            if default is dataclasses.MISSING and field.default_factory is not dataclasses.MISSING:
                default = field.default_factory()
            out.append(Argument(field.name, str(field.type), default, ""))
        return out

    def fields(self) -> list[Argument]:
        """The fields of ``Args`` with their docstrings, read with the parser that gives the
        command line its help text."""
        import docstring_parser  # tyro's docstring reader

        docs: dict[str, str] = {}
        # a subclass's own docstrings over those of the fields it inherits
        for klass in reversed(self.args_type.__mro__):
            if dataclasses.is_dataclass(klass):
                for param in docstring_parser.parse_from_object(klass).params:
                    docs[param.arg_name] = " ".join((param.description or "").split())
        return [dataclasses.replace(a, doc=docs.get(a.name, "")) for a in self._defaults()]

    def _check_made(self, made: Any, methods: tuple[str, ...], usage: str) -> None:
        wrong = [a for a in methods if not callable(getattr(made, a, None))]
        if not isinstance(getattr(made, "name", None), str):
            wrong.insert(0, "name")
        if wrong:
            kind = KIND_NAMES[self.kind].replace("-", " ")
            raise PluginError(
                f"{self.path} made {made!r}, which is not a {kind} (the plug-in contract: "
                f"sfa_gym.plugins): it needs name: str and {', '.join(methods)} (e.g. {usage}) "
                f"(missing or wrong: {wrong})"
            )


@dataclass(frozen=True)
class MethodPlugin(Plugin):
    """A feature-method plug-in: ``plugin(**args)`` is a fresh, unfitted method."""

    kind: ClassVar[Kind] = "method"
    factories: ClassVar[tuple[str, ...]] = ("make_method", "METHOD")
    missing: ClassVar[str] = "neither make_method(**kwargs) nor a METHOD class"

    def __call__(self, **args: Any) -> FeatureMethod:
        """A fresh method with ``args`` (JSON types; see :meth:`parse`).

        Raises:
            ValueError: see :meth:`parse`. PluginError: what the file made lacks ``name``,
                ``fit`` or ``transform``.
        """
        method = self.make(**self.arguments(args))
        self._check_made(method, ("fit", "transform"), "fit(views)")
        return method

    def from_command_line(self, argv: Sequence[str]) -> FeatureMethod:
        """A fresh method with ``Args`` read from options (``--n-bands 4``; ``--help`` lists the
        fields with their docstrings and exits), as ``sfa-gym`` reads its settings."""
        import tyro

        args = tyro.cli(self.args_type, args=list(argv), prog=self.name)
        return self(**{f.name: getattr(args, f.name) for f in dataclasses.fields(args)})


@dataclass(frozen=True)
class ControllerPlugin(Plugin):
    """A controller plug-in: ``plugin(rover, weights, args)`` is a fresh controller that sees only
    the rover's sensors."""

    kind: ClassVar[Kind] = "controller"
    factories: ClassVar[tuple[str, ...]] = ("make_controller",)
    missing: ClassVar[str] = "no make_controller(rover, weights, **kwargs)"

    def __call__(
        self, rover: Any, weights: ArrayLike, args: Mapping[str, Any] | None = None
    ) -> Any:
        """A fresh controller for ``rover`` (a :class:`~sfa_gym.navigation.sensors.Rover`) and
        cost ``weights`` ``(k,)``, wrapped in :class:`~sfa_gym.navigation.sensors.SensorsOnly`.

        Raises:
            ValueError: see :meth:`parse`. PluginError: what ``make_controller`` returned lacks
                ``name``, ``reset`` or ``act``.
        """
        from sfa_gym.navigation.sensors import SensorsOnly

        weights = np.asarray(weights, dtype=np.float64)
        controller = self.make(rover, weights, **self.arguments(args))
        self._check_made(controller, ("reset", "act"), "act(obs, info)")
        return SensorsOnly(controller)


def _json_value(value: Any, where: str) -> Any:
    """``value`` in JSON types (tuples as lists, paths as strings), as a result file records it;
    a PluginError naming ``where`` for a value that has none."""
    if value is None or isinstance(value, bool | int | float | str):
        return value
    if isinstance(value, os.PathLike):
        return os.fspath(value)
    if isinstance(value, list | tuple):
        return [_json_value(v, f"{where}[{i}]") for i, v in enumerate(value)]
    if isinstance(value, dict) and all(isinstance(k, str) for k in value):
        return {k: _json_value(v, f"{where}[{k!r}]") for k, v in value.items()}
    raise PluginError(
        f"{where} is {value!r}, a {type(value).__name__}: a result records only JSON types "
        "(None, bool, int, float, str, lists, dicts with str keys, paths)"
    )


def _args_type(path: Path, module: ModuleType, kind: Kind) -> type:
    args_type = getattr(module, "Args", None)
    if args_type is None:
        raise PluginError(
            f"{path} defines no Args dataclass: a {KIND_NAMES[kind]} needs "
            "`@dataclass(frozen=True) class Args` listing its arguments (with defaults), so "
            "that results can record them"
        )
    if not (isinstance(args_type, type) and dataclasses.is_dataclass(args_type)):
        raise PluginError(f"{path}: Args must be a dataclass of the arguments, got {args_type!r}")
    return args_type


PLUGIN_TYPES: Mapping[str, type[Plugin]] = {"method": MethodPlugin, "controller": ControllerPlugin}


def load_plugin(source: str | os.PathLike[str], kind: Kind = "method") -> Plugin:
    """The plug-in ``source`` of ``kind``: a built-in name (``"band_means"``, ``"run_and_tumble"``)
    or a file.

    Raises:
        FileNotFoundError, ValueError: see :func:`resolve_plugin`.
        PluginError: the file fails to import or does not follow the contract (no factory of its
            kind, no ``Args`` dataclass).
    """
    plugin_type = PLUGIN_TYPES[kind]
    path = resolve_plugin(source, kind)
    module = import_plugin_file(path)
    factories = [getattr(module, name, None) for name in plugin_type.factories]
    make = next((f for f in factories if callable(f)), None)
    if make is None:
        raise PluginError(f"{path} defines {plugin_type.missing} at module level")
    return plugin_type(path.stem, path, make, _args_type(path, module, kind))


def load_method_plugin(source: str | os.PathLike[str]) -> MethodPlugin:
    """The feature-method plug-in ``source`` (see :func:`load_plugin`)."""
    return load_plugin(source, "method")  # type: ignore[return-value]


def load_controller_plugin(source: str | os.PathLike[str]) -> ControllerPlugin:
    """The controller plug-in ``source`` (see :func:`load_plugin`)."""
    return load_plugin(source, "controller")  # type: ignore[return-value]


def _runs_here(source: str | os.PathLike[str], kind: Kind) -> bool:
    from sfa_gym.sandbox import isolation

    return isolation(**{kind: source}) in ("built-in", "in-process")


def load_method(
    source: str | os.PathLike[str],
    args: Mapping[str, Any] | None = None,
    *,
    limits: Any = None,
    hidden: Sequence[str | os.PathLike[str]] = (),
) -> FeatureMethod:
    """A fresh, unfitted method from the plug-in ``source`` with ``args`` (JSON types), in this
    process or a worker with ``limits`` (:class:`~sfa_gym.sandbox.Limits`) that cannot read the
    folders ``hidden`` (see the module docstring); close it with ``close()``.

    Raises:
        FileNotFoundError, ValueError, PluginError: see :func:`load_method_plugin` and
            :meth:`Plugin.parse`. PluginTimeout, PluginCrashed: a worker hung or died while
            loading.
    """
    from sfa_gym.sandbox import InProcess, IsolatedMethod

    if _runs_here(source, "method"):
        return InProcess(load_method_plugin(source)(**dict(args or {})))  # type: ignore[return-value]
    return IsolatedMethod(source, args, limits, hidden)


def load_controller(
    source: str | os.PathLike[str],
    rover: Any,
    weights: ArrayLike,
    args: Mapping[str, Any] | None = None,
    *,
    limits: Any = None,
    hidden: Sequence[str | os.PathLike[str]] = (),
) -> Any:
    """A fresh controller from the plug-in ``source`` for ``rover`` and cost ``weights``, in
    this process or a worker, as :func:`load_method`; close it with ``close()``."""
    from sfa_gym.sandbox import InProcess, IsolatedController

    if _runs_here(source, "controller"):
        return InProcess(load_controller_plugin(source)(rover, weights, args))
    return IsolatedController(source, rover, weights, args, limits, hidden)


def describe(
    source: str | os.PathLike[str],
    kind: Kind,
    args: Mapping[str, Any] | None = None,
    *,
    limit: float,
    hidden: Sequence[str | os.PathLike[str]] = (),
) -> dict[str, Any]:
    """What a sweep records of the plug-in ``source`` with ``args`` (:meth:`Plugin.describe`):
    read here (a built-in made once, for its factory's checks; under IN_PROCESS not made, so
    that its side effects are its tasks') or in a worker within ``limit`` s (describe_plugin)."""
    from sfa_gym.sandbox import describe_plugin, isolation

    where = isolation(**{kind: source})
    if where in ("built-in", "in-process"):
        return load_plugin(source, kind).describe(args, make=where == "built-in")
    return describe_plugin(source, kind, args, limit=limit, hidden=hidden)


def load_plugins(
    folder: Path | None,
    *,
    use_default: bool = True,
    package_dir: Path | None = None,
    hidden: Sequence[str | os.PathLike[str]] = (),
) -> list[tuple[FeatureMethod, tuple[str, ...]]]:
    """The feature methods of the plug-in files in ``folder`` (default arguments, each loaded by
    :func:`load_method`), each with the regressions ``sfa-gym localize`` evaluates it with: the
    linear one, the one it is paired with and its extra ones. Close them with
    :func:`close_plugins`. A method named ``hierarchical_sfa`` (the built-in ``sfa.py``) is left
    out: the protocols train their own, with their ``--sfa.*`` settings, under that name. So
    is, with a line on stderr, a file that needs an extra not installed (the deep methods
    without torch). From the default folder, so are the methods that train for minutes
    (:func:`~sfa_gym.plugin_files.default_baseline_files`).

    Args:
        folder: the folder the user named, or None.
        use_default: with ``folder=None``, load the :func:`default_plugin_folder` (saying on
            stderr which one when it is not the checkout's); without it, load nothing.
        package_dir: where ``sfa_gym`` is installed (for tests).
        hidden: folders the workers must not read (the output folder, the render cache).

    Raises:
        ValueError: ``folder`` is not a folder.
        PluginError, PluginTimeout, PluginCrashed: a file that cannot be loaded (the methods
            loaded before it are closed).
    """
    if folder is not None and not Path(folder).is_dir():
        raise ValueError(f"--baselines {str(folder)!r} is not a folder")
    default = folder is None and use_default
    if default:
        folder, origin = default_plugin_folder(package_dir)
        if folder is None or checkout_root(package_dir) is None:
            print(f"sfa-gym: {origin}", file=sys.stderr)
    methods: list[tuple[FeatureMethod, tuple[str, ...]]] = []
    if folder is None:
        return methods
    files = default_baseline_files(folder) if default else list_plugin_files(folder)
    try:
        for path in files:
            try:
                method = load_method(path, hidden=hidden)
            except PluginError as error:
                extra = missing_extra(error)
                if extra is None:
                    raise
                print(f"sfa-gym: {path.name} left out: it needs sfa-gym[{extra}]", file=sys.stderr)
                continue
            if method.name == "hierarchical_sfa":
                method.close()  # type: ignore[attr-defined]
                continue
            found = get_capabilities(method)
            methods.append((method, ("linear", found.regressor, *found.extra_regressors)))
    except BaseException:
        close_plugins(methods)
        raise
    return methods


def close_plugins(methods: Sequence[tuple[FeatureMethod, Any]]) -> None:
    """Close every method of :func:`load_plugins` (stops the workers)."""
    for method, _ in methods:
        method.close()  # type: ignore[attr-defined]
