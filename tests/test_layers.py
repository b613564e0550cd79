"""The package's layering (STYLE.md, "The shape of the package"), read from the source with ``ast``:

(a) no module imports a ``_private`` name (module, function, constant) of another package, nor
    reaches one as ``module._name``: a private name is for the package that holds it (and its
    sub-packages); what another package needs gets a public name there;
(b) no two modules import each other, counting imports inside functions (a function-level
    import is how a circle usually hides): the shared piece belongs in a module both import.
"""

from __future__ import annotations

import ast
from pathlib import Path

import swarmnav

ROOT = Path(swarmnav.__file__).parent


def modules(root: Path = ROOT) -> dict[str, tuple[Path, bool]]:
    """Dotted name -> (file, is_package) of every module under ``root``."""
    out = {}
    for f in sorted(root.rglob("*.py")):
        parts = [root.name, *f.relative_to(root).with_suffix("").parts]
        is_pkg = parts[-1] == "__init__"
        out[".".join(parts[:-1] if is_pkg else parts)] = (f, is_pkg)
    return out


def imports(name: str, is_pkg: bool, source: str, known: set[str]) -> list[tuple[int, str, str]]:
    """Every import of ``swarmnav`` code in a module's source, at any depth (functions,
    ``TYPE_CHECKING`` blocks): ``(line, module imported from, full dotted name imported)``.

    The module imported from is the submodule when ``from P import m`` names one, else ``P``.
    """
    package = name if is_pkg else name.rpartition(".")[0]
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            found += [(node.lineno, a.name, a.name) for a in node.names if a.name.split(".")[0] == "swarmnav"]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                up = package.split(".")[: len(package.split(".")) - (node.level - 1)]
                base = ".".join(up + ([base] if base else []))
            if base.split(".")[0] != "swarmnav":
                continue
            for a in node.names:
                full = f"{base}.{a.name}"
                found.append((node.lineno, full if full in known else base, full))
    return found


def _is_private(part: str) -> bool:
    return part.startswith("_") and not (part.startswith("__") and part.endswith("__"))


def private_leak(importer: str, is_pkg: bool, imported: str, known: dict[str, tuple[Path, bool]]) -> str | None:
    """The package that owns the private part of ``imported`` if ``importer`` lies outside it."""
    parts = imported.split(".")
    i = next((k for k, p in enumerate(parts) if _is_private(p)), None)
    if i is None:
        return None
    owner = ".".join(parts[:i])
    if owner in known and not known[owner][1]:  # a private name of a module: its package owns it
        owner = owner.rpartition(".")[0]
    here = importer if is_pkg else importer.rpartition(".")[0]
    return None if here == owner or here.startswith(owner + ".") else owner


def module_attributes(source: str, known: set[str]) -> list[tuple[int, str]]:
    """``alias._name`` uses where ``alias`` is a ``swarmnav`` module bound by an import
    (``from swarmnav.sensing import lidar`` then ``lidar._ray_table``): ``(line, full name)``."""
    tree = ast.parse(source)
    bound = {}
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module and not node.level:
            bound |= {a.asname or a.name: f"{node.module}.{a.name}" for a in node.names
                      if f"{node.module}.{a.name}" in known}
        elif isinstance(node, ast.Import):
            bound |= {a.asname: a.name for a in node.names if a.asname and a.name in known}
    return [(node.lineno, f"{bound[node.value.id]}.{node.attr}") for node in ast.walk(tree)
            if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) and node.value.id in bound]


def private_imports(mods: dict[str, tuple[Path, bool]], root: Path = ROOT) -> list[str]:
    bad = []
    for name, (path, is_pkg) in mods.items():
        source = path.read_text(encoding="utf-8")
        used = [(line, full) for line, _, full in imports(name, is_pkg, source, set(mods))]
        for line, full in sorted(used + module_attributes(source, set(mods))):
            owner = private_leak(name, is_pkg, full, mods)
            if owner is not None:
                bad.append(f"{path.relative_to(root.parent)}:{line} imports {full}, private to {owner}")
    return bad


def two_module_cycles(mods: dict[str, tuple[Path, bool]]) -> list[str]:
    edges: dict[str, dict[str, int]] = {}
    for name, (path, is_pkg) in mods.items():
        for line, target, _ in imports(name, is_pkg, path.read_text(encoding="utf-8"), set(mods)):
            if target != name and target in mods:
                edges.setdefault(name, {}).setdefault(target, line)
    return [f"{a} (line {ln}) <-> {b} (line {edges[b][a]})"
            for a, out in sorted(edges.items()) for b, ln in sorted(out.items())
            if a < b and a in edges.get(b, {})]


def test_no_module_imports_a_private_name_of_another_package():
    assert private_imports(modules()) == []


def test_no_two_modules_import_each_other():
    assert two_module_cycles(modules()) == []


def test_the_checks_see_the_leaks_they_forbid(tmp_path):
    # the very leaks this test was written against, in a scratch package shaped like swarmnav
    files = {
        "__init__.py": "",
        "sensing/__init__.py": "from swarmnav.sensing.lidar import ray_table\n",
        "sensing/_kernels.py": "def esdf_query_kernel(): ...\n",
        "sensing/lidar.py": "from swarmnav.sensing._kernels import esdf_query_kernel\ndef _ray_table(n): ...\n",
        "methods/__init__.py": "",
        "methods/hes.py": "def f():\n    from swarmnav.sensing.lidar import _ray_table\n",
        "methods/sph.py": "from swarmnav.sensing._kernels import esdf_query_kernel\nfrom ..sensing import ray_table\n",
        "methods/vicsek.py": "from swarmnav.sensing import lidar\nc = lidar.ray_table(8)\ns = lidar._ray_table(8)\n",
        "experiments/__init__.py": "",
        "experiments/runner.py": "def run():\n    from swarmnav.experiments.backends import BACKENDS\n",
        "experiments/backends.py": "from .runner import run\nBACKENDS = {}\n",
    }
    root = tmp_path / "swarmnav"
    for rel, text in files.items():
        (root / rel).parent.mkdir(parents=True, exist_ok=True)
        (root / rel).write_text(text)
    mods = modules(root)
    bad = private_imports(mods, root)
    assert len(bad) == 3, bad  # sensing's own use of _kernels is allowed
    assert "methods/hes.py:2 imports swarmnav.sensing.lidar._ray_table, private to swarmnav.sensing" in bad[0]
    assert "methods/sph.py:1 imports swarmnav.sensing._kernels.esdf_query_kernel" in bad[1]
    assert "methods/vicsek.py:3 imports swarmnav.sensing.lidar._ray_table" in bad[2]
    assert two_module_cycles(mods) == ["swarmnav.experiments.backends (line 1) <-> swarmnav.experiments.runner (line 2)"]


def test_the_checks_read_the_whole_package():
    mods = modules()
    assert {"swarmnav.cli", "swarmnav.methods.hes.method", "swarmnav.sensing.lidar"} <= set(mods)
    path, is_pkg = mods["swarmnav.methods.hes.method"]
    targets = {t for _, t, _ in imports("swarmnav.methods.hes.method", is_pkg, path.read_text(), set(mods))}
    assert {"swarmnav.sensing", "swarmnav.methods.hes.decision"} <= targets
