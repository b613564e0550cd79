"""Parameter records: typed, immutable, and strict about unknown keys.

Methods and experiments keep their parameters in frozen dataclasses. :func:`build` turns a
mapping of overrides (from Python, ``--set key=value`` strings or experiment specs) into such
a record, coercing strings to the field's type and rejecting unknown keys by name.
"""

from __future__ import annotations

import dataclasses
import math
import typing
from typing import Any, Mapping, TypeVar

from swarmnav.errors import ConfigError

T = TypeVar("T")


def build(cls: type[T], overrides: Mapping[str, Any] | None = None, *, context: str = "") -> T:
    """Instantiate parameter record ``cls`` with ``overrides`` applied.

    Raises:
        ConfigError: on an unknown key (naming it and the known keys) or a bad value.
    """
    base = cls()
    if not overrides:
        return base
    fields = {f.name: f for f in dataclasses.fields(cls) if f.init}
    hints = typing.get_type_hints(cls)
    where = f"{context}: " if context else ""
    changes = {}
    for key, value in overrides.items():
        if key not in fields:
            close = [k for k in fields if k.startswith(key[:3])]
            hint = f" (did you mean {', '.join(sorted(close))}?)" if close else ""
            raise ConfigError(f"{where}unknown parameter '{key}'{hint}; known: {', '.join(sorted(fields))}")
        changes[key] = coerce(value, hints[key], f"{where}{key}")
    return dataclasses.replace(base, **changes)


def coerce(value: Any, typ: Any, name: str) -> Any:
    """Convert ``value`` (possibly a string from the command line) to type ``typ``."""
    origin = typing.get_origin(typ)
    args = typing.get_args(typ)
    if origin in (typing.Union, getattr(__import__("types"), "UnionType", None)):
        if value is None or (isinstance(value, str) and value.lower() in ("none", "null")):
            if type(None) in args:
                return None
        errors = []
        for a in args:
            if a is type(None):
                continue
            try:
                return coerce(value, a, name)
            except ConfigError as e:
                errors.append(str(e))
        raise ConfigError(errors[0] if errors else f"{name}: invalid value {value!r}")
    if typ is bool:
        if isinstance(value, bool):
            return value
        if isinstance(value, str) and value.lower() in ("true", "1", "yes", "on", "false", "0", "no", "off"):
            return value.lower() in ("true", "1", "yes", "on")
        raise ConfigError(f"{name}: expected true/false, got {value!r}")
    if typ is int:
        if isinstance(value, bool):
            raise ConfigError(f"{name}: expected an integer, got {value!r}")
        try:
            f = float(value)
        except (TypeError, ValueError):
            raise ConfigError(f"{name}: expected an integer, got {value!r}") from None
        if not f.is_integer():
            raise ConfigError(f"{name}: expected an integer, got {value!r}")
        return int(f)
    if typ is float:
        if isinstance(value, bool):
            raise ConfigError(f"{name}: expected a number, got {value!r}")
        try:
            f = float(value)
        except (TypeError, ValueError):
            raise ConfigError(f"{name}: expected a number, got {value!r}") from None
        if math.isnan(f):
            raise ConfigError(f"{name}: expected a number, got NaN")
        return f
    if typ is str:
        return str(value)
    if origin is typing.Literal:
        if value not in args:
            raise ConfigError(f"{name}: expected one of {', '.join(map(str, args))}, got {value!r}")
        return value
    if origin is tuple and isinstance(value, (list, tuple)):
        return tuple(coerce(v, args[0], name) for v in value)
    return value


def as_dict(record: Any) -> dict[str, Any]:
    """Parameter record to a plain JSON-able dict."""
    return {f.name: getattr(record, f.name) for f in dataclasses.fields(record) if f.init}
