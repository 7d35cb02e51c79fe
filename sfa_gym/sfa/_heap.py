"""Freed memory kept on the heap while the engine trains (glibc only; elsewhere a no-op).

Why. Each chunk of a training pass allocates its working arrays anew (raw pixels, node inputs,
their expansion, the time differences: 30-70 MB each at the default budget). glibc serves blocks
above its mmap threshold (32 MB at most) with fresh pages from ``mmap`` and unmaps them on
``free``, so every chunk faults in and zeroes its pages again: 15-20 % of the CPU time of a
paper-scale fit went to the kernel (docs/notes/2026-11-27-sfa-training-time.md). Inside
:func:`kept_heap` glibc serves every block from one heap and keeps what is freed there, so the
next chunk reuses pages that are mapped already. Nothing that is computed changes (the fitted
models were compared byte for byte).

On exit glibc's previous behaviour is set again (its defaults, or the values of the
``MALLOC_*_`` environment variables that set them) and the kept memory is returned to the system
(``malloc_trim``).
"""

from __future__ import annotations

import ctypes
import ctypes.util
import functools
import os
from contextlib import AbstractContextManager, nullcontext
from typing import Any

from sfa_gym.sfa._scope import CountedScope

__all__ = ["kept_heap"]

# mallopt's parameters (glibc's malloc.h)
M_TRIM_THRESHOLD = -1
M_MMAP_MAX = -4
M_ARENA_MAX = -8

# while training: no block from mmap, freed memory kept up to 2 GiB, one arena (so that the
# pool's threads reuse each other's freed chunks instead of growing an arena each)
_TRAINING = {M_MMAP_MAX: 0, M_TRIM_THRESHOLD: 2**31 - 1, M_ARENA_MAX: 1}
# glibc's defaults and the environment variables that override them (0 arenas: glibc's default)
_DEFAULTS = {
    M_MMAP_MAX: ("MALLOC_MMAP_MAX_", 65536),
    M_TRIM_THRESHOLD: ("MALLOC_TRIM_THRESHOLD_", 128 * 1024),
    M_ARENA_MAX: ("MALLOC_ARENA_MAX", 0),
}


@functools.cache
def _glibc() -> Any | None:
    """The C library if it is glibc (has ``mallopt`` and ``malloc_trim``), else None."""
    name = ctypes.util.find_library("c")
    if not name:
        return None
    try:
        libc = ctypes.CDLL(name)
    except OSError:
        return None
    if not all(hasattr(libc, f) for f in ("mallopt", "malloc_trim", "gnu_get_libc_version")):
        return None
    return libc


def _previous(param: int) -> int:
    variable, default = _DEFAULTS[param]
    try:
        return int(os.environ.get(variable, default))
    except ValueError:  # glibc ignores a malformed value too
        return default


def _keep() -> None:
    for param, value in _TRAINING.items():
        _glibc().mallopt(param, value)


def _release() -> None:
    for param in _TRAINING:
        _glibc().mallopt(param, _previous(param))
    _glibc().malloc_trim(0)


_KEPT = CountedScope(_keep, _release)


def kept_heap() -> AbstractContextManager[None]:
    """Keep freed memory on glibc's heap inside the block (nestable, thread-safe)."""
    return _KEPT.held() if _glibc() is not None else nullcontext()
