"""Where a task's time goes: wall seconds per phase (``render``, ``fit``, ``features``,
``episodes``), each phase counted without the phases inside it, and ``other`` for the rest
(loading, regression, scoring).

The protocols mark their phases with :func:`phase`; a caller that wants the figures wraps the
work in :func:`measure` (the leaderboard does for every task, and stores them in its result).
Outside :func:`measure` a phase costs one context-variable look-up.
"""

from __future__ import annotations

import time
from collections.abc import Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass, field

__all__ = ["PHASES", "Phases", "measure", "phase"]

PHASES = ("render", "fit", "features", "episodes")
"""The phases the protocols mark: reading runs from the render cache (rendering those it does
not hold yet; marked where the protocols read, so that the rendering code, whose hash keys the
cache, stays as it is), fitting the method,
computing its features (rotation averages and feature fields included), the navigation
episodes."""


@dataclass
class Phases:
    """Seconds per phase of one :func:`measure`."""

    seconds: dict[str, float] = field(default_factory=dict)
    _stack: list[list[float]] = field(default_factory=list)  # [start, seconds of inner phases]
    _started: float = field(default_factory=time.perf_counter)

    def as_dict(self) -> dict[str, float]:
        """``{phase: seconds}`` (rounded to 10 ms) with ``other``: the wall time since the
        measurement started that no phase took."""
        total = time.perf_counter() - self._started
        out = {name: round(s, 2) for name, s in self.seconds.items()}
        out["other"] = round(max(total - sum(self.seconds.values()), 0.0), 2)
        return out


_current: ContextVar[Phases | None] = ContextVar("sfa_gym_phases", default=None)


@contextmanager
def measure() -> Iterator[Phases]:
    """Collect the :func:`phase` seconds of the work inside (nested measurements: the inner
    one collects its own)."""
    phases = Phases()
    token = _current.set(phases)
    try:
        yield phases
    finally:
        _current.reset(token)


@contextmanager
def phase(name: str) -> Iterator[None]:
    """Count the wall time inside as ``name`` (one of :data:`PHASES`), less that of the phases
    nested in it."""
    if name not in PHASES:
        raise ValueError(f"phase must be one of {PHASES}, got {name!r}")
    phases = _current.get()
    if phases is None:
        yield
        return
    frame = [time.perf_counter(), 0.0]
    phases._stack.append(frame)
    try:
        yield
    finally:
        phases._stack.pop()
        elapsed = time.perf_counter() - frame[0]
        phases.seconds[name] = phases.seconds.get(name, 0.0) + elapsed - frame[1]
        if phases._stack:
            phases._stack[-1][1] += elapsed
