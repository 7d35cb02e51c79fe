"""Peak resident memory (RSS) of a process and of a worker's process tree, read from Linux's
``/proc``: what a leaderboard task records beside its seconds (``peak_rss_mb``).

The evaluator's own peak is reset when a task starts (``/proc/self/clear_refs``), because a Ray
worker runs many tasks and the kernel keeps one high-water mark per process. A plug-in worker
lives for one task; its peak is read just before it is stopped, summed over the worker and the
processes it started (the confinement's and the plug-in's own), which bounds their combined
peak from above. Elsewhere than on Linux the figures are None.
"""

from __future__ import annotations

import contextlib
from pathlib import Path

__all__ = ["own_peak_mb", "reset_own_peak", "tree_peak_mb"]

_PROC = Path("/proc")


def reset_own_peak() -> None:
    """Start this process's high-water mark afresh (where the kernel allows it)."""
    with contextlib.suppress(OSError):
        (_PROC / "self" / "clear_refs").write_text("5")


def own_peak_mb() -> float | None:
    """This process's peak RSS since it started or since :func:`reset_own_peak`, MiB."""
    return _peak_mb("self")


def tree_peak_mb(pid: int) -> float | None:
    """The sum of the peak RSS of process ``pid`` and of its living descendants, MiB (None:
    ``pid`` is gone or ``/proc`` is not readable)."""
    children: dict[int, list[int]] = {}
    for stat in _PROC.glob("[0-9]*/stat"):
        with contextlib.suppress(OSError, ValueError, IndexError):
            # the command name (field 2) may hold spaces and parentheses: split after its end
            fields = stat.read_text().rsplit(")", 1)[1].split()
            children.setdefault(int(fields[1]), []).append(int(stat.parent.name))
    peaks, todo = [], [pid]
    while todo:
        found = todo.pop()
        peak = _peak_mb(str(found))
        if peak is not None:
            peaks.append(peak)
        todo += children.get(found, [])
    return round(sum(peaks), 1) if peaks else None


def _peak_mb(pid: str) -> float | None:
    with contextlib.suppress(OSError):
        for line in (_PROC / pid / "status").read_text().splitlines():
            if line.startswith("VmHWM:"):
                return round(int(line.split()[1]) / 1024, 1)
    return None
