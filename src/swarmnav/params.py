"""Parameter records: typed, immutable, declared with unit, valid range and source.

Methods keep their parameters in frozen dataclasses whose fields are declared with
:func:`param`: the default, its unit, the interval of valid values, where the value comes
from (a paper's table or equation, or ``ours``) and a one-line meaning. :func:`build` is the
one place that turns overrides (from Python, ``--set key=value`` strings or experiment specs)
into such a record: it coerces strings to the field's type, rejects unknown keys by name,
non-finite numbers and values outside the declared range, and applies named presets
(``preset=NAME``). :func:`describe` lists a record's parameters for ``swarmnav methods NAME``.
"""

from __future__ import annotations

import dataclasses
import difflib
import math
import re
import typing
from typing import Any, Mapping, TypeVar

from swarmnav.errors import ConfigError

T = TypeVar("T")

_INTERVAL = re.compile(r"^\s*([\[(])\s*([^,\s]+)\s*,\s*([^\])\s]+)\s*([\])])\s*$")


@dataclasses.dataclass(frozen=True, slots=True)
class Range:
    """An interval of valid values, written as in mathematics: ``"(0, inf)"``, ``"[0, 1]"``."""

    lo: float
    hi: float
    lo_closed: bool
    hi_closed: bool

    @classmethod
    def parse(cls, text: str) -> Range:
        m = _INTERVAL.match(text)
        if not m:
            raise ValueError(f"not an interval: {text!r} (write e.g. '(0, inf)' or '[1, 8]')")
        lo, hi = _number(m.group(2)), _number(m.group(3))
        if not lo <= hi or math.isnan(lo) or math.isnan(hi):
            raise ValueError(f"empty interval: {text!r}")
        return cls(lo, hi, m.group(1) == "[" and math.isfinite(lo), m.group(4) == "]" and math.isfinite(hi))

    def __contains__(self, x: float) -> bool:
        above = x >= self.lo if self.lo_closed else x > self.lo
        below = x <= self.hi if self.hi_closed else x < self.hi
        return bool(above and below)

    def __str__(self) -> str:
        def num(v: float) -> str:
            if math.isinf(v):
                return "-inf" if v < 0 else "inf"
            k = round(v / math.pi)
            if k and k * math.pi == v:  # a multiple of pi, as declared ("2pi" parses to 2 * math.pi)
                return {1: "pi", -1: "-pi"}.get(k, f"{k}pi")
            return f"{v:g}" if float(f"{v:g}") == v else repr(v)

        return f"{'[' if self.lo_closed else '('}{num(self.lo)}, {num(self.hi)}{']' if self.hi_closed else ')'}"


def _number(text: str) -> float:
    """A bound: a number, inf, or a multiple of pi ("pi", "2pi", "-pi")."""
    if text.endswith("pi"):
        k = text[:-2]
        return (float(k) if k not in ("", "-") else (-1.0 if k == "-" else 1.0)) * math.pi
    return float(text)


def param(default: Any, unit: str = "", range: str | None = None, source: str = "ours", doc: str = "", *,
          results: bool = True) -> Any:
    """Declare a parameter field: ``dt: float = param(0.1, "s", "(0, 1]", "Sec. 5.1", "step")``.

    Args:
        default: the default value.
        unit: SI unit ("m", "m/s^2", "deg", ...); "" for dimensionless, switches and names.
        range: interval of valid values of a number (see :class:`Range`); numbers must also be
            finite. None for switches, choices and text.
        source: where the default comes from: the paper's table / equation / section, or "ours".
        doc: what the parameter does, in one line.
        results: False for a parameter of how a run is computed, not of what it computes (a
            thread count): runs differing only in it are identical, so :func:`identity` leaves
            it out of a run's key.
    """
    meta = {"unit": unit, "range": None if range is None else Range.parse(range), "source": source, "doc": doc,
            "results": results}
    return dataclasses.field(default=default, metadata=meta)


@dataclasses.dataclass(frozen=True, slots=True)
class ParamInfo:
    """One parameter of a record, as :func:`describe` lists it."""

    name: str
    kind: str  # "float", "int", "bool", "text" or "choice"
    default: Any
    unit: str
    range: Range | None
    choices: tuple[Any, ...]
    source: str
    doc: str

    @property
    def valid(self) -> str:
        """The valid values in words: an interval, the choices, or true/false."""
        if self.kind == "bool":
            return "true | false"
        if self.kind == "choice":
            return " | ".join(map(str, self.choices))
        if self.range is not None:
            return str(self.range) + (" (integer)" if self.kind == "int" else "")
        return "text" if self.kind == "text" else "finite"


def describe(cls: type) -> list[ParamInfo]:
    """Every parameter of record class ``cls``, in declaration order; the fields of a nested record
    are listed under dotted names (``passage.margin``)."""
    out = []
    for name, f, typ in _leaves(cls):
        choices: tuple[Any, ...] = ()
        if typ is bool:
            kind = "bool"
        elif typ is int:
            kind = "int"
        elif typ is float:
            kind = "float"
        elif typing.get_origin(typ) is typing.Literal:
            kind, choices = "choice", typing.get_args(typ)
        else:
            kind = "text"
        md = f.metadata
        out.append(ParamInfo(name, kind, f.default, md.get("unit", ""), md.get("range"), choices,
                             md.get("source", ""), md.get("doc", "")))
    return out


def _leaves(cls: type, prefix: str = "") -> list[tuple[str, dataclasses.Field, Any]]:
    """(dotted name, field, type) of every parameter of ``cls``, nested records flattened."""
    hints = typing.get_type_hints(cls)
    out = []
    for f in dataclasses.fields(cls):
        if not f.init:
            continue
        typ = hints[f.name]
        if dataclasses.is_dataclass(typ):
            out.extend(_leaves(typ, f"{prefix}{f.name}."))
        else:
            out.append((prefix + f.name, f, typ))
    return out


def aliases(cls: type) -> dict[str, str]:
    """Old (flat) parameter names of record class ``cls`` -> their current (dotted) names."""
    return dict(getattr(cls, "ALIASES", {}))


def presets(cls: type) -> dict[str, dict[str, Any]]:
    """Named presets of record class ``cls`` (``preset=NAME`` in :func:`build`): name -> overrides."""
    return dict(getattr(cls, "PRESETS", {}))


def preset_aliases(cls: type) -> dict[str, str]:
    """Older preset names of record class ``cls`` -> the preset they now name (``faithful`` ->
    ``paper``): accepted by :func:`build`, so old specs and stored runs still resolve."""
    return dict(getattr(cls, "PRESET_ALIASES", {}))


def default_build(cls: type) -> str | None:
    """The preset of record class ``cls`` that its defaults are (``DEFAULT_BUILD``), or None."""
    return getattr(cls, "DEFAULT_BUILD", None)


def preset_doc(cls: type, name: str) -> str:
    """One line on what preset ``name`` of record class ``cls`` is (``PRESET_DOCS``), or ""."""
    return getattr(cls, "PRESET_DOCS", {}).get(name, "")


def differences(cls: type, preset: str) -> list[tuple[str, Any, Any]]:
    """``(parameter, default value, value in the preset)`` of every parameter in which preset
    ``preset`` of record class ``cls`` differs from the default build, in declaration order: what
    the preset resolves to, not what it lists (a listed value equal to the default is no difference)."""
    base, other = as_dict(cls()), as_dict(build(cls, {"preset": preset}))
    return [(k, base[k], other[k]) for k in base if other[k] != base[k]]


def build(cls: type[T], overrides: Mapping[str, Any] | None = None, *, context: str = "") -> T:
    """Instantiate parameter record ``cls`` with ``overrides`` applied.

    ``preset=NAME`` (one of the record's ``PRESETS``, or an older name of one in
    ``PRESET_ALIASES``) applies that preset's values first; the other overrides then apply on top of it.

    Raises:
        ConfigError: on an unknown key (naming it and the known keys), a value of the wrong
            type, a non-finite number, or a number outside the parameter's declared range.
    """
    base = cls()
    if not overrides:
        return base
    where = f"{context}: " if context else ""
    alias = aliases(cls)
    overrides = {alias.get(k, k): v for k, v in flatten(overrides).items()}
    if "preset" in overrides:
        name = str(overrides.pop("preset"))
        table = presets(cls)
        name = preset_aliases(cls).get(name, name)
        if name not in table:
            known = ", ".join(sorted(table)) or "none"
            raise ConfigError(f"{where}unknown preset '{name}'{_did_you_mean(name, table)}; known: {known}")
        overrides = {**{alias.get(k, k): v for k, v in table[name].items()}, **overrides}
    fields = {name: (f, typ) for name, f, typ in _leaves(cls)}
    changes = {}
    for key, value in overrides.items():
        if key not in fields:
            raise ConfigError(f"{where}unknown parameter '{key}'{_did_you_mean(key, [*fields, *alias])}; "
                              f"known: {', '.join(sorted(fields))}")
        f, typ = fields[key]
        changes[key] = value = coerce(value, typ, f"{where}{key}")
        _check_range(key, f, value, where)
    return _replace(base, changes)


def flatten(values: Mapping[str, Any], prefix: str = "") -> dict[str, Any]:
    """Nested mappings to dotted keys: ``{"passage": {"on": False}}`` -> ``{"passage.on": False}``
    (a TOML table ``[params.passage]`` or the dotted TOML key ``passage.on = false`` reads as the former)."""
    out: dict[str, Any] = {}
    for key, value in values.items():
        if isinstance(value, Mapping):
            out.update(flatten(value, f"{prefix}{key}."))
        else:
            out[f"{prefix}{key}"] = value
    return out


def _replace(record: Any, changes: Mapping[str, Any]) -> Any:
    """``record`` with dotted-name ``changes`` applied (nested records replaced, not mutated)."""
    own: dict[str, Any] = {}
    nested: dict[str, dict[str, Any]] = {}
    for key, value in changes.items():
        head, dot, rest = key.partition(".")
        if dot:
            nested.setdefault(head, {})[rest] = value
        else:
            own[key] = value
    for head, sub in nested.items():
        own[head] = _replace(getattr(record, head), sub)
    return dataclasses.replace(record, **own) if own else record


def _did_you_mean(key: str, known) -> str:
    close = difflib.get_close_matches(key, list(known), n=3, cutoff=0.6)
    close += [k for k in known if k.startswith(key[:3]) and k not in close and len(key) >= 3][: 3 - len(close)]
    return f" (did you mean {', '.join(close)}?)" if close else ""


def _check_range(name: str, f: dataclasses.Field, value: Any, where: str) -> None:
    rng = f.metadata.get("range")
    if rng is None or value is None or isinstance(value, bool):
        return
    if value not in rng:
        unit = f.metadata.get("unit", "")
        raise ConfigError(f"{where}{name} must be in {rng}{' ' + unit if unit else ''}, got {value!r}")


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
        if not math.isfinite(f):
            raise ConfigError(f"{name}: expected a finite number, got {value!r}")
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
    """Parameter record to a plain JSON-able dict; nested records under dotted names, so that
    ``build(type(record), as_dict(record)) == record``."""
    out: dict[str, Any] = {}
    for f in dataclasses.fields(record):
        if not f.init:
            continue
        value = getattr(record, f.name)
        if dataclasses.is_dataclass(value):
            out.update({f"{f.name}.{k}": v for k, v in as_dict(value).items()})
        else:
            out[f.name] = value
    return out


def identity(record: Any) -> dict[str, Any]:
    """:func:`as_dict` without the parameters declared ``results=False`` (:func:`param`): the
    parameters a run's results depend on, which identify it (the experiment store's run key)."""
    skip = {name for name, f, _ in _leaves(type(record)) if not f.metadata.get("results", True)}
    return {k: v for k, v in as_dict(record).items() if k not in skip}
