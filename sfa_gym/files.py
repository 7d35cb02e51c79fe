"""Files of the run, model and field formats: written so that nothing is lost (atomically,
durably, with strict JSON), and the one reader of the project's ``.npz`` files.

A file is written to a temporary file in the same directory, flushed and fsynced, then renamed
over the target (``os.replace`` is atomic on POSIX), and the directory is fsynced so that the
rename survives a power cut. A reader therefore sees the old file or the new one, never half of
one. Runs (:mod:`sfa_gym.recording.runfile`), models (:mod:`sfa_gym.sfa.io`) and feature fields
(:mod:`sfa_gym.navigation.field`) all write this way.

An ``.npz`` file (:func:`write_npz`, :func:`read_npz`) is a zip archive as ``np.savez`` writes it,
one ``.npy`` member per array, the first, ``header``, a 0-d unicode array holding a JSON object
with the file's ``format`` and ``version``. It is never unpickled, and nothing large is read before
the file has been checked against its own header: the member names must be exactly those the
header defines; each member's ``.npy`` header (read without inflating its data) must declare the
dtype and shape the header gives, and the member's size in the zip directory must equal that; a
compressed member may not inflate to more than :data:`MAX_COMPRESSION_RATIO` times its stored
size. A small file whose members would inflate to gigabytes is thus refused after reading a few
hundred bytes.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import tempfile
import zipfile
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import IO, Any, TypeVar

import numpy as np

__all__ = [
    "MAX_COMPRESSION_RATIO",
    "check_format_header",
    "load_error",
    "read_npy_header",
    "read_npz",
    "strict_json",
    "write_atomic",
    "write_json_atomic",
    "write_npz",
]

MAX_HEADER_BYTES = 1 << 20
"""Largest ``header`` member of an ``.npz`` file accepted (a real header is a few kB)."""
MAX_COMPRESSION_RATIO = 100
"""Largest inflated / stored size of a compressed member (float weights compress ~1.1 : 1)."""
T = TypeVar("T")


def _fsync_dir(directory: Path) -> None:
    # makes the rename durable; not possible on every platform
    with contextlib.suppress(OSError):
        fd = os.open(directory, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)


def write_atomic(path: str | os.PathLike[str], write: Callable[[IO[bytes]], None]) -> None:
    """Create or replace ``path`` with what ``write(file)`` writes, atomically and durably.

    ``write`` receives a binary file object. If it raises (or the process is interrupted), the
    temporary file is removed and ``path`` is left as it was.
    """
    path = Path(path)
    directory = path.parent if str(path.parent) else Path(".")
    fd, tmp = tempfile.mkstemp(dir=directory, prefix=f".{path.name}.", suffix=".tmp")
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
    _fsync_dir(directory)


def _find_non_finite(value: Any, where: str) -> str | None:
    if isinstance(value, float) and not math.isfinite(value):
        return f"{where} = {value!r}"
    if isinstance(value, dict):
        for key, item in value.items():
            found = _find_non_finite(item, f"{where}.{key}" if where else str(key))
            if found:
                return found
    if isinstance(value, list | tuple):
        for i, item in enumerate(value):
            found = _find_non_finite(item, f"{where}[{i}]")
            if found:
                return found
    return None


def strict_json(value: Any, indent: int | None = 1) -> str:
    """``json.dumps`` that refuses NaN and infinities, naming the offending key.

    Standard JSON has no NaN or Infinity; Python writes them anyway and most other readers
    then fail. Raises:
        ValueError: a value is not finite; the message gives its path, e.g. ``a.b[2] = nan``.
    """
    try:
        return json.dumps(value, indent=indent, allow_nan=False)
    except ValueError:
        found = _find_non_finite(value, "")
        raise ValueError(
            f"cannot write a non-finite number to JSON: {found or 'a value'}; "
            "expected finite numbers"
        ) from None


def write_json_atomic(path: str | os.PathLike[str], value: Any, indent: int | None = 1) -> None:
    """Write ``value`` as strict JSON (see :func:`strict_json`) to ``path``, atomically."""
    text = strict_json(value, indent=indent).encode()
    write_atomic(path, lambda file: file.write(text))


def read_npy_header(stream: IO[bytes]) -> tuple[tuple[int, ...], bool, np.dtype[Any]]:
    """``(shape, fortran_order, dtype)`` from the ``.npy`` header at the start of ``stream``,
    which is left at the first data byte; nothing of the data is read.

    Raises:
        ValueError: not a ``.npy`` header, or a format version other than 1.0 and 2.0.
    """
    version = np.lib.format.read_magic(stream)
    read = {
        (1, 0): np.lib.format.read_array_header_1_0,
        (2, 0): np.lib.format.read_array_header_2_0,
    }.get(version)
    if read is None:
        raise ValueError(f"unsupported .npy version {version}")
    shape, fortran, dtype = read(stream)
    return tuple(shape), bool(fortran), dtype


def check_format_header(header: Any, expected: str, newest: int, what: str) -> int:
    """The version of a file whose parsed JSON header names its ``format`` and ``version``.

    Args:
        header: the parsed header (anything: a damaged file can hold any JSON).
        expected: the format name the header must give.
        newest: the newest format version this library reads.
        what: what the file is, for the message ("an sfa-gym model file").
    Raises:
        ValueError: another format, a version that is not a positive int, or a version newer
            than ``newest`` (the message says to upgrade and which library wrote the file).
    """
    if not isinstance(header, dict) or header.get("format") != expected:
        got = header.get("format") if isinstance(header, dict) else type(header).__name__
        raise ValueError(f"format is {got!r}, expected {expected!r}: not {what}")
    version = header.get("version")
    if isinstance(version, bool) or not isinstance(version, int) or version < 1:
        raise ValueError(f"invalid format version {version!r}")
    if version > newest:
        from sfa_gym import __version__

        writer = header.get("library_version")
        by = f" (the file was written by sfa-gym {writer})" if writer else ""
        raise ValueError(
            f"format version {version} is newer than this sfa-gym ({__version__}) reads "
            f"(up to {newest}); upgrade sfa-gym{by}"
        )
    return version


def write_npz(
    path: str | os.PathLike[str], header: dict[str, Any], arrays: dict[str, np.ndarray]
) -> None:
    """Write ``header`` (strict JSON, the first member) and ``arrays`` to ``path`` as
    ``np.savez`` does, atomically."""
    members = {"header": np.array(strict_json(header, indent=None)), **arrays}
    write_atomic(path, lambda file: np.savez(file, **members))  # type: ignore[arg-type]


def load_error(what: str, path: Any, why: object) -> ValueError:
    """The error of a file that cannot be loaded: names what it is, the file and why."""
    return ValueError(f"cannot load {what} {str(path)!r}: {why}")


class _BadFile(ValueError):
    """What is wrong with an ``.npz`` file (the caller adds the file's name)."""


Layout = Callable[[dict[str, Any], int], tuple[T, dict[str, tuple[str, tuple[int, ...]]]]]


def read_npz(
    path: str | os.PathLike[str], what: str, fmt: str, newest: int, layout: Layout[T]
) -> tuple[T, dict[str, np.ndarray]]:
    """Read an ``.npz`` file of format ``fmt`` written by :func:`write_npz`, after the checks
    of the module docstring.

    Args:
        what: what the file holds, for the messages ("SFA model").
        fmt, newest: the header's format name and the newest version this library reads.
        layout: ``(header, version) -> (parsed, members)``: what the caller makes of the
            header, and the members (besides ``header``) the file must hold, name ->
            ``(dtype, shape)``; a ValueError, KeyError or TypeError means a bad header.
    Returns:
        ``parsed`` and the arrays by member name.
    Raises:
        FileNotFoundError: no such file.
        ValueError: not such a file (a pickle, another archive, another format), a newer
            version, missing or extra members, members whose dtype, shape or size disagree
            with the header, or corrupt data; the message names the file and what is wrong.
    """
    if not Path(path).is_file():
        raise FileNotFoundError(f"no {what} file at {str(path)!r}")
    try:
        with open(path, "rb") as file:
            if file.read(1) == b"\x80":  # the PROTO opcode every pickle (protocol >= 2) opens with
                raise _BadFile("the file is a pickle, and pickles are never unpickled")
        with zipfile.ZipFile(path) as archive:
            return _read_npz(archive, f"an sfa-gym {what} file", fmt, newest, layout)
    except _BadFile as err:
        raise load_error(what, path, err) from None
    except (zipfile.BadZipFile, OSError, EOFError) as err:
        raise load_error(what, path, f"not a readable .npz archive ({err})") from None


def _read_npz(
    archive: zipfile.ZipFile, what: str, fmt: str, newest: int, layout: Layout[T]
) -> tuple[T, dict[str, np.ndarray]]:
    members: dict[str, zipfile.ZipInfo] = {}
    for info in archive.infolist():
        name = info.filename.removesuffix(".npy")
        if name == info.filename or name in members:
            raise _BadFile(f"member {info.filename!r} is not a (single) .npy array")
        _check_inflation(info)
        members[name] = info
    if "header" not in members:
        raise _BadFile(f"missing member(s) ['header']: not {what}")
    header = _read_header(archive, members["header"])
    try:
        version = check_format_header(header, fmt, newest, what)
    except ValueError as err:
        raise _BadFile(str(err)) from None
    try:
        parsed, expected = layout(header, version)
    except (KeyError, TypeError, ValueError) as err:
        raise _BadFile(f"invalid header ({type(err).__name__}: {err})") from None
    unknown = sorted(set(members) - set(expected) - {"header"})
    if unknown:
        raise _BadFile(f"members the format does not define: {unknown}")
    missing = [key for key in expected if key not in members]
    if missing:
        raise _BadFile(f"missing member(s) {missing}")
    # every member's declared size is checked before any member's data is read
    for key, (dtype, shape) in expected.items():
        with _member(archive, members[key], key) as file:
            _check_npy_header(file, members[key], key, dtype, shape)
    arrays = {}
    for key, (dtype, shape) in expected.items():
        with _member(archive, members[key], key) as file:
            fortran, got = _check_npy_header(file, members[key], key, dtype, shape)
            arrays[key] = _read_data(file, key, got, shape, fortran).copy()
    return parsed, arrays


def _check_inflation(info: zipfile.ZipInfo) -> None:
    if info.compress_type == zipfile.ZIP_STORED:
        if info.file_size != info.compress_size:
            raise _BadFile(
                f"member {info.filename!r} is stored uncompressed but declares "
                f"{info.file_size} bytes in {info.compress_size}"
            )
    elif info.file_size > MAX_COMPRESSION_RATIO * max(info.compress_size, 1):
        raise _BadFile(
            f"member {info.filename!r} would inflate from {info.compress_size} to "
            f"{info.file_size} bytes (more than {MAX_COMPRESSION_RATIO} times): refused"
        )


def _check_npy_header(
    file: IO[bytes], info: zipfile.ZipInfo, key: str, dtype: str | None, shape: tuple[int, ...]
) -> tuple[bool, np.dtype[Any]]:
    """Read the ``.npy`` header at the start of ``file`` and check it against the expected
    ``dtype`` (None: unicode text) and ``shape`` and against the member's size; returns
    whether the data is in Fortran order and its dtype (``file`` is left at the data)."""
    try:
        got_shape, fortran, got_dtype = read_npy_header(file)
    except ValueError as err:
        raise _BadFile(f"member {key!r} is not a .npy array ({err})") from None
    if got_dtype.hasobject:
        raise _BadFile(f"member {key!r} holds Python objects (a pickle), which are never unpickled")
    if (got_dtype.kind != "U") if dtype is None else (got_dtype != np.dtype(dtype)):
        want = "unicode text" if dtype is None else np.dtype(dtype).name
        raise _BadFile(f"member {key!r} has dtype {got_dtype}, expected {want}")
    if got_shape != shape:
        raise _BadFile(f"member {key!r} has shape {got_shape}, expected {shape}")
    data_bytes = math.prod(got_shape) * got_dtype.itemsize
    if info.file_size != file.tell() + data_bytes:
        raise _BadFile(
            f"member {info.filename!r} holds {info.file_size} bytes, but its header declares "
            f"{got_shape} {got_dtype} ({file.tell() + data_bytes} bytes with the header)"
        )
    return fortran, got_dtype


@contextlib.contextmanager
def _member(archive: zipfile.ZipFile, info: zipfile.ZipInfo, key: str) -> Iterator[IO[bytes]]:
    """The member opened for reading; a checksum error becomes an error naming the member (a
    small member is read whole, and its checksum checked, with its first bytes)."""
    try:
        with archive.open(info) as file:
            yield file
    except zipfile.BadZipFile as err:
        raise _BadFile(f"member {key!r} is corrupt ({err})") from None


def _read_data(
    file: IO[bytes], key: str, dtype: np.dtype[Any], shape: tuple[int, ...], fortran: bool
) -> np.ndarray:
    size = math.prod(shape) * dtype.itemsize
    data = file.read(size)
    if len(data) != size:
        raise _BadFile(f"member {key!r} is truncated")
    return np.frombuffer(data, dtype=dtype).reshape(shape, order="F" if fortran else "C")


def _read_header(archive: zipfile.ZipFile, info: zipfile.ZipInfo) -> Any:
    if info.file_size > MAX_HEADER_BYTES:
        raise _BadFile(f"the header member holds {info.file_size} bytes; a header is a few kB")
    with _member(archive, info, "header") as file:
        fortran, dtype = _check_npy_header(file, info, "header", None, ())
        text = _read_data(file, "header", dtype, (), fortran)
    try:
        return json.loads(str(text[()]))
    except (json.JSONDecodeError, UnicodeError) as err:
        raise _BadFile(f"the header is not valid JSON ({err})") from None
