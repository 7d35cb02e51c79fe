"""Threads for the SFA engine: scoped single-threaded BLAS and an ordered parallel map.

Why. The engine's work is dominated by large float32 matrix products (Gram matrices of node
inputs). OpenBLAS parallelises each product over its own threads, which synchronise many times
per product; on a machine whose cores are shared with other processes, a descheduled BLAS
thread stalls its partners, and two BLAS threads on two busy cores were measured 5x slower than
one (``sgemm`` 25 vs 125 GFLOP/s here; ``eigh`` 40x slower). The engine therefore runs BLAS
single-threaded while it works and parallelises at a coarser grain itself: independent chunks
of data go to a small thread pool (numpy releases the GIL in BLAS calls and array loops), and
their results are combined in chunk order, so the numbers do not depend on the number of
threads or on scheduling.

BLAS control uses the OpenBLAS libraries already loaded in the process (numpy's and scipy's
wheels each bundle one) through their ``*_set_num_threads`` entry points; the previous setting
is restored on exit. Where no OpenBLAS is found (another BLAS), BLAS is left alone and the
engine runs its chunks one at a time, so that BLAS threads and pool threads never compete.
"""

from __future__ import annotations

import ctypes
import functools
import glob
import os
import threading
from collections import deque
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import Future, ThreadPoolExecutor
from contextlib import contextmanager
from typing import Any, TypeVar

__all__ = [
    "blas_controllable",
    "blas_corename",
    "n_workers",
    "ordered_map",
    "single_threaded_blas",
]

T = TypeVar("T")
R = TypeVar("R")

_SETTERS = (
    "scipy_openblas_set_num_threads64_",
    "scipy_openblas_set_num_threads",
    "openblas_set_num_threads64_",
    "openblas_set_num_threads",
)
_GETTERS = (
    "scipy_openblas_get_num_threads64_",
    "scipy_openblas_get_num_threads",
    "openblas_get_num_threads64_",
    "openblas_get_num_threads",
)

_CORENAMES = (
    "scipy_openblas_get_corename64_",
    "scipy_openblas_get_corename",
    "openblas_get_corename64_",
    "openblas_get_corename",
)

_lock = threading.Lock()
_depth = 0
_saved: list[tuple[Any, Any, int]] = []
_handles: list[tuple[Any, Any]] | None = None


def _loaded_openblas_paths() -> list[str]:
    """Paths of the OpenBLAS shared libraries mapped into this process."""
    paths: set[str] = set()
    try:
        with open("/proc/self/maps", encoding="utf-8", errors="replace") as fh:
            for line in fh:
                path = line.split()[-1] if line.strip() else ""
                if "openblas" in os.path.basename(path).lower():
                    paths.add(path)
    except OSError:  # no procfs (macOS): look next to the numpy and scipy packages
        import numpy
        import scipy

        for pkg in (numpy, scipy):
            base = os.path.dirname(pkg.__file__ or "")
            for d in (base + ".libs", os.path.join(base, ".dylibs")):
                paths.update(glob.glob(os.path.join(d, "*openblas*")))
    return sorted(paths)


def _openblas_handles() -> list[tuple[Any, Any]]:
    """``(get, set)`` thread-count functions of every loaded OpenBLAS (cached)."""
    global _handles
    if _handles is None:
        import scipy.linalg  # noqa: F401  (make sure scipy's own BLAS is loaded before scanning)

        found = []
        for path in _loaded_openblas_paths():
            try:
                lib = ctypes.CDLL(path)
            except OSError:
                continue
            setter = next((getattr(lib, n) for n in _SETTERS if hasattr(lib, n)), None)
            getter = next((getattr(lib, n) for n in _GETTERS if hasattr(lib, n)), None)
            if setter is None or getter is None:
                continue
            setter.argtypes, setter.restype = [ctypes.c_int], None
            getter.argtypes, getter.restype = [], ctypes.c_int
            found.append((getter, setter))
        _handles = found
    return _handles


@functools.cache
def blas_corename() -> str | None:
    """The kernel family numpy's OpenBLAS runs (e.g. ``"Haswell"``, ``"SkylakeX"``), or None
    if numpy does not use OpenBLAS. ``OPENBLAS_CORETYPE`` in the environment forces it."""
    import numpy

    for path in _loaded_openblas_paths():
        if os.path.dirname(path) != os.path.dirname(numpy.__file__) + ".libs":
            continue
        try:
            lib = ctypes.CDLL(path)
        except OSError:
            continue
        for name in _CORENAMES:
            fn = getattr(lib, name, None)
            if fn is not None:
                fn.restype = ctypes.c_char_p
                return fn().decode()
    return None


def blas_controllable() -> bool:
    """Whether the BLAS thread count can be set (OpenBLAS found in the process)."""
    return bool(_openblas_handles())


@contextmanager
def single_threaded_blas() -> Iterator[None]:
    """Run BLAS with one thread inside the block (nestable, restores the previous counts)."""
    global _depth, _saved
    handles = _openblas_handles()
    with _lock:
        if _depth == 0:
            _saved = [(get, put, int(get())) for get, put in handles]
            for _, put, _n in _saved:
                put(1)
        _depth += 1
    try:
        yield
    finally:
        with _lock:
            _depth -= 1
            if _depth == 0:
                for _, put, n in _saved:
                    put(n)
                _saved = []


def available_cpus() -> int:
    """CPUs this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        return os.cpu_count() or 1


def n_workers(n_jobs: int | None) -> int:
    """Pool size for ``n_jobs`` (None: every available CPU); 1 if BLAS cannot be controlled."""
    if not blas_controllable():
        return 1
    if n_jobs is None:
        return available_cpus()
    return max(1, int(n_jobs))


def ordered_map(fn: Callable[[T], R], items: Iterable[T], workers: int) -> Iterator[R]:
    """``map(fn, items)`` on ``workers`` threads, yielding results in the order of ``items``.

    At most ``workers`` calls run at a time (one more may wait in the queue), so the working
    memory is bounded by ``workers`` chunks. With ``workers == 1`` everything runs in the
    calling thread.
    """
    items = list(items)
    if workers <= 1 or len(items) <= 1:
        for item in items:
            yield fn(item)
        return
    pending: deque[Future[R]] = deque()
    with ThreadPoolExecutor(max_workers=workers, thread_name_prefix="sfa") as pool:
        try:
            for item in items:
                if len(pending) > workers:
                    yield pending.popleft().result()
                pending.append(pool.submit(fn, item))
            while pending:
                yield pending.popleft().result()
        finally:
            for fut in pending:
                fut.cancel()
