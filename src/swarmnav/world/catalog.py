"""Any scene by name: a built-in scene, a generator spec or a scene file.

The one place that knows every source of scenes, so the scenario model (``scenario``) and
the generators (which build scenarios) need not import each other.
"""

from __future__ import annotations

from dataclasses import replace
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from swarmnav.errors import ScenarioError
from swarmnav.world import generators
from swarmnav.world.scenario import Scenario, builtin_names, load_file, loads


def load_scenario(name_or_path: str | Path, **overrides: Any) -> Scenario:
    """Load a scene by built-in name, generator spec or file path.

    Args:
        name_or_path: a built-in scene name (``swarmnav scenarios``), a generator spec
            ``GEN:key=value,...`` (``random_forest:density=0.25,seed=3``,
            ``periodic_box:n=100,rho=4.102``), or a path to a ``.toml`` scene file.
        **overrides: ``n=`` resizes the swarm.
    """
    s = str(name_or_path)
    if isinstance(name_or_path, Path) or s.endswith(".toml") or "/" in s:
        scn = load_file(s)
    elif ":" in s or s in generators.GENERATORS:
        scn = generators.from_spec(s, n=overrides.get("n"))
        scn = replace(scn, name=_label(scn.name, s, overrides.get("n")))
    elif s in builtin_names():
        text = resources.files("swarmnav.world").joinpath("scenes", f"{s}.toml").read_text("utf-8")
        scn = loads(text, source=f"{s}.toml")
    else:
        import difflib

        close = difflib.get_close_matches(s, builtin_names() + list(generators.GENERATORS), n=3)
        hint = f" (did you mean {', '.join(close)}?)" if close else ""
        raise ScenarioError(
            f"{s}: unknown scene{hint} (built-in: {', '.join(builtin_names())}; "
            f"generators: {', '.join(generators.GENERATORS)}; or a path to a .toml file)"
        )
    unknown = set(overrides) - {"n"}
    if unknown:
        raise ScenarioError(f"{s}: unknown scene override(s) {sorted(unknown)}")
    if "n" in overrides and overrides["n"] is not None:
        n = overrides["n"]
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
            raise ScenarioError(f"{s}: n must be an integer >= 1, got {n!r}")
        scn = scn.with_n(int(n))
    return scn


def _label(name: str, spec: str, n: Any) -> str:
    """The generated scene's name with every option of ``spec`` it leaves out appended, so the
    label rebuilds the same scene (``random_forest:density=0.45,seed=1,length=12,...``).

    The generator's own name comes first (it spells the options that define the family, e.g.
    density and seed, defaults included); then the spec's other options as written; then the
    swarm size when ``n`` overrides it."""
    head, _, rest = name.partition(":")
    have = {item.partition("=")[0].strip() for item in rest.split(",") if item.strip()}
    extra = []
    for item in (x.strip() for x in spec.partition(":")[2].split(",")):
        key, _, val = item.partition("=")
        key = key.strip()
        if key and key not in have and not (key == "n" and n is not None):
            extra.append(f"{key}={val.strip()}")
            have.add(key)
    if n is not None and "n" not in have:
        extra.append(f"n={int(n)}")
    return ",".join([name, *extra]) if rest or not extra else f"{head}:{','.join(extra)}"
