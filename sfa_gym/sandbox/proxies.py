"""The evaluator's side of an isolated plug-in: a method or controller whose calls run in the
plug-in's worker process (:class:`~sfa_gym.sandbox.process.Worker`), each within its time limit.

What crosses to the worker is what the protocol gives a plug-in: views and panoramas (never
their poses), and for a controller its observation (features, and the current and goal panorama
for a controller that declares it acts on panoramas) and the rover's own sensors
(:data:`~sfa_gym.navigation.sensors.ROVER_SENSORS`). What comes back is checked here: numbers
and arrays of numbers where features or actions are expected.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from threadpoolctl import ThreadpoolController

from sfa_gym._checks import FEATURE_BOUND, machine_memory_bytes
from sfa_gym.capabilities import Capabilities
from sfa_gym.plugin_files import PluginError, resolve_plugin
from sfa_gym.sandbox.process import Worker

__all__ = [
    "TIME_LIMITS",
    "IsolatedController",
    "IsolatedMethod",
    "InProcess",
    "Limits",
    "check_memory_mb",
    "check_time_limits",
    "default_memory_mb",
]


def default_memory_mb(sharing: int = 1) -> int:
    """Three quarters of this machine's physical memory, MiB, shared by ``sharing`` workers that
    may run at the same time: the default memory limit of a worker (room for the evaluators and
    the system beside runaway plug-ins, which together cannot exhaust the machine)."""
    if isinstance(sharing, bool) or not isinstance(sharing, int) or sharing < 1:
        raise ValueError(f"sharing must be a positive int of workers, got {sharing!r}")
    return machine_memory_bytes() * 3 // 4 // 2**20 // sharing


TIME_LIMITS = ("load", "fit", "transform", "reset", "act")
"""The kinds of call that have a time limit (fields of :class:`Limits`, seconds)."""


def check_time_limits(seconds: Any, where: str = "time limits") -> dict[str, float]:
    """``seconds`` (``{"fit": 60}``) checked: an object whose keys are :data:`TIME_LIMITS` and
    whose values are positive numbers.

    Raises:
        ValueError: the message starts with ``where`` and names the bad key or value.
    """
    if not isinstance(seconds, Mapping):
        raise ValueError(f"{where} must be an object of seconds per kind of call, got {seconds!r}")
    for name, value in seconds.items():
        if name not in TIME_LIMITS:
            raise ValueError(f"{where}: no time limit named {name!r}; the limits are {TIME_LIMITS}")
        if isinstance(value, bool) or not isinstance(value, int | float) or not 0 < value < 1e9:
            raise ValueError(
                f"{where}: time limit {name} must be a positive number of seconds (below 1e9), "
                f"got {value!r}"
            )
    return dict(seconds)


def check_memory_mb(value: Any, where: str = "memory limit") -> int:
    """``value`` checked as a memory limit: a positive int of MiB.

    Raises:
        ValueError: the message starts with ``where`` and names the value.
    """
    if isinstance(value, bool) or not isinstance(value, int) or value < 1:
        raise ValueError(f"{where} must be a positive int of MiB, got {value!r}")
    return value


@dataclass(frozen=True)
class Limits:
    """What a plug-in's worker may spend: a wall-clock limit of each kind of call, seconds, and
    a memory limit (generous: a limit stops a plug-in that hangs or runs away, it does not rank
    fast or frugal ones)."""

    load: float = 300.0
    """importing the file and making the method or controller"""
    fit: float = 1800.0
    """``fit``"""
    transform: float = 600.0
    """one ``transform`` (a block of a few thousand views)"""
    reset: float = 10.0
    """a controller's ``reset``"""
    act: float = 1.0
    """one ``act`` of a controller"""
    memory_mb: int = dataclasses.field(default_factory=default_memory_mb)
    """the worker's address space, MiB (``RLIMIT_AS``, set before the plug-in is imported;
    default: :func:`default_memory_mb`); numpy with OpenBLAS reserves a few hundred MiB of it
    before a plug-in allocates anything"""

    @classmethod
    def of(
        cls, seconds: Mapping[str, float] | None, memory_mb: int | None = None, sharing: int = 1
    ) -> Limits:
        """The defaults with ``seconds`` (``{"fit": 60}``) and ``memory_mb`` (None: the
        default, :func:`default_memory_mb` shared by ``sharing`` workers at a time) applied.

        Raises:
            ValueError: a key that is not a kind of call (the message lists them), or a limit
                that is not a positive number.
        """
        given = check_time_limits(seconds or {})
        if memory_mb is None:
            memory_mb = default_memory_mb(sharing)
        return cls(**given, memory_mb=memory_mb)

    def __post_init__(self) -> None:
        check_time_limits({name: getattr(self, name) for name in TIME_LIMITS})
        check_memory_mb(self.memory_mb, "memory limit memory_mb")


class _Isolated:
    """The worker of one plug-in file, loaded with its arguments."""

    kind: str

    def __init__(
        self,
        source: str | os.PathLike[str],
        args: Mapping[str, Any] | None,
        limits: Limits | None,
        hidden: Sequence[str | os.PathLike[str]],
        **loading: Any,
    ) -> None:
        self.path = resolve_plugin(source, self.kind)  # type: ignore[arg-type]
        self.limits = limits or Limits()
        self._worker = Worker(str(self.path), hidden, self.limits.memory_mb)
        request = {"path": str(self.path), "kind": self.kind, "args": dict(args or {}), **loading}
        try:
            about = self._worker.call(request, self.limits.load, "loading")
        except BaseException:
            self._worker.stop()
            raise
        if not isinstance(about, dict) or not isinstance(about.get("name"), str):
            self._worker.stop()
            raise PluginError(f"{self.path} made a {self.kind} without a name: str")
        self.name: str = about["name"]
        self.arguments: dict[str, Any] = dict(about.get("arguments") or {})
        """every field of the plug-in's ``Args`` with the arguments applied (what results record)"""
        self._params: dict[str, Any] = dict(about.get("params") or {})
        try:
            found = dict(about["capabilities"])
            found["extra_regressors"] = tuple(found.get("extra_regressors", ()))
            self.capabilities = Capabilities(**found)
        except (TypeError, ValueError, KeyError) as error:
            self.close()
            raise PluginError(f"{self.path} reported unreadable capabilities: {error}") from None

    def _call(self, call: str, limit: float, *args: Any) -> Any:
        return self._worker.call({"call": call, "args": list(args)}, limit, f"{call}()")

    def close(self) -> None:
        """Stop the worker (the proxy is unusable afterwards)."""
        self._worker.close()

    @property
    def peak_rss_mb(self) -> float | None:
        """The worker's peak RSS, MiB, once it was closed (None before)."""
        return self._worker.peak_rss_mb

    def __enter__(self) -> _Isolated:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.name!r}, {str(self.path)!r})"


def _numbers(value: Any, who: str, what: str) -> NDArray[Any]:
    """``value`` as an array of real numbers, or a PluginError naming ``who`` and ``what``."""
    if isinstance(value, list):
        try:
            value = np.asarray(value)
        except ValueError:
            pass
    if not isinstance(value, np.ndarray) or value.dtype.kind not in "biuf":
        shown = f"an array of {value.dtype}" if isinstance(value, np.ndarray) else repr(value)[:80]
        raise PluginError(f"{who}: {what} must be an array of real numbers, got {shown}")
    return value


def checked_features(value: Any, shape: tuple[int, ...], who: str, what: str) -> NDArray[Any]:
    """``value`` as features whose leading dimensions are ``shape`` (plus one feature axis),
    finite and within :data:`FEATURE_BOUND`, or a PluginError naming ``who`` and ``what``."""
    found = _numbers(value, who, what)
    if found.ndim != len(shape) + 1 or found.shape[: len(shape)] != shape or found.shape[-1] < 1:
        expected = ", ".join(map(str, shape))
        raise PluginError(
            f"{who}: {what} must have shape ({expected}, k) with k >= 1, got {found.shape}"
        )
    if not found.size:
        return found
    # the extremes alone decide both checks (NaN and infinities reach them), in two passes
    # without temporaries: a block of features can be hundreds of MB
    low, high = float(np.min(found)), float(np.max(found))
    if not (math.isfinite(low) and math.isfinite(high)):
        raise PluginError(f"{who}: {what} returned non-finite features (NaN or infinity)")
    magnitude = max(abs(low), abs(high))
    if magnitude > FEATURE_BOUND:
        raise PluginError(
            f"{who}: {what} returned a feature of magnitude {magnitude:.3g}; "
            f"expected at most {FEATURE_BOUND:g}"
        )
    return found


class IsolatedMethod(_Isolated):
    """A feature method (the plug-in contract of :mod:`sfa_gym.plugins`) running in its own
    worker process: ``name``, ``capabilities``, ``fit``, ``transform``, after fitting
    ``input_shape_``, and ``get_params`` (the method's own, values that are not JSON types as
    their ``repr``).

    Args:
        source: a built-in name or a plug-in file (:func:`~sfa_gym.plugins.resolve_plugin`).
        args: keyword arguments of the plug-in's ``Args`` (JSON types), checked in the worker.
        limits: the time and memory limits (default :class:`Limits`).
        hidden: folders the worker must not read (the render cache, the results).
    """

    kind = "method"

    def __init__(
        self,
        source: str | os.PathLike[str],
        args: Mapping[str, Any] | None = None,
        limits: Limits | None = None,
        hidden: Sequence[str | os.PathLike[str]] = (),
    ) -> None:
        super().__init__(source, args, limits, hidden)

    def fit(self, views: ArrayLike, sequence_ids: ArrayLike | None = None) -> IsolatedMethod:
        # called as the caller called it: a method may take no sequence_ids at all
        given = [np.asarray(views)] + ([] if sequence_ids is None else [np.asarray(sequence_ids)])
        found = self._call("fit", self.limits.fit, *given)
        shape = found.get("input_shape_") if isinstance(found, dict) else None
        if shape is not None:
            self.input_shape_ = tuple(int(n) for n in shape)
        self._params = dict(found.get("params") or self._params)
        return self

    def transform(self, views: ArrayLike) -> NDArray[Any]:
        views = np.asarray(views)
        found = self._call("transform", self.limits.transform, views)
        return checked_features(found, (len(views),), self.name, "transform(views)")

    def get_params(self, deep: bool = True) -> dict[str, Any]:
        return dict(self._params)


class IsolatedController(_Isolated):
    """A navigation controller plug-in running in its own worker process: ``reset(obs, info)``
    and ``act(obs, info)`` send the observation (features; with the capability ``panoramas``
    also the current and the goal panorama, as arrays) and only the rover's own sensors of
    ``info``; ``capabilities`` is what the plug-in declared.

    Args:
        source: a built-in name or a controller plug-in file.
        rover: the :class:`~sfa_gym.navigation.sensors.Rover` it drives.
        weights: the cost weights of the features ``(k,)``.
        args, limits, hidden: as for :class:`IsolatedMethod`.
    """

    kind = "controller"

    def __init__(
        self,
        source: str | os.PathLike[str],
        rover: Any,
        weights: ArrayLike,
        args: Mapping[str, Any] | None = None,
        limits: Limits | None = None,
        hidden: Sequence[str | os.PathLike[str]] = (),
    ) -> None:
        rover_fields = dataclasses.asdict(rover)
        weights = np.asarray(weights, dtype=np.float64)
        super().__init__(source, args, limits, hidden, rover=rover_fields, weights=weights)

    @staticmethod
    def _seen(obs: Mapping[str, Any], info: Mapping[str, Any]) -> list[Any]:
        from sfa_gym.navigation.sensors import SensorsOnly

        return [dict(obs), SensorsOnly.sensors(info)]

    def reset(self, obs: Mapping[str, Any], info: Mapping[str, Any]) -> None:
        self._call("reset", self.limits.reset, *self._seen(obs, info))

    def act(self, obs: Mapping[str, Any], info: Mapping[str, Any]) -> NDArray[Any]:
        found = self._call("act", self.limits.act, *self._seen(obs, info))
        return _numbers(found, self.name, "act(obs, info)")


class InProcess:
    """A plug-in of the package's own (or any, under :data:`~sfa_gym.sandbox.IN_PROCESS`) in
    the evaluator's process, looking like a worker's proxy: each call runs with one BLAS and
    OpenMP thread, as a worker computes (its environment sets them so), so that a score does
    not depend on where the method ran; ``close`` does nothing and ``peak_rss_mb`` is None
    (the evaluator's own peak includes it)."""

    peak_rss_mb = None

    def __init__(self, made: Any) -> None:
        self.made = made
        # the thread pools loaded now, the plug-in's own included (a scan per call costs ms)
        self._pools = ThreadpoolController()

    def __getattr__(self, name: str) -> Any:
        found = getattr(self.made, name)
        if not callable(found):
            return found

        @functools.wraps(found)
        def call(*args: Any, **kwargs: Any) -> Any:
            with self._pools.limit(limits=1):
                out = found(*args, **kwargs)
            return self if out is self.made else out

        return call

    def close(self) -> None:
        """Nothing to stop."""

    def __enter__(self) -> InProcess:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def __repr__(self) -> str:
        return f"InProcess({self.made!r})"
