"""Settings dataclasses from JSON (a world spec, a track's ``params``, a plug-in's ``Args``):
every value checked against its field's type hint, with errors that name the key path, the
value and what was expected."""

from __future__ import annotations

import dataclasses
import os
import pathlib
import types
from collections.abc import Mapping
from pathlib import Path
from typing import Any, Literal, Union, get_args, get_origin, get_type_hints

__all__ = ["dataclass_from_json"]


def dataclass_from_json(
    cls: type, values: Any, where: str = "", *, noun: str = "argument", base: Any = None
) -> Any:
    """``cls(**values)`` after checking every value against its field's type hint.

    Nested dataclasses are built from JSON objects, lists become tuples (of the given length
    for ``tuple[X, Y]``), ints become floats where a float is wanted, a ``Literal`` takes one of
    its values, a union the first of its types the value fits; other hints pass unchanged.

    Args:
        where: what ``values`` come from (a file), starting every message.
        noun: what a key is called in messages ("key", "setting").
        base: an instance whose fields the given values replace (``dataclasses.replace``); an
            object given for a field that holds a dataclass replaces that one's fields.
    Raises:
        ValueError: an unknown key, a value of the wrong type, or a value ``cls`` refuses; the
            message names the key's path (``arena.size[0]``) and the value.
        TypeError: the field types of ``cls`` do not resolve.
    """
    return _dataclass(cls, values, (where, noun), "", base)


def _dataclass(cls: type, values: Any, at: tuple[str, str], path: str, base: Any) -> Any:
    where, noun = at
    if not isinstance(values, Mapping):
        raise ValueError(f"{_label(at, path)} must be an object of {cls.__name__}, got {values!r}")
    names = [f.name for f in dataclasses.fields(cls)]
    unknown = sorted(set(values) - set(names))
    if unknown:
        key = f"{path}.{unknown[0]}" if path else unknown[0]
        raise ValueError(
            f"{where}: " * bool(where)
            + f"unknown {noun} {key!r}; the fields of {cls.__name__} are {names}"
        )
    try:
        hints = get_type_hints(cls)
    except Exception as error:  # an annotation that does not resolve in its module
        raise TypeError(f"{where}: cannot read the types of {cls.__name__}: {error}") from None
    checked = {}
    for key, value in values.items():
        inner = getattr(base, key, None)
        sub = f"{path}.{key}" if path else key
        if dataclasses.is_dataclass(inner) and isinstance(value, Mapping):
            checked[key] = _dataclass(type(inner), value, at, sub, inner)
        else:
            checked[key] = _convert(value, hints.get(key, Any), at, sub)
    try:
        return cls(**checked) if base is None else dataclasses.replace(base, **checked)
    except (TypeError, ValueError) as error:
        given = f"bad {noun}s {checked!r}"
        raise ValueError(": ".join(filter(None, (where, path, given, str(error))))) from None


def _label(at: tuple[str, str], path: str) -> str:
    where, noun = at
    if not path:
        return where or f"the {noun}s"
    return f"{where}: " * bool(where) + f"{noun} {path}"


def _type_name(hint: Any) -> str:
    if isinstance(hint, type):
        return hint.__name__
    return str(hint).replace("typing.", "")


def _convert(value: Any, hint: Any, at: tuple[str, str], path: str) -> Any:
    """``value`` as the type ``hint`` wants it, or a ValueError naming ``path``."""
    origin = get_origin(hint)
    wrong = ValueError(f"{_label(at, path)} must be {_type_name(hint)}, got {value!r}")
    if hint is Any:
        return value
    if dataclasses.is_dataclass(hint):
        return _dataclass(hint, value, at, path, None)  # type: ignore[arg-type]
    if origin is Literal:
        choices = get_args(hint)
        if any(value == c and type(value) is type(c) for c in choices):
            return value
        raise ValueError(f"{_label(at, path)} must be one of {list(choices)}, got {value!r}")
    if origin in (Union, types.UnionType):
        options = [o for o in get_args(hint) if value is None or o is not type(None)]
        if len(options) == 1:  # its own message, e.g. naming a nested key
            return _convert(value, options[0], at, path)
        for option in options:
            try:
                return _convert(value, option, at, path)
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
                raise ValueError(f"{_label(at, path)} must have {len(items)} items, got {value!r}")
            pairs = enumerate(zip(value, items, strict=True))
            return tuple(_convert(v, h, at, f"{path}[{i}]") for i, (v, h) in pairs)
        item = items[0] if items else Any
        out = [_convert(v, item, at, f"{path}[{i}]") for i, v in enumerate(value)]
        return tuple(out) if (origin or hint) is tuple else out
    return value
