"""Methods registered by name; the conformance tests run every registered method."""

from __future__ import annotations

import difflib
from dataclasses import dataclass
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


def _load_builtins() -> None:
    import importlib

    for mod in _BUILTIN_MODULES:
        importlib.import_module(mod)


def names() -> list[str]:
    _load_builtins()
    return sorted(_REGISTRY)


def spec(name: str) -> MethodSpec:
    _load_builtins()
    if name not in _REGISTRY:
        close = difflib.get_close_matches(name, list(_REGISTRY), n=3)
        hint = f" (did you mean {', '.join(close)}?)" if close else ""
        raise ConfigError(f"unknown method '{name}'{hint}; known: {', '.join(sorted(_REGISTRY))}")
    return _REGISTRY[name]


def make(name: str, **params: Any) -> Method:
    """A fresh method instance; unknown parameter names raise ConfigError."""
    return spec(name).factory(**params)
