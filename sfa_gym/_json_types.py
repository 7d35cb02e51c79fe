"""JSON-type values (what a command line's ``NAME=VALUE`` or a result file gives) checked
against a dataclass's field types, with errors that name the field, the value and the type."""

from __future__ import annotations

import dataclasses
import os
import pathlib
import types
from collections.abc import Mapping
from pathlib import Path
from typing import Any, Literal, Union, get_args, get_origin, get_type_hints

__all__ = ["dataclass_from_json", "from_json"]


def dataclass_from_json(cls: type, values: Mapping[str, Any], where: str) -> Any:
    """``cls(**values)`` after checking every value against its field's type (see
    :func:`from_json`); ``where`` (e.g. the file that defines ``cls``) starts every message.

    Raises:
        ValueError: a key that is not a field of ``cls``, a value of the wrong type, or a value
            ``cls`` refuses; the message names the field and the value.
        TypeError: the field types of ``cls`` do not resolve.
    """
    names = [f.name for f in dataclasses.fields(cls)]
    unknown = sorted(set(values) - set(names))
    if unknown:
        raise ValueError(
            f"{where}: unknown argument {unknown[0]!r}; the fields of {cls.__name__} are {names}"
        )
    try:
        hints = get_type_hints(cls)
    except Exception as error:  # an annotation that does not resolve in its module
        raise TypeError(f"{where}: cannot read the types of {cls.__name__}: {error}") from None
    checked = {
        k: from_json(f"{where}: argument {k}", v, hints.get(k, Any)) for k, v in values.items()
    }
    try:
        return cls(**checked)
    except (TypeError, ValueError) as error:
        raise ValueError(f"{where}: bad arguments {checked!r}: {error}") from None


def _type_name(hint: Any) -> str:
    if isinstance(hint, type):
        return hint.__name__
    return str(hint).replace("typing.", "")


def from_json(where: str, value: Any, hint: Any) -> Any:
    """``value`` as the type ``hint`` wants it (int -> float, list -> tuple), or a ValueError
    naming ``where``, the value and the type. Types not listed here pass unchanged:
    ``Args`` itself checks them, if it does."""
    origin = get_origin(hint)
    wrong = ValueError(f"{where} must be {_type_name(hint)}, got {value!r}")
    if hint is Any:
        return value
    if origin is Literal:
        choices = get_args(hint)
        if any(value == c and type(value) is type(c) for c in choices):
            return value
        raise ValueError(f"{where} must be one of {list(choices)}, got {value!r}")
    if origin in (Union, types.UnionType):
        for option in get_args(hint):
            try:
                return from_json(where, value, option)
            except ValueError:
                continue
        raise wrong
    if hint is type(None):
        if value is None:
            return None
        raise wrong
    if hint is bool or hint is str:
        if isinstance(value, hint):
            return value
        raise wrong
    if hint is int:
        if isinstance(value, int) and not isinstance(value, bool):
            return value
        raise wrong
    if hint is float:
        if isinstance(value, int | float) and not isinstance(value, bool):
            return float(value)
        raise wrong
    if hint is pathlib.Path:
        if isinstance(value, str | os.PathLike):
            return Path(value)
        raise wrong
    if origin in (tuple, list) or hint in (tuple, list):
        if not isinstance(value, list | tuple):
            raise wrong
        items = get_args(hint)
        if origin is tuple and items and items[-1] is not Ellipsis:
            if len(value) != len(items):
                raise ValueError(f"{where} must have {len(items)} items, got {value!r}")
            pairs = enumerate(zip(value, items, strict=True))
            return tuple(from_json(f"{where}[{i}]", v, h) for i, (v, h) in pairs)
        item = items[0] if items else Any
        out = [from_json(f"{where}[{i}]", v, item) for i, v in enumerate(value)]
        return tuple(out) if (origin or hint) is tuple else out
    return value
