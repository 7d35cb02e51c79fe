"""The messages between the evaluator and a plug-in's worker process: JSON-type values and numpy
arrays of numbers, nothing else.

A message is an 8-byte big-endian length, a JSON header and the raw bytes of its arrays. The
header holds the value with every array replaced by ``{"__array__": i}`` and, for each array,
its dtype and shape. Decoding never unpickles and never builds an object of a type the message
names: only dicts, lists, strings, numbers, booleans, None and arrays of booleans, integers,
floats or complex numbers, their byte counts checked against dtype and shape. What a plug-in
sends back can therefore not run code in the evaluator.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from typing import Any

import numpy as np

__all__ = ["MAX_HEADER", "WireError", "decode", "encode"]

MAX_HEADER = 64 * 2**20
"""Largest JSON header accepted (bytes): a worker cannot make the evaluator parse gigabytes."""

# numpy dtype kinds an array may have: booleans, integers, floats, complex numbers.
NUMBER_KINDS = "biufc"


class WireError(ValueError):
    """A message that is not a well-formed message of this format."""


def _flatten(value: Any, arrays: list[np.ndarray]) -> Any:
    """``value`` as JSON types, its arrays appended to ``arrays`` and replaced by references."""
    if isinstance(value, np.ndarray):
        if value.dtype.kind not in NUMBER_KINDS:
            raise WireError(f"only arrays of numbers cross the process boundary, got {value.dtype}")
        arrays.append(np.ascontiguousarray(value))
        return {"__array__": len(arrays) - 1}
    if isinstance(value, np.generic):
        return _flatten(np.asarray(value)[()].item(), arrays)
    if value is None or isinstance(value, bool | int | str):
        return value
    if isinstance(value, float):
        # JSON has no NaN or infinity: such floats travel as 0-d arrays, bit for bit
        return value if math.isfinite(value) else _flatten(np.float64(value).reshape(()), arrays)
    if isinstance(value, list | tuple):
        return [_flatten(v, arrays) for v in value]
    if isinstance(value, dict):
        if not all(isinstance(k, str) for k in value):
            raise WireError(f"dict keys must be strings, got {list(value)!r}")
        if "__array__" in value:
            raise WireError("'__array__' is a reserved key")
        return {k: _flatten(v, arrays) for k, v in value.items()}
    raise WireError(
        f"a {type(value).__name__} cannot cross the process boundary: only JSON types and "
        "numpy arrays of numbers"
    )


def encode(value: Any) -> list[bytes | memoryview]:
    """The parts of the message of ``value`` (write them in order)."""
    arrays: list[np.ndarray] = []
    body = _flatten(value, arrays)
    spec = [{"dtype": a.dtype.str, "shape": list(a.shape)} for a in arrays]
    header = json.dumps({"value": body, "arrays": spec}, allow_nan=False).encode()
    parts: list[bytes | memoryview] = [len(header).to_bytes(8, "big"), header]
    parts.extend(memoryview(a.reshape(-1).view(np.uint8)) for a in arrays if a.size)
    return parts


def decode(read_exactly: Callable[[int], bytearray]) -> Any:
    """The value of the next message, reading with ``read_exactly(n) -> n bytes``.

    Raises:
        WireError: a header too long or not JSON, an array reference out of range, a dtype that
            is not a number type, a negative or non-integer shape.
    """
    length = int.from_bytes(read_exactly(8), "big")
    if length > MAX_HEADER:
        raise WireError(f"a message header of {length} bytes (at most {MAX_HEADER})")
    try:
        header = json.loads(bytes(read_exactly(length)))
        specs, body = header["arrays"], header["value"]
        arrays = [_read_array(spec, read_exactly) for spec in specs]
    except (ValueError, KeyError, TypeError) as error:
        if isinstance(error, WireError):
            raise
        raise WireError(f"a malformed message: {type(error).__name__}: {error}") from error
    return _unflatten(body, arrays)


def _read_array(spec: Any, read_exactly: Callable[[int], bytearray]) -> np.ndarray:
    dtype = np.dtype(str(spec["dtype"]))
    shape = spec["shape"]
    if dtype.kind not in NUMBER_KINDS or dtype.fields is not None:
        raise WireError(f"an array of dtype {dtype} (only numbers)")
    if not isinstance(shape, list) or not all(
        isinstance(n, int) and not isinstance(n, bool) and n >= 0 for n in shape
    ):
        raise WireError(f"an array shape {shape!r} (a list of non-negative ints)")
    n_bytes = math.prod(shape) * dtype.itemsize
    data = read_exactly(n_bytes) if n_bytes else bytearray()
    return np.frombuffer(data, dtype=dtype).reshape(shape)


def _unflatten(value: Any, arrays: list[np.ndarray]) -> Any:
    if isinstance(value, list):
        return [_unflatten(v, arrays) for v in value]
    if isinstance(value, dict):
        if set(value) == {"__array__"}:
            index = value["__array__"]
            if not isinstance(index, int) or not 0 <= index < len(arrays):
                raise WireError(f"an array reference {index!r} out of range")
            array = arrays[index]
            return array[()].item() if array.ndim == 0 else array
        return {k: _unflatten(v, arrays) for k, v in value.items()}
    return value
