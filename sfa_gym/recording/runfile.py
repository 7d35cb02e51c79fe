"""Recorded runs: panoramas and ground-truth poses along a trajectory, one ``.npy`` file each.

A *run* is ``N`` samples of

- ``panoramas``: ``(N, H, W, 3)`` uint8 RGB, the env's observations;
- ``poses``: ``(N, 3)`` float64 ``(x, y, yaw)`` in metres and radians (from ``info``);
- ``time``: ``(N,)`` float64 seconds since the reset (``info["t"]`` if the env reports it,
  else the step count times the control period); for a run over a pose list, where no time
  passes, the sample index;
- ``actions``: ``(N, 2)`` float32 ``(v, w)`` in m/s and rad/s: ``actions[i]`` is the command
  whose step produced sample ``i``; ``actions[0]`` (the reset) and all actions of a pose-list
  run are zero.

On-disk format (version 2)
--------------------------
A run is a directory ``<name>.run/`` holding

- ``panoramas.npy``, ``poses.npy``, ``time.npy``, ``actions.npy``: the four arrays, each a
  ``.npy`` file with the dtype and shape above (no pickled objects: read with
  ``allow_pickle=False``); each holds at least ``n`` samples, and the first ``n`` are the run;
- ``run.json``, the header, a JSON object::

    {"format": "sfa-gym-run", "version": 2,
     "kind": "trajectory" | "poses",
     "env_id": ..., "env_kwargs": {...}, "world": ..., "world_seed": ..., "panorama": {...},
     "arena_bounds": [xmin, xmax, ymin, ymax], "dt": seconds per step,
     "seed": ..., "driver": {"type": ..., ...its arguments}, "n_steps": requested N or null,
     "shape": [H, W, 3], "sfa_gym_version": ..., "created": ISO time,
     "n": samples stored, "complete": false | true,
     "end_reason": null | "n_steps" | "driver_done" | "terminated" | "truncated"}

The header is written last: the recorder appends each block of samples to ``panoramas.npy``
(numpy leaves room in a ``.npy`` header for its first dimension to grow, so the file is always
a valid ``.npy``), rewrites the three small arrays, each atomically
(:func:`sfa_gym.files.write_atomic`: a temporary file in the same directory, fsync,
``os.replace``), and then the header with the new ``n``, as strict JSON (no NaN or infinity).
An interrupted recording leaves a valid ``"complete": false`` run of whole blocks;
:func:`~sfa_gym.recording.recorder.record` resumes it: it resets the env with the same seed,
replays the stored actions (checking that driver and physics reproduce the stored actions and
poses) and continues. Version 1 runs (chunked ``.npz`` files) are not read: record them again.

:func:`load_run` reads a run; its panoramas are memory-mapped, so a 5900-sample 600x60 run
(640 MB) opens instantly and is read from disk as it is indexed. Each read maps the file afresh,
one block of :data:`BLOCK_BYTES` at a time, and unmaps it when done, so a process that copies
panoramas out holds the copy only, not also the file's pages (those stay in the kernel's page
cache, shared).
"""

from __future__ import annotations

import dataclasses
import io
import json
import math
import os
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

import sfa_gym

__all__ = ["BLOCK_BYTES", "FORMAT", "VERSION", "Panoramas", "Run", "RunFormatError", "load_run"]

FORMAT = "sfa-gym-run"
VERSION = 2
HEADER = "run.json"
SUFFIX = ".run"
BLOCK_BYTES = 64 * 2**20
"""Bytes of ``panoramas.npy`` mapped at a time by a read."""

# the arrays of a run: dtype and shape after the leading sample axis ("obs" = (H, W, 3))
_ARRAYS: dict[str, tuple[np.dtype, str | tuple[int, ...]]] = {
    "panoramas": (np.dtype(np.uint8), "obs"),
    "poses": (np.dtype(np.float64), (3,)),
    "time": (np.dtype(np.float64), ()),
    "actions": (np.dtype(np.float32), (2,)),
}
# header keys that describe the recording itself; everything else must match to resume
_BOOKKEEPING = {"sfa_gym_version", "created", "n", "complete", "end_reason"}


class RunFormatError(ValueError):
    """A file is not a sfa-gym run, or is damaged; the message names the file."""


class Panoramas:
    """Read-only ``(N, H, W, 3)`` uint8 array view of a run's ``panoramas.npy``.

    Indexing with an int, a slice, an integer or boolean array returns a numpy array (a copy),
    mapping only the blocks involved, for the read only; ``np.asarray(panoramas)`` loads
    everything.
    """

    def __init__(self, path: Path, offset: int, shape: tuple[int, ...]) -> None:
        self.path = path
        self._offset = offset
        self.shape = shape
        self.dtype = np.dtype(np.uint8)
        self._block = max(1, BLOCK_BYTES // math.prod(shape[1:]))

    ndim = property(lambda self: len(self.shape))
    nbytes = property(lambda self: math.prod(self.shape))

    def __len__(self) -> int:
        return self.shape[0]

    def __repr__(self) -> str:
        return f"Panoramas({str(self.path)!r}, shape={self.shape})"

    def _map(self, start: int) -> NDArray[np.uint8]:
        # A new map per read, unmapped when the caller drops it: a map kept open would keep
        # every page read resident in this process beside the copies made of them.
        count = min(self._block, len(self) - start)
        offset = self._offset + start * math.prod(self.shape[1:])
        shape = (count, *self.shape[1:])
        return np.memmap(self.path, dtype=self.dtype, mode="r", offset=offset, shape=shape)

    def _take(self, indices: NDArray[np.intp]) -> NDArray[np.uint8]:
        out = np.empty((len(indices), *self.shape[1:]), dtype=self.dtype)
        owner = indices // self._block
        for b in np.unique(owner):
            where = owner == b
            start = int(b) * self._block
            out[where] = self._map(start)[indices[where] - start]
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
        for start in range(0, len(self), self._block):
            yield from self._map(start)

    def __array__(self, dtype: Any = None, copy: bool | None = None) -> NDArray[Any]:
        out = self[:]
        return out if dtype is None else out.astype(dtype, copy=False)


@dataclasses.dataclass(frozen=True)
class Run:
    """A recorded run (see the module docstring for the arrays and the format).

    Attributes:
        path: the ``<name>.run`` directory.
        panoramas: ``(N, H, W, 3)`` uint8, read lazily from ``panoramas.npy``.
        poses: ``(N, 3)`` float64 ``(x, y, yaw)``, metres and radians.
        time: ``(N,)`` float64 seconds since the reset (sample index for pose-list runs).
        actions: ``(N, 2)`` float32 ``(v, w)``, m/s and rad/s; ``actions[i]`` produced sample i.
        metadata: the header.
        complete: whether the recording finished (an incomplete run can be resumed).
    """

    path: Path
    panoramas: Panoramas
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
            f"reads version {VERSION}: record the run again"
        )
    shape, n = header.get("shape"), header.get("n")
    if (
        not (isinstance(shape, list) and all(isinstance(s, int) for s in shape))
        or isinstance(n, bool)
        or not (isinstance(n, int) and n >= 0)
        or not isinstance(header.get("complete"), bool)
    ):
        raise RunFormatError(f"{path} lacks a valid 'shape', 'n' (samples) or 'complete'")
    return header


def _append_panoramas(path: Path, block: NDArray[np.uint8], start: int) -> None:
    """Write ``block`` as samples ``start, ...`` of the ``.npy`` file ``path`` (created when
    ``start`` is 0; whatever follows them is cut), then its header's sample count, in place
    (numpy pads a ``.npy`` header so that its first dimension can grow), and fsync."""
    head = io.BytesIO()
    shape = (start + len(block), *block.shape[1:])
    np.lib.format.write_array_header_1_0(
        head, {"descr": "|u1", "fortran_order": False, "shape": shape}
    )
    with open(path, "r+b" if start else "wb") as file:
        if start:
            np.lib.format.read_magic(file)
            np.lib.format.read_array_header_1_0(file)
            if file.tell() != len(head.getvalue()):
                raise RunFormatError(f"{path} has a .npy header of another size; cannot append")
        file.seek(len(head.getvalue()) + start * math.prod(block.shape[1:]))
        file.write(block.data)
        file.truncate()
        file.seek(0)
        file.write(head.getvalue())
        file.flush()
        os.fsync(file.fileno())


def load_run(path: str | os.PathLike[str]) -> Run:
    """Open a run directory written by :func:`~sfa_gym.recording.recorder.record`.

    Checks the header (format name, version) and that every array file exists and holds at
    least ``n`` samples of the expected dtype and shape; the panoramas are memory-mapped.

    Raises:
        FileNotFoundError: ``path`` does not exist.
        RunFormatError: a file is missing, foreign, damaged or truncated; the message names it.
    """
    directory = Path(path)
    header = _read_header(directory)
    n, obs_shape = header["n"], tuple(header["shape"])
    arrays: dict[str, Any] = {}
    for name, (dtype, tail) in _ARRAYS.items():
        file = directory / f"{name}.npy"
        if not file.is_file():
            raise RunFormatError(f"{file} is missing")
        try:
            array = np.load(file, mmap_mode="r", allow_pickle=False)
        except (ValueError, OSError, EOFError) as error:
            raise RunFormatError(f"{file} is damaged, truncated or foreign: {error}") from None
        want = obs_shape if tail == "obs" else tail
        if array.dtype != dtype or array.shape[1:] != want or len(array) < n:
            raise RunFormatError(
                f"{file} holds {array.dtype} of shape {array.shape}, expected {dtype} of shape "
                f"{(n, *want)} or more samples ({HEADER} says {n})"
            )
        arrays[name] = array.offset if name == "panoramas" else np.array(array[:n])
    return Run(
        path=directory,
        panoramas=Panoramas(directory / "panoramas.npy", arrays.pop("panoramas"), (n, *obs_shape)),
        **arrays,
        metadata=header,
        complete=header["complete"],
    )
