"""The shared render cache: a rendered run is keyed by what determines its pixels, rendered once
and reused by every method, every track and every process.

The key of a :class:`RunRequest` is the SHA-256 of a JSON object holding the content of the
world spec (not only its name: an edited spec is another world), the world seed, the panorama
spec, the env id, the driver with its arguments, the number of frames, the reset seed,
:data:`RENDERING_VERSION`, the MuJoCo version and, when the request passes other env kwargs
(camera, mirror, rover, dynamics spec, start hour, sensor, control period, ...), every one of
them whose value differs from the env id's default (its registered kwargs over its
constructor's defaults). Leaving a kwarg out and passing its default are the same run. The
defaults themselves (and named presets such as ``rover="outdoor"``) are code, like the
renderer: a change of the code that changes a run's pixels or poses (the simulation, the
camera, the drivers, the recorder, a default) bumps :data:`RENDERING_VERSION`, and a test fails
when a fixed scene's pixels change while the version stays. The run lives in
``<cache>/<key>.run`` (the run file format of :mod:`sfa_gym.recording.runfile`) beside
``<key>.json``, the key's readable content.

Concurrency: a process that finds no complete entry takes an exclusive ``fcntl.flock`` on
``<key>.lock``, looks again (another process may have rendered it meanwhile) and renders it, so
that the workers of a sweep that ask for the same run at once render it once. The run format
writes its header last, so a reader sees the samples written and whether the run is complete;
a render that was killed is resumed, an entry that fails the run format's checks (a missing or
truncated file) is rendered again. Each render appends one line to ``<cache>/renders.log``
(key, pid, seconds).
"""

from __future__ import annotations

import contextlib
import dataclasses
import fcntl
import hashlib
import importlib.metadata
import inspect
import json
import math
import os
import time
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import platformdirs

__all__ = [
    "RENDERING_VERSION",
    "RunCache",
    "RunFolder",
    "RunRequest",
    "changed_env_kwargs",
    "default_cache_dir",
    "env_defaults",
]

RENDERING_VERSION = 3
"""Bumped by every change of the code that changes a run's pixels or poses (the package
version is not part of the key: most releases do not change a pixel). 3: the cache key no
longer hashes the sources of ``sfa_gym.sim`` and ``sfa_gym.recording``."""

ENV_VARIABLE = "SFA_GYM_CACHE"


def default_cache_dir() -> Path:
    """``$SFA_GYM_CACHE`` if set, else ``runs`` in the user's cache folder for ``sfa-gym``:
    ``~/.cache/sfa-gym/runs`` on Linux (``$XDG_CACHE_HOME/sfa-gym/runs`` where that is set, e.g.
    on a cluster whose home quota is small), ``~/Library/Caches/sfa-gym/runs`` on macOS."""
    override = os.environ.get(ENV_VARIABLE)
    if override:
        return Path(override)
    return platformdirs.user_cache_path("sfa-gym", appauthor=False) / "runs"


# the request's own fields: env kwargs may not set them a second time
_REQUEST_KWARGS = ("world", "world_seed", "panorama")


def _canonical(name: str, value: Any) -> Any:
    """``value`` as JSON types that compare equal exactly when the values do: dataclasses as
    ``{"type": class name, **fields}``, tuples as lists, numpy scalars as Python numbers.

    Raises:
        TypeError: a value without a stable JSON form (its ``repr`` could hold an address);
            the message names the kwarg ``name``.
    """
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        fields = {f.name: getattr(value, f.name) for f in dataclasses.fields(value)}
        return {"type": type(value).__name__, **_canonical(name, fields)}
    if isinstance(value, Mapping):
        return {str(k): _canonical(f"{name}.{k}", v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_canonical(f"{name}[{i}]", v) for i, v in enumerate(value)]
    if hasattr(value, "item") and callable(value.item) and getattr(value, "ndim", None) == 0:
        value = value.item()  # numpy scalars
    if isinstance(value, float) and not math.isfinite(value):
        raise TypeError(f"env kwarg {name} = {value!r}: a cache key needs a finite number")
    if value is None or isinstance(value, bool | int | float | str):
        return value
    raise TypeError(
        f"env kwarg {name} = {value!r} ({type(value).__name__}) has no stable JSON form for "
        "the cache key; pass numbers, strings, bools, None, lists, dicts or dataclasses"
    )


def env_defaults(env_id: str) -> dict[str, Any]:
    """The kwargs ``gym.make(env_id)`` uses when given none: the registered ones over the
    defaults of the entry point's signature (a kwarg without a default is absent).

    Raises:
        ValueError: ``env_id`` is not registered.
    """
    import gymnasium as gym
    from gymnasium.envs.registration import load_env_creator

    import sfa_gym  # noqa: F401  (registers the sfa_gym ids)

    try:
        spec = gym.spec(env_id)
    except gym.error.Error as error:
        raise ValueError(f"env_id {env_id!r} is not a registered env: {error}") from None
    creator = spec.entry_point if callable(spec.entry_point) else load_env_creator(spec.entry_point)
    defaults = {
        name: p.default
        for name, p in inspect.signature(creator).parameters.items()
        if p.default is not inspect.Parameter.empty
        and p.kind in (p.POSITIONAL_OR_KEYWORD, p.KEYWORD_ONLY)
    }
    return {**defaults, **spec.kwargs}


def changed_env_kwargs(env_id: str, env_kwargs: Mapping[str, Any]) -> dict[str, Any]:
    """``env_kwargs`` without those equal to the env id's defaults (:func:`env_defaults`), in
    canonical JSON form (see :func:`_canonical`), sorted by name: what enters the cache key.

    Raises:
        ValueError: a kwarg the env does not take, or one of the request's own fields
            (``world``, ``world_seed``, ``panorama``).
        TypeError: a value without a stable JSON form.
    """
    defaults = env_defaults(env_id)
    changed = {}
    for name in sorted(env_kwargs):
        if name in _REQUEST_KWARGS:
            raise ValueError(
                f"env kwarg {name!r} is a field of the RunRequest itself; set it there"
            )
        if name not in defaults:
            raise ValueError(
                f"env kwarg {name!r} is not a keyword argument of {env_id} with a default; "
                f"it takes {sorted(defaults)}"
            )
        value = _canonical(name, env_kwargs[name])
        # compared as JSON text: Python's == would call True equal to 1
        if json.dumps(value, sort_keys=True) != json.dumps(
            _canonical(name, defaults[name]), sort_keys=True
        ):
            changed[name] = value
    return changed


@dataclass(frozen=True)
class RunRequest:
    """A run to render: ``record(env_id, driver, n_steps=n_steps, seed=seed)`` in ``world``
    with ``world_seed`` and panoramas ``panorama = (height, width)`` pixels.

    Attributes:
        world: a world spec name, or None: the env id's own world.
        panorama: ``(height, width)`` pixels, or None: the env id's own camera.
        driver: a :class:`~sfa_gym.recording.drivers.GridPositions` or a driver instance; its
            ``describe()`` enters the key.
        env_kwargs: further keyword arguments of ``gym.make(env_id)`` (not ``world``,
            ``world_seed`` or ``panorama``: fields of the request); those that differ from the
            env id's defaults enter the key (see the module docstring).
    """

    world: str | None
    world_seed: int
    panorama: tuple[int, int] | None
    driver: Any
    n_steps: int | None = None
    seed: int = 0
    env_id: str = "sfa_gym/OmniRover-v0"
    env_kwargs: Mapping[str, Any] = field(default_factory=dict)

    def panorama_spec(self) -> Any:
        """The env's :class:`~sfa_gym.sim.camera.PanoramaSpec` (other fields at defaults), or
        None (the env's own camera)."""
        from sfa_gym.sim.camera import PanoramaSpec

        if self.panorama is None:
            return None
        height, width = self.panorama
        return PanoramaSpec(width=int(width), height=int(height))

    def record_kwargs(self) -> dict[str, Any]:
        """The ``env_kwargs`` of the recorder: the request's own, its world and world seed and
        its panorama spec (world and panorama only when given: else the env id's own)."""
        kwargs: dict[str, Any] = dict(self.env_kwargs)
        if self.world is not None:
            kwargs["world"] = self.world
        kwargs["world_seed"] = self.world_seed
        if self.panorama is not None:
            kwargs["panorama"] = self.panorama_spec()
        return kwargs

    def key_content(self) -> dict[str, Any]:
        """Everything that determines the pixels, as JSON types."""
        from sfa_gym.sim.worlds.spec import load_world_spec

        # the env id's own world is a world spec too: its content enters the key
        world = self.world if self.world is not None else env_defaults(self.env_id)["world"]
        spec = dataclasses.asdict(load_world_spec(world))
        spec_text = json.dumps(spec, sort_keys=True, default=list)
        panorama = self.panorama_spec()
        content = {
            "rendering_version": RENDERING_VERSION,
            # from the distribution's metadata: importing mujoco here, before the GL backend
            # is chosen (sim.gl.configure), would fix MuJoCo on GLFW for the whole process
            "mujoco": importlib.metadata.version("mujoco"),
            "env_id": self.env_id,
            "world": world,
            "world_spec_sha256": hashlib.sha256(spec_text.encode()).hexdigest(),
            "world_seed": int(self.world_seed),
            # None: the env's own camera, whose defaults are code (in RENDERING_VERSION)
            "panorama": None if panorama is None else dataclasses.asdict(panorama),
            "driver": json.loads(json.dumps(self.driver.describe(), default=list)),
            "n_steps": self.n_steps,
            "seed": int(self.seed),
        }
        changed = changed_env_kwargs(self.env_id, self.env_kwargs) if self.env_kwargs else {}
        if changed:
            # only when there are any: leaving a kwarg out and passing its default are one run
            content["env_kwargs"] = changed
        return content

    def key(self) -> str:
        """The cache key: SHA-256 (hex) of :meth:`key_content` as canonical JSON."""
        text = json.dumps(self.key_content(), sort_keys=True, separators=(",", ":"))
        return hashlib.sha256(text.encode()).hexdigest()


@contextlib.contextmanager
def _locked(path: Path) -> Iterator[None]:
    """Hold an exclusive ``flock`` on ``path`` (created if missing) inside the block.

    By hand rather than with filelock: ``flock`` on a fresh open file excludes other processes
    and other threads alike, the kernel drops it when a render is killed, and the lock file is
    never deleted (deleting it would let two processes lock two different files). filelock
    gives the same on Linux through many more layers (reentrant, per-thread and singleton
    locks, leases, whose defaults have changed between its major versions) and is no
    dependency of sfa-gym's core; its one gain, Windows, is no platform the renderer is set up
    for (EGL or OSMesa, :mod:`sfa_gym.sim.gl`).
    """
    with open(path, "a+b") as file:
        fcntl.flock(file.fileno(), fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(file.fileno(), fcntl.LOCK_UN)


class RunCache:
    """Rendered runs on disk, keyed by :meth:`RunRequest.key` (see the module docstring).

    Args:
        root: the cache folder (created on first use); default :func:`default_cache_dir`.
        progress: progress bars while rendering.
    """

    def __init__(self, root: str | os.PathLike[str] | None = None, progress: bool = False):
        self.root = default_cache_dir() if root is None else Path(root)
        self.progress = progress

    def path(self, request: RunRequest) -> Path:
        """Where the run of ``request`` is (or will be) stored."""
        return self.root / f"{request.key()}.run"

    def _complete(self, path: Path) -> Any | None:
        """The run at ``path`` if it is complete and passes the run format's checks."""
        from sfa_gym.recording.runfile import RunFormatError, load_run

        with contextlib.suppress(RunFormatError, OSError):
            run = load_run(path)
            return run if run.complete else None
        return None

    def get(self, request: RunRequest) -> Any:
        """The :class:`~sfa_gym.recording.runfile.Run` of ``request``, rendered if no complete
        entry exists (once, whichever number of processes ask at the same time)."""
        from sfa_gym.files import write_json_atomic
        from sfa_gym.recording.recorder import ReplayMismatchError, RunMismatchError
        from sfa_gym.recording.runfile import RunFormatError

        path = self.path(request)
        run = self._complete(path)
        if run is not None:
            return run
        self.root.mkdir(parents=True, exist_ok=True)
        with _locked(path.with_suffix(".lock")):
            run = self._complete(path)
            if run is not None:
                return run
            started = time.perf_counter()
            try:  # a killed render resumes
                run = _record(request, path, self.progress)
            except (RunFormatError, RunMismatchError, ReplayMismatchError):
                # damaged: nothing in it is kept
                run = _record(request, path, self.progress, overwrite=True)
            seconds = time.perf_counter() - started
        write_json_atomic(path.with_suffix(".json"), request.key_content())
        line = f"{path.stem} pid={os.getpid()} seconds={seconds:.2f}\n"
        # one write of a short line with O_APPEND: lines of concurrent processes do not mix
        fd = os.open(self.root / "renders.log", os.O_WRONLY | os.O_CREAT | os.O_APPEND, 0o644)
        try:
            os.write(fd, line.encode())
        finally:
            os.close(fd)
        return run

    def renders(self) -> list[str]:
        """The lines of ``renders.log``: one per render since the cache was created."""
        log = self.root / "renders.log"
        return log.read_text().splitlines() if log.is_file() else []


class RunFolder:
    """Runs recorded under given names in one folder (an experiment's output folder): a
    :class:`~sfa_gym.protocols.RunSource` whose runs are reused by the next call with the same
    settings, and resumed when a render was interrupted (see
    :func:`~sfa_gym.recording.recorder.record`).

    Args:
        folder: where the runs are kept (created on first use).
        names: the file name (without ``.run``) of each request this folder records; a request
            is recognised by its :meth:`RunRequest.key`.
        progress: progress bars while rendering.
    """

    def __init__(
        self,
        folder: str | os.PathLike[str],
        names: Mapping[str, RunRequest],
        progress: bool = False,
    ):
        self.folder = Path(folder)
        self._names = {request.key(): name for name, request in names.items()}
        self.progress = progress

    def get(self, request: RunRequest) -> Any:
        """The run of ``request`` in ``<folder>/<name>.run``, recorded (or resumed) if needed.

        Raises:
            KeyError: a request this folder was not given a name for.
        """
        name = self._names.get(request.key())
        if name is None:
            raise KeyError(
                f"{self.folder} keeps the runs {sorted(self._names.values())}; this request is "
                f"none of them: {request}"
            )
        return _record(request, self.folder / f"{name}.run", self.progress)


def _record(request: RunRequest, path: Path, progress: bool, overwrite: bool = False) -> Any:
    """:func:`~sfa_gym.recording.recorder.record` the run of ``request`` into ``path``."""
    from sfa_gym.recording.recorder import record

    return record(
        request.env_id,
        request.driver,
        path,
        n_steps=request.n_steps,
        seed=request.seed,
        env_kwargs=request.record_kwargs(),
        overwrite=overwrite,
        progress=progress,
    )
