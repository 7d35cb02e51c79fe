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

BLAS control goes through threadpoolctl, which finds every BLAS library loaded in the process
(numpy's and scipy's wheels each bundle an OpenBLAS) and sets its thread count; the previous
setting is restored on exit. Where threadpoolctl finds no BLAS it can control, BLAS is left alone
and the engine runs its chunks one at a time, so that BLAS threads and pool threads never compete.
"""

from __future__ import annotations

import functools
import os
from collections import deque
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import Future, ThreadPoolExecutor
from contextlib import AbstractContextManager
from typing import Any, TypeVar

from threadpoolctl import OpenBLASController, ThreadpoolController

from sfa_gym.sfa._scope import CountedScope

__all__ = [
    "blas_controllable",
    "blas_corename",
    "n_workers",
    "ordered_map",
    "single_threaded_blas",
]

T = TypeVar("T")
R = TypeVar("R")

_limiter: Any = None


@functools.cache
def _blas() -> ThreadpoolController:
    """The BLAS libraries loaded in this process, as a threadpoolctl controller (cached).

    Those loaded at the first call: numpy's and scipy's, the engine's. A BLAS another package
    loads later (the engine never calls it) is left alone; scanning again at every limit would
    cost ~1.5 ms, more than a navigation step's features.
    """
    import scipy.linalg  # noqa: F401  (make sure scipy's own BLAS is loaded before scanning)

    return ThreadpoolController().select(user_api="blas")


@functools.cache
def blas_corename() -> str | None:
    """The kernel family numpy's OpenBLAS runs (e.g. ``"Haswell"``, ``"SkylakeX"``), or None
    if numpy does not use OpenBLAS. ``OPENBLAS_CORETYPE`` in the environment forces it."""
    import numpy

    numpy_libs = os.path.dirname(numpy.__file__) + ".libs"
    for lib in _blas().info():
        if lib["internal_api"] == "openblas" and os.path.dirname(lib["filepath"]) == numpy_libs:
            return lib["architecture"]
    return None


def blas_controllable() -> bool:
    """Whether the BLAS thread count can be set (threadpoolctl found a BLAS in the process)."""
    return bool(_blas().lib_controllers)


def _take_openblas_control() -> None:
    """Let this thread set OpenBLAS's (process-wide) thread count.

    threadpoolctl >= 3.8 lets only one thread at a time change a pthreads OpenBLAS and silently
    ignores the others; the engine's scope may open and close on different threads, so the
    thread that opens or closes it takes control (earlier threadpoolctl has no such rule).
    """
    clear = getattr(OpenBLASController, "clear_controlling_thread", None)
    if clear is not None:
        clear(force=True)


def _release_openblas_control() -> None:
    clear = getattr(OpenBLASController, "clear_controlling_thread", None)
    if clear is not None:
        clear()


def _limit_blas() -> None:
    global _limiter
    _take_openblas_control()
    _limiter = _blas().limit(limits=1)
    _release_openblas_control()


def _restore_blas() -> None:
    global _limiter
    _take_openblas_control()
    _limiter.restore_original_limits()
    _release_openblas_control()
    _limiter = None


# counted, not nested threadpoolctl limiters: see CountedScope
_ONE_BLAS_THREAD = CountedScope(_limit_blas, _restore_blas)


def single_threaded_blas() -> AbstractContextManager[None]:
    """Run BLAS with one thread inside the block (nestable, restores the previous counts)."""
    return _ONE_BLAS_THREAD.held()


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

    Why not ``ThreadPoolExecutor.map``: before Python 3.14 (its ``buffersize``) it submits every
    item at once, so finished results pile up while the caller consumes them; the SFA passes
    return per-chunk moment copies of up to ``_sources.PARTIAL_BYTES`` (256 MB) each and merge
    them in the calling thread, so an unbounded run-ahead could hold all of them at once. The
    window below is that ``buffersize`` (``workers + 1``); the executor does the rest.
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
