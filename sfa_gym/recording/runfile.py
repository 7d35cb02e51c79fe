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
     "chunks": [{"file": "chunk-00000.npz", "n": 500, "sha256": "9f86d0..."}, ...],
     "n": total samples in the chunks, "complete": false | true,
     "end_reason": null | "n_steps" | "driver_done" | "terminated" | "truncated"}

- ``chunk-00000.npz``, ``chunk-00001.npz``, ...: consecutive samples in chunk order, each an
  ``np.savez`` archive (uncompressed by default; ``np.savez_compressed`` also reads) of exactly
  the four arrays ``panoramas``, ``poses``, ``time``, ``actions``, with ``n`` rows each and the
  dtypes above; no pickled objects (read with ``allow_pickle=False``).

Each chunk entry may carry ``"sha256"``, the SHA-256 of the chunk file (hex). It was added
without a version bump: runs written before have no checksums and load as before (unchecked),
and older readers ignore the key. Every file is written atomically
(:func:`sfa_gym.files.write_atomic`: a temporary file in the same directory, fsync,
``os.replace``), the header as strict JSON (no NaN or infinity), and the header is rewritten
after each chunk, so an interrupted recording leaves a valid, ``"complete": false`` run of whole
chunks. :func:`~sfa_gym.recording.recorder.record` resumes it: it resets the env with the same
seed, replays the stored actions (checking that driver and physics reproduce the stored actions
and poses) and continues. Files other than the header and listed chunks are ignored.

:func:`load_run` reads a run; the panoramas of uncompressed chunks are memory-mapped, so a
5900-sample 600x60 run (640 MB) opens instantly and is read from disk as it is indexed. Each read
maps the chunk afresh and unmaps it when done, so a process that copies panoramas out holds the
copy only, not also the file's pages (those stay in the kernel's page cache, shared). A
memory map skips the zip's own CRC, so the checksums are verified instead: each chunk file is
hashed the first time its panoramas are read (about 1.5 GB/s), and :meth:`Run.verify` checks all
chunks at once; a chunk whose bytes changed raises :class:`RunFormatError` naming it.
"""

from __future__ import annotations

import dataclasses
import hashlib
import io
import json
import math
import os
import re
import struct
import zipfile
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

import sfa_gym
from sfa_gym.files import read_npy_header, write_atomic, write_json_atomic

__all__ = [
    "FORMAT",
    "VERSION",
    "Run",
    "RunFormatError",
    "ChunkedPanoramas",
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
_SHA256 = re.compile(r"[0-9a-f]{64}")
# header keys that describe the recording itself; everything else must match to resume
_BOOKKEEPING = {"sfa_gym_version", "created", "chunks", "n", "complete", "end_reason"}


class RunFormatError(ValueError):
    """A file is not a sfa-gym run, or is damaged; the message names the file."""


# ------------------------------------------------------------------------ chunk files


def _write_header(directory: Path, header: Mapping[str, Any]) -> None:
    write_json_atomic(directory / HEADER, header)


def _write_chunk(path: Path, arrays: Mapping[str, NDArray[Any]], compress: bool) -> str:
    """Write one chunk atomically; return the SHA-256 (hex) of the bytes written."""
    save = np.savez_compressed if compress else np.savez
    # serialised in memory first, so that the checksum is that of what was meant to be written
    buffer = io.BytesIO()
    save(buffer, **arrays)
    data = buffer.getbuffer()
    write_atomic(path, lambda file: file.write(data))
    return hashlib.sha256(data).hexdigest()


def _file_sha256(path: Path) -> str:
    try:
        with open(path, "rb") as file:
            return hashlib.file_digest(file, "sha256").hexdigest()
    except OSError as error:
        raise RunFormatError(f"chunk {path} cannot be read: {error}") from None


def _verify_chunk(path: Path, expected: str | None) -> None:
    """Compare the chunk file's SHA-256 with the header's (``None``: a run without checksums)."""
    if expected is None:
        return
    found = _file_sha256(path)
    if found != expected:
        raise RunFormatError(
            f"chunk {path} is corrupted: its SHA-256 is {found}, but {HEADER} records "
            f"{expected}; record the run again (load_run(..., verify=False) reads it unchecked)"
        )


def _member_header(zf: zipfile.ZipFile, member: str) -> tuple[tuple[int, ...], np.dtype, int]:
    """Shape, dtype and data offset (inside the member) of one ``.npy`` member."""
    with zf.open(member) as stream:
        shape, fortran, dtype = read_npy_header(stream)
        if fortran and len(shape) > 1:
            raise ValueError("Fortran-ordered array")
        return shape, dtype, stream.tell()


def _stored_offset(path: Path, zf: zipfile.ZipFile, member: str) -> int | None:
    """Where the data of an uncompressed ``.npy`` member of an ``.npz`` starts in the file, for
    a memory map; ``None`` if the member is compressed."""
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
    return offset


def _read_chunk(path: Path, n: int, obs_shape: tuple[int, ...]) -> dict[str, Any]:
    """The small arrays of a chunk, and where its panoramas start in the file (``None``:
    compressed, decoded when read)."""
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
                    out[name] = _stored_offset(path, zf, f"{name}.npy")
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
    only the chunks involved (memory-mapped where uncompressed, for the read only; a compressed
    chunk is decoded once and cached until another one is needed). ``np.asarray(panoramas)``
    loads everything.
    Before a chunk's panoramas are first returned, its file is checked against its SHA-256
    (``checksums[c]``; ``None`` skips the check).
    """

    def __init__(
        self,
        files: list[Path],
        counts: list[int],
        obs_shape: tuple[int, ...],
        offsets: list[int | None],
        checksums: list[str | None] | None = None,
    ) -> None:
        self._files = files
        self._offsets = offsets
        self._checksums = checksums or [None] * len(files)
        self._verified = [digest is None for digest in self._checksums]
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

    def verify(self, c: int | None = None) -> None:
        """Check chunk ``c`` (all chunks if ``None``) against its checksum, once per chunk.

        Raises:
            RunFormatError: a chunk file's bytes differ from those recorded; names the chunk.
        """
        for i in range(len(self._files)) if c is None else (c,):
            if not self._verified[i]:
                _verify_chunk(self._files[i], self._checksums[i])
                self._verified[i] = True

    def chunk(self, c: int) -> NDArray[np.uint8]:
        """The panoramas of chunk ``c``, ``(n_c, H, W, 3)`` (memory-mapped or decoded)."""
        self.verify(c)
        offset = self._offsets[c]
        if offset is not None:
            # A new map per read, unmapped when the caller drops it: a map kept open would keep
            # every page read resident in this process beside the copies made of them.
            count = int(self._starts[c + 1] - self._starts[c])
            return np.memmap(
                self._files[c],
                dtype=self.dtype,
                mode="r",
                offset=offset,
                shape=(count, *self.shape[1:]),
            )
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
        out = np.empty(self.shape, dtype=self.dtype)
        for start, chunk in self.iter_chunks():  # one chunk mapped at a time
            out[start : start + len(chunk)] = chunk
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

    def verify(self) -> None:
        """Check every chunk file against the checksum in the header now (reads the whole run;
        otherwise each chunk is checked when its panoramas are first read).

        Raises:
            RunFormatError: a chunk's bytes differ from those recorded; the message names it.
        """
        self.panoramas.verify()

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
        digest = c.get("sha256")
        if digest is not None and not (isinstance(digest, str) and _SHA256.fullmatch(digest)):
            raise RunFormatError(
                f"{path}: chunk {name!r} has sha256 {digest!r}, expected 64 hex digits"
            )
    return header


def load_run(path: str | os.PathLike[str], *, verify: bool = True) -> Run:
    """Open a run directory written by :func:`~sfa_gym.recording.recorder.record`.

    Checks the header (format name, version), that every listed chunk exists and holds exactly
    the expected arrays with the right shapes and dtypes; panoramas of uncompressed chunks are
    memory-mapped, compressed ones are decoded on access.

    Args:
        path: the ``<name>.run`` directory.
        verify: check each chunk against the SHA-256 in the header before its panoramas are
            first read (runs without checksums are not checked); :meth:`Run.verify` checks
            all chunks at once. ``False`` reads a damaged run as it is.

    Raises:
        FileNotFoundError: ``path`` does not exist.
        RunFormatError: a file is missing, foreign, damaged or truncated; the message names it.
    """
    directory = Path(path)
    header = _read_header(directory)
    obs_shape = tuple(int(s) for s in header["shape"])
    files, counts, offsets, parts, checksums = [], [], [], [], []
    for c in header["chunks"]:
        file = directory / c["file"]
        chunk = _read_chunk(file, int(c["n"]), obs_shape)
        checksums.append(c.get("sha256") if verify else None)
        files.append(file)
        counts.append(int(c["n"]))
        offsets.append(chunk["panoramas"])
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
        panoramas=ChunkedPanoramas(files, counts, obs_shape, offsets, checksums),
        poses=stacked("poses"),
        time=stacked("time"),
        actions=stacked("actions"),
        metadata=metadata,
        complete=header["complete"],
    )
