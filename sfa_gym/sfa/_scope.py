"""A process-wide setting held while at least one block of code is inside it."""

from __future__ import annotations

import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager

__all__ = ["CountedScope"]


class CountedScope:
    """``enter()`` runs when the first block opens the scope, ``leave()`` when the last one
    closes it; blocks may nest and run on several threads at once.

    The scope is counted rather than nested because the engine enters it from several threads
    (pool threads fit nodes while the caller holds it), and the thread that leaves last need
    not be the one that entered first.
    """

    def __init__(self, enter: Callable[[], None], leave: Callable[[], None]) -> None:
        self._enter, self._leave = enter, leave
        self._lock = threading.Lock()
        self._depth = 0

    @contextmanager
    def held(self) -> Iterator[None]:
        """Hold the setting inside the block."""
        with self._lock:
            if self._depth == 0:
                self._enter()
            self._depth += 1
        try:
            yield
        finally:
            with self._lock:
                self._depth -= 1
                if self._depth == 0:
                    self._leave()
