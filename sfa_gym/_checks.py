"""Checks of scalar settings shared across the package; each error names the setting.

Bools are never numbers here (``True`` is an ``int`` to Python, never a sensible setting).
"""

from __future__ import annotations

import math
import os
from typing import Any

import numpy as np

__all__ = [
    "FEATURE_BOUND",
    "check_finite",
    "check_fits_in_memory",
    "check_int",
    "check_int_in",
    "check_positive",
    "check_positive_int",
    "check_world_seed",
    "is_int",
    "is_number",
    "machine_memory_bytes",
]


FEATURE_BOUND = 1e12
"""The largest magnitude a feature may have: far above any real feature, far below where sums of
squares over a field overflow or lose every digit."""


def is_number(value: Any) -> bool:
    """Whether ``value`` is a real number (bools are not)."""
    return isinstance(value, int | float | np.number) and not isinstance(value, bool)


def is_int(value: Any) -> bool:
    """Whether ``value`` is an int (Python's or numpy's; bools are not)."""
    return isinstance(value, int | np.integer) and not isinstance(value, bool)


def check_int(name: str, value: Any) -> int:
    """``value`` as an int; TypeError naming ``name`` if it is not one (bools are not)."""
    if not is_int(value):
        raise TypeError(f"{name} must be an int, got {value!r}")
    return int(value)


def check_world_seed(name: str, value: Any) -> int:
    """``value`` as a world seed: an int ``>= 0`` (the seed of the world's
    ``np.random.default_rng``); TypeError or ValueError naming ``name`` otherwise. The one rule
    of world seeds: the world builder and the protocols' settings both check it."""
    seed = check_int(name, value)
    if seed < 0:
        raise ValueError(f"{name} must be >= 0, got {seed}")
    return seed


def check_positive_int(name: str, value: Any, *, none: bool = False) -> int | None:
    """``value`` as an int after checking that it is one and ``>= 1`` (``None`` passes when
    ``none``); ValueError naming ``name`` otherwise."""
    if value is None and none:
        return None
    if not is_int(value) or value < 1:
        expected = "a positive int or None" if none else "a positive int"
        raise ValueError(f"{name} must be {expected}, got {value!r}")
    return int(value)


def check_int_in(name: str, value: Any, low: int, high: int | None = None) -> int:
    """``value`` as an int after checking that it is one in ``[low, high]`` (no upper bound
    for None); ValueError naming ``name`` and the range otherwise."""
    if not is_int(value) or value < low or (high is not None and value > high):
        bound = f">= {low}" if high is None else f"in [{low}, {high}]"
        raise ValueError(f"{name} must be an int {bound}, got {value!r}")
    return int(value)


def check_finite(name: str, value: Any, *, low: float = -math.inf) -> float:
    """``value`` as a float after checking that it is a finite number ``>= low``."""
    if not (is_number(value) and math.isfinite(value) and value >= low):
        bound = "a finite number" if low == -math.inf else f"a finite number >= {low:g}"
        raise ValueError(f"{name} must be {bound}, got {value!r}")
    return float(value)


def check_positive(name: str, value: Any) -> float:
    """``value`` as a float after checking that it is a finite number ``> 0``."""
    if not (is_number(value) and value > 0 and math.isfinite(value)):
        raise ValueError(f"{name} must be a positive number, got {value!r}")
    return float(value)


def machine_memory_bytes() -> int:
    """This machine's physical memory, bytes."""
    return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")


def check_fits_in_memory(what: str, n_bytes: float) -> None:
    """ValueError naming ``what`` (the setting and its size) if holding ``n_bytes`` would take
    more than this machine's physical memory: refused before anything is allocated."""
    available = machine_memory_bytes()
    if n_bytes > available:
        raise ValueError(
            f"{what} would need {n_bytes / 2**30:.3g} GiB of memory; this machine has "
            f"{available / 2**30:.3g} GiB"
        )
