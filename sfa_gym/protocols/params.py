"""A protocol's ``Config`` from plain values (a track file's ``params``): the defaults with the
given fields replaced, JSON lists as tuples and objects as the nested settings, then checked by
the ``Config``'s own ``validate()``."""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from typing import Any, TypeVar

__all__ = ["config_from_params"]

T = TypeVar("T")


def config_from_params(default: T, params: Mapping[str, Any], where: str = "") -> T:
    """``dataclasses.replace(default, **params)``, validated.

    A JSON list becomes a tuple; an object given for a field whose default is a dataclass (the
    navigation protocol's ``gradient``) replaces that dataclass's fields the same way.

    Raises:
        ValueError: a name that is not a field of ``default`` (the message lists the fields), or
            a bad value (from ``validate()``, naming it).
        TypeError: a value of the wrong type, named by ``validate()``.
    """
    if not isinstance(params, Mapping):
        raise ValueError(f"{where or 'params'} must be an object, got {params!r}")
    names = [f.name for f in dataclasses.fields(default)]  # type: ignore[arg-type]
    unknown = sorted(set(params) - set(names))
    if unknown:
        raise ValueError(
            f"unknown setting '{where}{unknown[0]}'; the settings of "
            f"{type(default).__name__} are {names}"
        )
    values = {}
    for name, value in params.items():
        current = getattr(default, name)
        if dataclasses.is_dataclass(current) and isinstance(value, Mapping):
            value = config_from_params(current, value, f"{where}{name}.")
        elif isinstance(value, list):
            value = tuple(value)
        values[name] = value
    config = dataclasses.replace(default, **values)  # type: ignore[type-var]
    config.validate()  # type: ignore[attr-defined]
    return config
