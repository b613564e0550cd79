"""Methods registered by name; the conformance tests run every registered method.

Three ways in, one registry (docs/plugins.md):

- the built-in families, registered when their modules are imported (:data:`_BUILTIN_MODULES`);
- plugins: an installed package that declares an entry point in the group ``swarmnav.methods``
  (``name = "package.module:Factory"``) is registered with the built-ins, under the entry point's name;
- a factory that is not installed, named ``module:Factory`` or ``path/to/file.py:Factory`` wherever
  a method name is taken (``run --method``, a spec's ``method``, ``--set method=``).

A plugin's or a named factory's object is a Method factory (usually the class) that carries its
parameter record class as ``Params`` (frozen dataclass of :func:`swarmnav.params.param` fields), and
may carry ``description`` (default: its docstring's first line) and ``navigation`` (default True).
A plugin that fails (its import raises, its name is a built-in's, its object is not such a factory)
is left out with one line saying why (:func:`plugin_errors`; ``swarmnav methods`` prints them), and
every other method works as before.
"""

from __future__ import annotations

import difflib
import importlib
import importlib.util
import sys
from dataclasses import dataclass, is_dataclass
from importlib.metadata import entry_points
from pathlib import Path
from typing import Any, Callable

from swarmnav.errors import ConfigError
from swarmnav.methods.base import Method


@dataclass(frozen=True, slots=True)
class MethodSpec:
    name: str
    factory: Callable[..., Method]
    description: str
    params: type  # the parameter record class (swarmnav.params: declared units, ranges, sources)
    navigation: bool = True  # a goal-seeking method (runs on the navigation scenes)

    @property
    def networked(self) -> bool:
        """The method reads the other agents only through the network (its class's ``networked``;
        a factory that is a ``functools.partial`` of the class answers for it)."""
        f = self.factory
        return bool(getattr(f, "networked", False) or getattr(getattr(f, "func", None), "networked", False))


_REGISTRY: dict[str, MethodSpec] = {}


def register(name: str, factory: Callable[..., Method], description: str, *, params: type,
             navigation: bool = True) -> None:
    """Register ``factory(**overrides) -> Method`` under ``name``; ``params`` is the record class
    the factory builds its parameters from (``swarmnav methods NAME`` lists it)."""
    if name in _REGISTRY:
        raise ValueError(f"method {name!r} registered twice")
    _REGISTRY[name] = MethodSpec(name, factory, description, params, navigation)


#: Modules whose import registers the built-in methods (one line per method family).
_BUILTIN_MODULES = (
    "swarmnav.methods.sph",
    "swarmnav.methods.apf",
    "swarmnav.methods.hes",
    "swarmnav.methods.vicsek",
    "swarmnav.methods.ego_swarm",
    "swarmnav.methods.mader",
    "swarmnav.methods.flocking",
    "swarmnav.methods.lsc",
    "swarmnav.methods.nmpc",
)


#: The entry-point group in which a package declares its methods.
ENTRY_POINT_GROUP = "swarmnav.methods"

_PLUGINS: dict[str, str] = {}  # entry-point name -> "" (registered) or the one line saying why not
_plugins_loaded = False


def _load_builtins() -> None:
    global _plugins_loaded
    for mod in _BUILTIN_MODULES:
        importlib.import_module(mod)
    if not _plugins_loaded:  # after the built-ins, so a plugin cannot take a built-in's name
        _plugins_loaded = True
        _load_plugins()


def _load_plugins() -> None:
    builtin = set(_REGISTRY)
    for ep in sorted(entry_points(group=ENTRY_POINT_GROUP), key=lambda e: e.name):
        dist = getattr(getattr(ep, "dist", None), "name", None)
        who = f"plugin '{ep.name}' ({ep.value}{f', package {dist}' if dist else ''})"
        if ep.name in builtin:
            _PLUGINS[ep.name] = f"{who} is not registered: '{ep.name}' is a built-in method's name"
            continue
        if ep.name in _PLUGINS:
            _PLUGINS[ep.name] = f"{who} is not registered: two plugins declare the name '{ep.name}'"
            _REGISTRY.pop(ep.name, None)
            continue
        try:
            factory = ep.load()
            _REGISTRY[ep.name] = spec_of(ep.name, factory)
        except Exception as e:  # noqa: BLE001 - a plugin's failure is reported, never raised into the built-ins
            _PLUGINS[ep.name] = f"{who} failed to load: {type(e).__name__}: {_one_line(e)}"
        else:
            _PLUGINS[ep.name] = ""


def _one_line(e: BaseException) -> str:
    return " ".join(str(e).split()) or "(no message)"


def plugin_errors() -> list[str]:
    """One line per plugin that is not registered, saying which and why."""
    _load_builtins()
    return [why for why in _PLUGINS.values() if why]


def plugins() -> list[str]:
    """The names of the registered plugins."""
    _load_builtins()
    return sorted(name for name, why in _PLUGINS.items() if not why)


def spec_of(name: str, factory: Any) -> MethodSpec:
    """The registry's record of a plugin's or a named factory's ``factory`` (module docstring);
    TypeError saying what is missing."""
    if isinstance(factory, MethodSpec):
        return MethodSpec(name, factory.factory, factory.description, factory.params, factory.navigation)
    if not callable(factory):
        raise TypeError(f"{factory!r} is not a method factory (a class or function that returns a method)")
    params = getattr(factory, "Params", None)
    if not (isinstance(params, type) and is_dataclass(params)):
        raise TypeError(f"{getattr(factory, '__name__', factory)!r} has no Params: its parameter record class "
                        "(a frozen dataclass of swarmnav.params.param fields), which swarmnav methods NAME lists")
    doc = (getattr(factory, "__doc__", None) or "").strip().splitlines()
    description = str(getattr(factory, "description", None) or (doc[0] if doc else name))
    return MethodSpec(name, factory, description, params, bool(getattr(factory, "navigation", True)))


def _named_factory(name: str) -> MethodSpec:
    """Register ``module:Factory`` or ``file.py:Factory`` under that name (ConfigError: one line)."""
    where, _, attr = name.rpartition(":")
    try:
        if where.endswith(".py"):
            path = Path(where).expanduser().resolve()
            if not path.is_file():
                raise ConfigError(f"method '{name}': no file {where}")
            key = f"swarmnav_user_method_{abs(hash(str(path)))}"
            module = sys.modules.get(key)
            if module is None:
                loader = importlib.util.spec_from_file_location(key, path)
                module = importlib.util.module_from_spec(loader)
                sys.modules[key] = module
                try:
                    loader.loader.exec_module(module)
                except BaseException:
                    del sys.modules[key]
                    raise
        else:
            module = importlib.import_module(where)
        factory = getattr(module, attr)
        made = spec_of(name, factory)
    except ConfigError:
        raise
    except Exception as e:  # noqa: BLE001 - the user's code: one line, never a traceback
        raise ConfigError(f"method '{name}' cannot be loaded: {type(e).__name__}: {_one_line(e)}") from None
    _REGISTRY[name] = made
    return made


def names() -> list[str]:
    """The built-in methods and the registered plugins (a ``module:Factory`` named earlier in this
    process is not listed)."""
    _load_builtins()
    return sorted(n for n in _REGISTRY if ":" not in n)


def spec(name: str) -> MethodSpec:
    _load_builtins()
    if name not in _REGISTRY:
        if ":" in name:
            return _named_factory(name)
        if _PLUGINS.get(name):
            raise ConfigError(_PLUGINS[name])
        known = names()
        close = difflib.get_close_matches(name, known, n=3)
        hint = f" (did you mean {', '.join(close)}?)" if close else ""
        raise ConfigError(f"unknown method '{name}'{hint}; known: {', '.join(known)}")
    return _REGISTRY[name]


def make(name: str, **params: Any) -> Method:
    """A fresh method instance; unknown parameter names raise ConfigError."""
    return spec(name).factory(**params)
