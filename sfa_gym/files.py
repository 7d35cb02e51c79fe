"""Files of the run and model formats: written so that nothing is lost (atomically, durably,
with strict JSON), and the ``.npy`` headers of their ``.npz`` members read without the data.

A file is written to a temporary file in the same directory, flushed and fsynced, then renamed
over the target (``os.replace`` is atomic on POSIX), and the directory is fsynced so that the
rename survives a power cut. A reader therefore sees the old file or the new one, never half of
one. Runs (:mod:`sfa_gym.recording.runfile`) and models (:mod:`sfa_gym.sfa.io`) both write this
way, and both check a member's ``.npy`` header before they read its data.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import IO, Any

import numpy as np

__all__ = [
    "check_format_header",
    "read_npy_header",
    "strict_json",
    "write_atomic",
    "write_json_atomic",
]


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
