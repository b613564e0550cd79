"""Every packaged spec flies the build its variant names say: a variant called ``NAME-paper/...``
sets ``preset = "paper"``, and in a spec that sets builds side by side every variant of a method
with presets names its preset (the default build changes when a better one is measured; a
stored comparison must not change meaning with it). Read from the TOML, so specs whose
optional parts (a local LLM) are not installed are checked too."""

from __future__ import annotations

import tomllib
from importlib import resources

import pytest

from swarmnav.experiments.spec import builtin_names
from swarmnav.methods import registry
from swarmnav.params import default_build


def _variants(name: str) -> list[tuple[str, str, dict]]:
    """(variant name, method, parameters: the spec's [params] under the variant's)."""
    text = resources.files("swarmnav.experiments").joinpath("specs", f"{name}.toml").read_text("utf-8")
    spec = tomllib.loads(text)
    return [(v["name"], v.get("method", spec.get("method")), {**spec.get("params", {}), **v.get("params", {})})
            for v in spec.get("variants", [])]


@pytest.mark.parametrize("name", builtin_names())
def test_a_paper_variant_flies_the_paper_build(name):
    for variant, _, params in _variants(name):
        if variant.split("/")[0].endswith("-paper"):
            assert params.get("preset") == "paper", f"{name}: {variant} flies preset={params.get('preset')}"


@pytest.mark.parametrize("name", builtin_names())
def test_a_spec_with_builds_side_by_side_names_every_build(name):
    variants = _variants(name)
    if not any(v.split("/")[0].endswith("-paper") for v, _, _ in variants):
        pytest.skip("no paper build beside another")
    for variant, method, params in variants:
        if default_build(type(registry.make(method).params)):
            assert "preset" in params, f"{name}: variant {variant} does not name its build"
