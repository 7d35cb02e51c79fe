"""Recorded runs: panoramas and ground-truth poses along a trajectory, stored in chunks.

A *run* is ``N`` samples of

- ``panoramas``: ``(N, H, W, 3)`` uint8 RGB, the env's observations;
- ``poses``: ``(N, 3)`` float64 ``(x, y, yaw)`` in metres and radians (from ``info``);
- ``time``: ``(N,)`` float64 seconds since the reset (``info["t"]`` if the env reports it,
  else the step count times the control period); for a run over a pose list, where no time
  passes, the sample index;
- ``actions``: ``(N, 2)`` float32 ``(v, w)`` in m/s and rad/s: ``actions[i]`` is the command
  whose step produced sample ``i``; ``actions[0]`` (the reset) and all actions of a pose-list
  run are zero.

On-disk format (version 1)
--------------------------
A run is a directory ``<name>.run/`` holding

- ``run.json``, the header, a JSON object::

    {"format": "sfa-gym-run", "version": 1,
     "kind": "trajectory" | "poses",
     "env_id": ..., "env_kwargs": {...}, "world": ..., "world_seed": ..., "panorama": {...},
     "arena_bounds": [xmin, xmax, ymin, ymax], "dt": seconds per step,
     "seed": ..., "driver": {"type": ..., ...its arguments}, "n_steps": requested N or null,
     "shape": [H, W, 3], "sfa_gym_version": ..., "created": ISO time,
     "chunks": [{"file": "chunk-00000.npz", "n": 500}, ...],
     "n": total samples in the chunks, "complete": false | true,
     "end_reason": null | "n_steps" | "driver_done" | "terminated" | "truncated"}

- ``chunk-00000.npz``, ``chunk-00001.npz``, ...: consecutive samples in chunk order, each an
  ``np.savez`` archive (uncompressed by default; ``np.savez_compressed`` also reads) of exactly
  the four arrays ``panoramas``, ``poses``, ``time``, ``actions``, with ``n`` rows each and the
  dtypes above; no pickled objects (read with ``allow_pickle=False``).

Every file is written atomically (a temporary file in the same directory, fsync, ``os.replace``)
and the header is rewritten after each chunk, so an interrupted recording leaves a valid,
``"complete": false`` run of whole chunks. :func:`record` resumes it: it resets the env with the
same seed, replays the stored actions (checking that driver and physics reproduce the stored
actions and poses) and continues. Files other than the header and listed chunks are ignored.

:func:`load_run` reads a run; the panoramas of uncompressed chunks are memory-mapped, so a
5900-sample 600x60 run (640 MB) opens instantly and is read from disk as it is indexed.
"""

from __future__ import annotations

import contextlib
import dataclasses
import datetime
import json
import math
import os
import struct
import tempfile
import zipfile
from collections.abc import Callable, Iterator, Mapping
from pathlib import Path
from typing import IO, Any

import gymnasium as gym
import numpy as np
from numpy.typing import NDArray
from tqdm.auto import tqdm

import sfa_gym
from sfa_gym.drivers import Driver, GridPositions

__all__ = [
    "FORMAT",
    "VERSION",
    "Run",
    "RunFormatError",
    "RunMismatchError",
    "ReplayMismatchError",
    "ChunkedPanoramas",
    "record",
    "load_run",
]

FORMAT = "sfa-gym-run"
VERSION = 1
HEADER = "run.json"
SUFFIX = ".run"

# the arrays of a chunk: dtype and shape after the leading sample axis ("obs" = (H, W, 3))
_ARRAYS: dict[str, tuple[np.dtype, str | tuple[int, ...]]] = {
    "panoramas": (np.dtype(np.uint8), "obs"),
    "poses": (np.dtype(np.float64), (3,)),
    "time": (np.dtype(np.float64), ()),
    "actions": (np.dtype(np.float32), (2,)),
}
# header keys that describe the recording itself; everything else must match to resume
_BOOKKEEPING = {"sfa_gym_version", "created", "chunks", "n", "complete", "end_reason"}


class RunFormatError(ValueError):
    """A file is not a sfa-gym run, or is damaged; the message names the file."""


class RunMismatchError(ValueError):
    """An existing run was recorded with other settings than the ones asked for."""


class ReplayMismatchError(RuntimeError):
    """Replaying a stored run did not reproduce its actions or poses (non-determinism)."""


# ------------------------------------------------------------------------ chunk files


def _fsync_dir(directory: Path) -> None:
    # makes the rename durable; not possible on every platform
    with contextlib.suppress(OSError):
        fd = os.open(directory, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)


def _write_atomic(path: Path, write: Callable[[IO[bytes]], None]) -> None:
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as file:
            write(file)
            file.flush()
            os.fsync(file.fileno())
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        raise
    _fsync_dir(path.parent)


def _write_header(directory: Path, header: Mapping[str, Any]) -> None:
    text = json.dumps(header, indent=1).encode()
    _write_atomic(directory / HEADER, lambda file: file.write(text))


def _write_chunk(path: Path, arrays: Mapping[str, NDArray[Any]], compress: bool) -> None:
    save = np.savez_compressed if compress else np.savez
    _write_atomic(path, lambda file: save(file, **arrays))


def _member_header(zf: zipfile.ZipFile, member: str) -> tuple[tuple[int, ...], np.dtype, int]:
    """Shape, dtype and data offset (inside the member) of one ``.npy`` member."""
    with zf.open(member) as stream:
        version = np.lib.format.read_magic(stream)
        read = {
            (1, 0): np.lib.format.read_array_header_1_0,
            (2, 0): np.lib.format.read_array_header_2_0,
        }.get(version)
        if read is None:
            raise ValueError(f"unsupported .npy version {version}")
        shape, fortran, dtype = read(stream)
        if fortran and len(shape) > 1:
            raise ValueError("Fortran-ordered array")
        return shape, dtype, stream.tell()


def _memmap_member(path: Path, zf: zipfile.ZipFile, member: str) -> np.memmap | None:
    """Memory-map an uncompressed ``.npy`` member of an ``.npz``; ``None`` if compressed."""
    info = zf.getinfo(member)
    if info.compress_type != zipfile.ZIP_STORED:
        return None
    shape, dtype, data_start = _member_header(zf, member)
    with open(path, "rb") as file:
        file.seek(info.header_offset)
        local = file.read(30)
    if len(local) < 30 or local[:4] != b"PK\x03\x04":
        raise ValueError(f"bad zip entry for {member}")
    name_len, extra_len = struct.unpack("<HH", local[26:30])
    offset = info.header_offset + 30 + name_len + extra_len + data_start
    nbytes = math.prod(shape) * dtype.itemsize
    if offset + nbytes > path.stat().st_size or data_start + nbytes != info.file_size:
        raise ValueError(f"{member} is shorter than its header says (truncated)")
    return np.memmap(path, dtype=dtype, mode="r", offset=offset, shape=shape)


def _read_chunk(path: Path, n: int, obs_shape: tuple[int, ...]) -> dict[str, Any]:
    """The small arrays of a chunk and its panoramas (memory-mapped, or ``None``: lazy)."""
    if not path.is_file():
        raise RunFormatError(f"chunk {path} is missing")
    try:
        with zipfile.ZipFile(path) as zf:
            members = sorted(zf.namelist())
            expected = sorted(f"{name}.npy" for name in _ARRAYS)
            if members != expected:
                raise RunFormatError(
                    f"{path} is not a sfa-gym run chunk: it holds {members}, expected {expected}"
                )
            out: dict[str, Any] = {}
            for name, (dtype, tail) in _ARRAYS.items():
                shape, got_dtype, _ = _member_header(zf, f"{name}.npy")
                want = (n, *(obs_shape if tail == "obs" else tail))
                if shape != want or got_dtype != dtype:
                    raise RunFormatError(
                        f"{path}: array {name!r} has shape {shape} and dtype {got_dtype}, "
                        f"expected {want} and {dtype}"
                    )
                if name == "panoramas":
                    out[name] = _memmap_member(path, zf, f"{name}.npy")
                else:
                    with zf.open(f"{name}.npy") as stream:
                        out[name] = np.lib.format.read_array(stream, allow_pickle=False)
            return out
    except RunFormatError:
        raise
    except (zipfile.BadZipFile, ValueError, OSError, EOFError) as error:
        raise RunFormatError(f"chunk {path} is damaged or truncated: {error}") from None


def _load_panoramas(path: Path) -> NDArray[np.uint8]:
    try:
        with np.load(path, allow_pickle=False) as npz:
            return npz["panoramas"]
    except (zipfile.BadZipFile, ValueError, OSError, EOFError) as error:
        raise RunFormatError(f"chunk {path} is damaged or truncated: {error}") from None


# ------------------------------------------------------------------------------ runs


class ChunkedPanoramas:
    """Read-only ``(N, H, W, 3)`` uint8 array view over the chunks of a run.

    Indexing with an int, a slice, an integer or boolean array returns a numpy array and reads
    only the chunks involved (memory-mapped where uncompressed; a compressed chunk is decoded
    once and cached until another one is needed). ``np.asarray(panoramas)`` loads everything.
    """

    def __init__(
        self,
        files: list[Path],
        counts: list[int],
        obs_shape: tuple[int, ...],
        maps: list[np.memmap | None],
    ) -> None:
        self._files = files
        self._maps = maps
        self._starts = np.concatenate([[0], np.cumsum(counts, dtype=np.int64)])
        self.shape = (int(self._starts[-1]), *obs_shape)
        self.dtype = np.dtype(np.uint8)
        self._cached: tuple[int, NDArray[np.uint8]] | None = None

    ndim = property(lambda self: len(self.shape))
    nbytes = property(lambda self: math.prod(self.shape))

    def __len__(self) -> int:
        return self.shape[0]

    def __repr__(self) -> str:
        return f"ChunkedPanoramas(shape={self.shape}, chunks={len(self._files)})"

    def chunk(self, c: int) -> NDArray[np.uint8]:
        """The panoramas of chunk ``c``, ``(n_c, H, W, 3)`` (memory-mapped or decoded)."""
        if self._maps[c] is not None:
            return self._maps[c]
        if self._cached is None or self._cached[0] != c:
            self._cached = (c, _load_panoramas(self._files[c]))
        return self._cached[1]

    def iter_chunks(self) -> Iterator[tuple[int, NDArray[np.uint8]]]:
        """Yield ``(start, panoramas of the chunk)`` in order."""
        for c in range(len(self._files)):
            yield int(self._starts[c]), self.chunk(c)

    def _take(self, indices: NDArray[np.intp]) -> NDArray[np.uint8]:
        out = np.empty((len(indices), *self.shape[1:]), dtype=self.dtype)
        owner = np.searchsorted(self._starts, indices, side="right") - 1
        for c in np.unique(owner):
            where = owner == c
            out[where] = self.chunk(int(c))[indices[where] - self._starts[c]]
        return out

    def __getitem__(self, key: Any) -> NDArray[np.uint8]:
        rest: tuple[Any, ...] = ()
        if isinstance(key, tuple):
            key, rest = (key[0], key[1:]) if key else (slice(None), ())
        n = len(self)
        if isinstance(key, int | np.integer):
            if not -n <= key < n:
                raise IndexError(f"index {key} is out of bounds for {n} panoramas")
            return self._take(np.array([key % n]))[0][rest]
        indices = np.arange(n)[key if isinstance(key, slice) else np.asarray(key)]
        out = self._take(indices.reshape(-1)).reshape(*indices.shape, *self.shape[1:])
        return out[(slice(None),) * indices.ndim + rest]

    def __iter__(self) -> Iterator[NDArray[np.uint8]]:
        for _, chunk in self.iter_chunks():
            yield from chunk

    def __array__(self, dtype: Any = None, copy: bool | None = None) -> NDArray[Any]:
        if not self._files:
            out = np.empty(self.shape, dtype=self.dtype)
        else:
            out = np.concatenate([np.asarray(chunk) for _, chunk in self.iter_chunks()])
        return out if dtype is None else out.astype(dtype, copy=False)


@dataclasses.dataclass(frozen=True)
class Run:
    """A recorded run (see the module docstring for the arrays and the format).

    Attributes:
        path: the ``<name>.run`` directory.
        panoramas: ``(N, H, W, 3)`` uint8, read lazily from the chunks.
        poses: ``(N, 3)`` float64 ``(x, y, yaw)``, metres and radians.
        time: ``(N,)`` float64 seconds since the reset (sample index for pose-list runs).
        actions: ``(N, 2)`` float32 ``(v, w)``, m/s and rad/s; ``actions[i]`` produced sample i.
        metadata: the header without the chunk list.
        complete: whether the recording finished (an incomplete run can be resumed).
    """

    path: Path
    panoramas: ChunkedPanoramas
    poses: NDArray[np.float64]
    time: NDArray[np.float64]
    actions: NDArray[np.float32]
    metadata: dict[str, Any]
    complete: bool

    def __len__(self) -> int:
        return len(self.poses)

    @property
    def positions(self) -> NDArray[np.float64]:
        """``(N, 2)`` float64 ``(x, y)`` in metres."""
        return self.poses[:, :2]


def _read_header(directory: Path) -> dict[str, Any]:
    path = directory / HEADER
    if not directory.is_dir():
        raise FileNotFoundError(f"run directory {directory} does not exist")
    if not path.is_file():
        raise RunFormatError(f"{directory} is not a sfa-gym run: {HEADER} is missing")
    try:
        header = json.loads(path.read_text())
    except (UnicodeDecodeError, json.JSONDecodeError) as error:
        raise RunFormatError(f"{path} is not valid JSON: {error}") from None
    if not isinstance(header, dict) or header.get("format") != FORMAT:
        found = header.get("format") if isinstance(header, dict) else type(header).__name__
        raise RunFormatError(f"{path} is not a {FORMAT!r} header (its format is {found!r})")
    version = header.get("version")
    if version != VERSION:
        raise RunFormatError(
            f"{path} has format version {version!r}; this sfa_gym ({sfa_gym.__version__}) "
            f"reads version {VERSION}"
        )
    chunks = header.get("chunks")
    shape = header.get("shape")
    if (
        not isinstance(chunks, list)
        or not all(isinstance(c, dict) and {"file", "n"} <= c.keys() for c in chunks)
        or not isinstance(shape, list)
        or not isinstance(header.get("complete"), bool)
    ):
        raise RunFormatError(
            f"{path} lacks a valid 'chunks' list of {{'file', 'n'}}, 'shape' or 'complete'"
        )
    for c in chunks:
        name = c["file"]
        if not isinstance(name, str) or Path(name).name != name or not isinstance(c["n"], int):
            raise RunFormatError(f"{path}: bad chunk entry {c!r}")
    return header


def load_run(path: str | os.PathLike[str]) -> Run:
    """Open a run directory written by :func:`record`.

    Checks the header (format name, version), that every listed chunk exists and holds exactly
    the expected arrays with the right shapes and dtypes; panoramas of uncompressed chunks are
    memory-mapped, compressed ones are decoded on access.

    Raises:
        FileNotFoundError: ``path`` does not exist.
        RunFormatError: a file is missing, foreign, damaged or truncated; the message names it.
    """
    directory = Path(path)
    header = _read_header(directory)
    obs_shape = tuple(int(s) for s in header["shape"])
    files, counts, maps, parts = [], [], [], []
    for c in header["chunks"]:
        file = directory / c["file"]
        chunk = _read_chunk(file, int(c["n"]), obs_shape)
        files.append(file)
        counts.append(int(c["n"]))
        maps.append(chunk["panoramas"])
        parts.append(chunk)
    if sum(counts) != header.get("n", sum(counts)):
        raise RunFormatError(
            f"{directory / HEADER}: 'n' is {header['n']} but the chunks hold {sum(counts)}"
        )

    def stacked(name: str) -> NDArray[Any]:
        dtype, tail = _ARRAYS[name]
        if not parts:
            return np.empty((0, *tail), dtype=dtype)
        return np.concatenate([p[name] for p in parts])

    metadata = {k: v for k, v in header.items() if k != "chunks"}
    return Run(
        path=directory,
        panoramas=ChunkedPanoramas(files, counts, obs_shape, maps),
        poses=stacked("poses"),
        time=stacked("time"),
        actions=stacked("actions"),
        metadata=metadata,
        complete=header["complete"],
    )


# ------------------------------------------------------------------------- recording


def _jsonable(value: Any) -> Any:
    """A JSON-compatible copy (dataclasses as dicts, tuples as lists, others by repr)."""
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {"type": type(value).__name__, **_jsonable(dataclasses.asdict(value))}
    if isinstance(value, Mapping):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, os.PathLike):
        return os.fspath(value)
    if value is None or isinstance(value, bool | int | float | str):
        return value
    return repr(value)


def _env_metadata(env: gym.Env) -> dict[str, Any]:
    unwrapped = env.unwrapped
    spec = env.spec
    bounds = getattr(unwrapped, "arena_bounds", None)
    dt = _control_period(unwrapped)
    world = getattr(unwrapped, "world", None)
    return _jsonable(
        {
            "env_id": spec.id if spec is not None else type(unwrapped).__name__,
            "env_kwargs": dict(spec.kwargs) if spec is not None else {},
            "world": getattr(world, "name", world),
            "world_seed": getattr(unwrapped, "world_seed", None),
            "panorama": getattr(unwrapped, "panorama", None),
            "arena_bounds": None if bounds is None else [float(b) for b in bounds],
            "dt": None if dt is None else float(dt),
            "shape": list(env.observation_space.shape),
        }
    )


def _control_period(unwrapped: gym.Env) -> float | None:
    """Seconds per env step: ``control_dt`` (sfa_gym envs) or ``dt`` (Gymnasium MuJoCo envs)."""
    for name in ("control_dt", "dt"):
        value = getattr(unwrapped, name, None)
        if isinstance(value, int | float) and value > 0:
            return float(value)
    return None


def _pose_of(info: Mapping[str, Any]) -> NDArray[np.float64]:
    try:
        return np.array([info["x"], info["y"], info["yaw"]], dtype=np.float64)
    except KeyError as error:
        raise KeyError(f"recording needs info with 'x', 'y', 'yaw'; {error} is missing") from None


def _pose_seed(seed: int, index: int) -> int:
    # every pose of a pose-list run gets its own reset seed, so that a resumed run is identical
    return int(np.random.SeedSequence([seed, index]).generate_state(1)[0])


class _Writer:
    """Buffers samples and writes them as chunks, rewriting the header after each."""

    def __init__(
        self,
        directory: Path,
        header: dict[str, Any],
        chunk_size: int,
        compress: bool,
        on_chunk: Callable[[int], None] | None,
    ) -> None:
        self.directory = directory
        self.header = header
        self.chunk_size = chunk_size
        self.compress = compress
        self.on_chunk = on_chunk
        self.buffer: dict[str, list[Any]] = {name: [] for name in _ARRAYS}

    def add(self, obs: Any, pose: NDArray[np.float64], time: float, action: Any) -> None:
        self.buffer["panoramas"].append(np.asarray(obs, dtype=np.uint8))
        self.buffer["poses"].append(pose)
        self.buffer["time"].append(time)
        self.buffer["actions"].append(np.asarray(action, dtype=np.float32))
        if len(self.buffer["poses"]) >= self.chunk_size:
            self.flush()

    def flush(self) -> None:
        n = len(self.buffer["poses"])
        if n == 0:
            return
        arrays = {name: np.asarray(self.buffer[name], dtype=_ARRAYS[name][0]) for name in _ARRAYS}
        name = f"chunk-{len(self.header['chunks']):05d}.npz"
        _write_chunk(self.directory / name, arrays, self.compress)
        self.header["chunks"].append({"file": name, "n": n})
        self.header["n"] += n
        _write_header(self.directory, self.header)
        self.buffer = {name: [] for name in _ARRAYS}
        if self.on_chunk is not None:
            self.on_chunk(self.header["n"])

    def finish(self, end_reason: str) -> None:
        self.flush()
        self.header["complete"] = True
        self.header["end_reason"] = end_reason
        _write_header(self.directory, self.header)


def _check_resumable(directory: Path, wanted: dict[str, Any]) -> dict[str, Any]:
    header = _read_header(directory)
    differences = [
        f"{key}: stored {header.get(key)!r}, requested {wanted.get(key)!r}"
        for key in sorted((header.keys() | wanted.keys()) - _BOOKKEEPING)
        if header.get(key) != wanted.get(key)
    ]
    if differences:
        raise RunMismatchError(
            f"{directory} holds a run recorded with other settings ("
            + "; ".join(differences)
            + "); record into another directory or pass overwrite=True"
        )
    return header


def _clear(directory: Path) -> None:
    """Remove the files of a run (header, chunks, temporaries), nothing else."""
    for file in directory.iterdir():
        name = file.name
        if name == HEADER or (name.startswith("chunk-") and name.endswith(".npz")):
            file.unlink()
    _remove_temporaries(directory)


def _remove_temporaries(directory: Path) -> None:
    for file in directory.glob(".*.tmp"):
        if file.name.startswith((".chunk-", f".{HEADER}.")):
            file.unlink()


def record(
    env: str | gym.Env,
    driver: Driver | GridPositions,
    out_dir: str | os.PathLike[str],
    *,
    n_steps: int | None = None,
    seed: int = 0,
    chunk_size: int = 500,
    compress: bool = False,
    env_kwargs: Mapping[str, Any] | None = None,
    overwrite: bool = False,
    progress: bool = True,
    on_chunk: Callable[[int], None] | None = None,
) -> Run:
    """Record a run of ``env`` driven by ``driver`` into the directory ``out_dir``.

    With a :class:`~sfa_gym.drivers.Driver`: ``env.reset(seed=seed, options={"pose":
    driver.start_pose})`` (no options if the start pose is ``None``), ``driver.reset(bounds,
    dt=..., seed=seed)``, then ``env.step(driver(info))`` until ``n_steps`` samples are stored,
    the driver is done or the episode ends. Actions are clipped to the action space.
    With :class:`~sfa_gym.drivers.GridPositions`: one ``env.reset`` per pose (the first
    ``n_steps`` poses, or all), each with its own seed derived from ``seed``.

    If ``out_dir`` already holds an incomplete run with the same settings, the recording
    resumes (see the module docstring); a complete one is returned as it is.

    Args:
        env: a registered env id (made with ``gym.make(env, **env_kwargs)`` and closed at the
            end) or an env; it must report ``x``, ``y``, ``yaw`` in ``info`` and have
            ``unwrapped.arena_bounds`` for drivers.
        driver: what to drive (or which poses to visit).
        out_dir: the run directory; its name must end with ``.run``.
        n_steps: number of samples to store (the reset counts as one); ``None``: until the
            driver is done (required for open-ended drivers) or all poses are visited.
        seed: seed of the env resets and of the driver.
        chunk_size: samples per chunk file.
        compress: write chunks with ``np.savez_compressed`` (smaller, slower, not mappable).
        env_kwargs: keyword arguments for ``gym.make`` when ``env`` is an id.
        overwrite: delete an existing run in ``out_dir`` instead of resuming it.
        progress: show a tqdm progress bar.
        on_chunk: called with the number of stored samples after each chunk is written.

    Returns:
        The recorded run, as :func:`load_run` returns it.

    Raises:
        RunMismatchError: ``out_dir`` holds a run recorded with other settings.
        ReplayMismatchError: resuming did not reproduce the stored actions or poses.
    """
    directory = Path(out_dir)
    if directory.suffix != SUFFIX:
        raise ValueError(
            f"out_dir must be a directory named '<name>{SUFFIX}', got {str(out_dir)!r}"
        )
    if not isinstance(chunk_size, int) or chunk_size < 1:
        raise ValueError(f"chunk_size must be a positive int, got {chunk_size!r}")
    if n_steps is not None and (not isinstance(n_steps, int) or n_steps < 1):
        raise ValueError(f"n_steps must be a positive int or None, got {n_steps!r}")
    if not isinstance(driver, Driver | GridPositions):
        raise TypeError(
            f"driver must be a sfa_gym.drivers.Driver or GridPositions, got {type(driver).__name__}"
        )
    if isinstance(driver, Driver) and n_steps is None and type(driver).done is Driver.done:
        raise ValueError(f"{type(driver).__name__} never finishes: give n_steps")

    owns_env = isinstance(env, str)
    if owns_env:
        # the run length is set here, not by the registered time limit
        limit = (n_steps or 0) + 10**9
        env = gym.make(env, max_episode_steps=limit, **dict(env_kwargs or {}))
    elif env_kwargs:
        raise ValueError("env_kwargs only apply when env is an id, not an env instance")
    try:
        wanted = {
            "format": FORMAT,
            "version": VERSION,
            "kind": "poses" if isinstance(driver, GridPositions) else "trajectory",
            **_env_metadata(env),
            "seed": seed,
            "driver": _jsonable(driver.describe()),
            "n_steps": n_steps,
        }
        if overwrite and directory.is_dir():
            _clear(directory)
        if (directory / HEADER).is_file():
            header = _check_resumable(directory, wanted)
            if header["complete"]:
                return load_run(directory)
            _remove_temporaries(directory)
            stored = load_run(directory)
        else:
            directory.mkdir(parents=True, exist_ok=True)
            header = {
                **wanted,
                "sfa_gym_version": sfa_gym.__version__,
                "created": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
                "chunks": [],
                "n": 0,
                "complete": False,
                "end_reason": None,
            }
            _write_header(directory, header)
            stored = None
        header["sfa_gym_version"] = sfa_gym.__version__
        writer = _Writer(directory, header, chunk_size, compress, on_chunk)
        try:
            if isinstance(driver, GridPositions):
                end = _record_poses(env, driver, writer, stored, n_steps, seed, progress)
            else:
                end = _record_drive(env, driver, writer, stored, n_steps, seed, progress)
        except BaseException:
            # the buffered samples are whole: keep them for a resume (if the disk lets us)
            with contextlib.suppress(Exception):
                writer.flush()
            raise
        writer.finish(end)
    finally:
        if owns_env:
            env.close()
    return load_run(directory)


def _bar(progress: bool, total: int | None, initial: int, desc: str) -> tqdm:
    return tqdm(total=total, initial=initial, disable=not progress, desc=desc, unit="frame")


def _record_poses(
    env: gym.Env,
    driver: GridPositions,
    writer: _Writer,
    stored: Run | None,
    n_steps: int | None,
    seed: int,
    progress: bool,
) -> str:
    poses = driver.poses(env)
    total = len(poses) if n_steps is None else min(n_steps, len(poses))
    start = 0 if stored is None else len(stored)
    with _bar(progress, total, start, writer.directory.name) as bar:
        for i in range(start, total):
            obs, info = env.reset(seed=_pose_seed(seed, i), options={"pose": tuple(poses[i])})
            writer.add(obs, _pose_of(info), float(i), np.zeros(2, dtype=np.float32))
            bar.update()
    return "n_steps" if total < len(poses) else "driver_done"


def _record_drive(
    env: gym.Env,
    driver: Driver,
    writer: _Writer,
    stored: Run | None,
    n_steps: int | None,
    seed: int,
    progress: bool,
) -> str:
    bounds = getattr(env.unwrapped, "arena_bounds", None)
    if bounds is None:
        raise ValueError(f"{env.unwrapped} has no arena_bounds to drive in")
    dt = _control_period(env.unwrapped)
    if dt is None:
        raise ValueError(f"{env.unwrapped} has no control period (control_dt or dt) in seconds")
    space = env.action_space
    low, high = space.low.astype(np.float32), space.high.astype(np.float32)
    driver.reset(bounds, dt=dt, seed=seed)
    options = None if driver.start_pose is None else {"pose": driver.start_pose}
    obs, info = env.reset(seed=seed, options=options)
    n_done = 0 if stored is None else len(stored)
    if n_done:
        info = _replay(env, driver, stored, info, low, high, progress)
    else:
        writer.add(obs, _pose_of(info), float(info.get("t", 0.0)), np.zeros(2, dtype=np.float32))
        n_done = 1
    end = "n_steps"
    with _bar(progress, n_steps, n_done, writer.directory.name) as bar:
        bar.update(0)
        while n_steps is None or n_done < n_steps:
            if driver.done:
                end = "driver_done"
                break
            action = np.clip(driver(info), low, high)
            obs, _, terminated, truncated, info = env.step(action)
            writer.add(obs, _pose_of(info), float(info.get("t", n_done * dt)), action)
            n_done += 1
            bar.update()
            if terminated or truncated:
                end = "terminated" if terminated else "truncated"
                break
    return end


def _replay(
    env: gym.Env,
    driver: Driver,
    stored: Run,
    info: dict[str, Any],
    low: NDArray[np.float32],
    high: NDArray[np.float32],
    progress: bool,
) -> dict[str, Any]:
    """Drive the stored steps again (not storing them) to restore env and driver state.

    Returns the ``info`` of the last stored sample.

    Raises:
        ReplayMismatchError: the driver chose another action or the env reached another pose.
    """
    advice = "the run cannot be resumed; record into a new directory or pass overwrite=True"

    def check_pose(i: int, info: Mapping[str, Any]) -> None:
        pose = _pose_of(info)
        error = np.abs(pose - stored.poses[i])
        error[2] = abs((pose[2] - stored.poses[i, 2] + np.pi) % (2 * np.pi) - np.pi)
        if error.max() > 1e-6:
            raise ReplayMismatchError(
                f"{stored.path}: replaying sample {i} reached pose {pose.tolist()}, stored "
                f"{stored.poses[i].tolist()}: the env is not deterministic; {advice}"
            )

    check_pose(0, info)
    with _bar(progress, len(stored) - 1, 0, f"replaying {stored.path.name}") as bar:
        for i in range(1, len(stored)):
            action = np.clip(driver(info), low, high)
            if not np.array_equal(action, stored.actions[i]):
                raise ReplayMismatchError(
                    f"{stored.path}: at sample {i} {type(driver).__name__} chose "
                    f"{action.tolist()}, stored {stored.actions[i].tolist()}: the driver is not "
                    f"deterministic; {advice}"
                )
            _, _, _, _, info = env.step(action)
            check_pose(i, info)
            bar.update()
    return info
