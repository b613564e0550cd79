"""Methods from outside swarmnav (docs/plugins.md): an installed plugin is listed, checked and flown
like a built-in; a broken plugin is named in one line and leaves the built-ins working; a factory
named ``module:Factory`` or ``file.py:Factory`` flies without being installed; ``check-method``
passes the built-ins and fails a method that breaks the contract."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

import swarmnav
from swarmnav.methods import registry
from swarmnav.sim.check import check_method

ROOT = Path(__file__).resolve().parents[1]
SRC = str(Path(swarmnav.__file__).resolve().parents[1])


def _cli(*args: str, path: list[str] = (), cwd: Path | None = None) -> subprocess.CompletedProcess:
    """``python -m swarmnav.cli ARGS`` in a fresh process with ``path`` before this checkout's src."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([*map(str, path), SRC])}
    return subprocess.run([sys.executable, "-m", "swarmnav.cli", *map(str, args)], capture_output=True, text=True,
                          env=env, cwd=cwd)


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    """examples/my_method installed as a user installs it (pip, no build isolation: offline), into a
    directory of its own that the CLI processes put on their path."""
    target = tmp_path_factory.mktemp("site")
    r = subprocess.run([sys.executable, "-m", "pip", "install", "-q", "--no-deps", "--no-build-isolation",
                        "--target", str(target), str(ROOT / "examples" / "my_method")], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    return target


def test_an_installed_plugin_is_listed_and_documented(site):
    r = _cli("methods", path=[site])
    assert r.returncode == 0 and r.stderr == ""
    line = next(x for x in r.stdout.splitlines() if x.startswith("steer"))
    assert "[plugin]" in line and "Goal pull" in line
    assert "apf" in r.stdout and "sph" in r.stdout  # the built-ins are all still there
    r = _cli("methods", "steer", path=[site])
    assert r.returncode == 0 and "k_goal" in r.stdout and "m/s^2" in r.stdout


def test_an_installed_plugin_passes_the_check_and_flies_the_forests(site, tmp_path):
    r = _cli("check-method", "steer", "--scenes", "default_corridor,sph_cluttered_3d", path=[site])
    assert r.returncode == 0, r.stdout + r.stderr
    assert r.stdout.count("ok  ") == 4 and "steer: conforms" in r.stdout
    r = _cli("experiment", "sph-forest", "--set", "method=steer", "--set", "density=0.15", "--seeds", "1",
             "--workers", "1", "--out", tmp_path / "forest", path=[site])
    assert r.returncode == 0, r.stderr
    runs = (tmp_path / "forest" / "runs.csv").read_text().splitlines()
    assert len(runs) == 2 and "steer" in runs[1]
    r = _cli("run", "--method", "steer", "--scenario", "default_corridor", "--steps", "50", "--out",
             tmp_path / "run", "--set", "k_goal=0.5", "--set", "net.loss=0.3", "--quiet", path=[site])
    assert r.returncode == 0, r.stderr
    cfg = json.loads((tmp_path / "run" / "config.json").read_text())
    assert cfg["method"] == "steer" and cfg["params"]["k_goal"] == 0.5 and cfg["net"]["loss"] == 0.3


def test_a_broken_plugin_is_named_in_one_line_and_the_built_ins_fly(tmp_path):
    dist = tmp_path / "broken_plugins-0.1.dist-info"
    dist.mkdir()
    (dist / "METADATA").write_text("Metadata-Version: 2.1\nName: broken-plugins\nVersion: 0.1\n")
    (dist / "entry_points.txt").write_text("[swarmnav.methods]\nbroken = no_such_module_xyz:Thing\n"
                                            "apf = json:dumps\nnot-a-method = json:JSONDecodeError\n")
    r = _cli("methods", path=[tmp_path])
    assert r.returncode == 0 and "apf" in r.stdout and "broken" not in r.stdout
    warnings = r.stderr.strip().splitlines()
    assert len(warnings) == 3 and all(w.startswith("swarmnav: warning: plugin '") for w in warnings)
    assert any("'broken'" in w and "ModuleNotFoundError" in w and "broken-plugins" in w for w in warnings)
    assert any("'apf'" in w and "built-in" in w for w in warnings)
    assert any("'not-a-method'" in w and "Params" in w for w in warnings)
    r = _cli("run", "--method", "apf", "--scenario", "default_corridor", "--steps", "5", "--out", tmp_path / "a",
             "--quiet", path=[tmp_path])
    assert r.returncode == 0, r.stderr
    r = _cli("run", "--method", "broken", "--scenario", "default_corridor", "--steps", "5", "--out",
             tmp_path / "b", path=[tmp_path])
    assert r.returncode == 2 and "Traceback" not in r.stderr and len(r.stderr.strip().splitlines()) == 1
    assert "plugin 'broken'" in r.stderr and "no_such_module_xyz" in r.stderr


_HOVER = '''
from dataclasses import dataclass
import numpy as np
from swarmnav.dynamics import SaturatedDoubleIntegrator
from swarmnav.params import build, param

@dataclass(frozen=True, slots=True)
class HoverParams:
    dt: float = param(0.1, "s", "(0, 1]", "ours", "control step")

class Hover:
    """Every agent holds still."""
    Params = HoverParams
    name = "hover"
    dims = (2, 3)

    def __init__(self, **overrides):
        self.params = build(HoverParams, overrides, context="hover")
        self.dt = self.params.dt
        self.dynamics = SaturatedDoubleIntegrator(1.0, 1.5)

    def reset(self, scenario, positions, velocities, rng):
        self.shape = positions.shape

    def act(self, obs, rng):
        return np.zeros(self.shape), {BAD}

    def summary(self):
        return {}
'''


def test_a_factory_named_by_its_file_flies_without_being_installed(tmp_path):
    (tmp_path / "mine.py").write_text(_HOVER.replace("{BAD}", "{}"))
    r = _cli("run", "--method", "mine.py:Hover", "--scenario", "default_corridor", "--steps", "5", "--out",
             tmp_path / "r", "--quiet", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    for bad, words in (("mine.py:Nope", "has no attribute 'Nope'"), ("nothere.py:Hover", "no file nothere.py"),
                       ("no_such_module_xyz:Hover", "ModuleNotFoundError")):
        r = _cli("run", "--method", bad, "--scenario", "default_corridor", "--steps", "5", "--out", tmp_path / "x",
                 cwd=tmp_path)
        assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1 and words in r.stderr, (bad, r.stderr)


def test_the_check_fails_a_method_that_breaks_the_contract(tmp_path):
    (tmp_path / "bad.py").write_text(_HOVER.replace("{BAD}", '{"velocity": 1.0}'))
    r = _cli("check-method", str(tmp_path / "bad.py") + ":Hover", "--scenes", "default_corridor")
    assert r.returncode == 1
    assert "FAIL  scene default_corridor: step 0: info key 'velocity' is not in the contract" in r.stdout
    assert "1 of 3 checks failed" in r.stdout


@pytest.mark.parametrize("name", registry.names())
def test_every_built_in_passes_the_contract_and_parameter_checks(name):
    verdicts = check_method(name, scenes=[])
    assert [v.check for v in verdicts] == ["contract", "parameters"]
    assert all(v.ok for v in verdicts), [v.line() for v in verdicts]


@pytest.mark.parametrize("name", ["apf", "vasarhelyi", "vem", "sph"])
def test_built_ins_pass_the_scene_checks(name):
    scene = "periodic_box:n=30,rho=4.102,seed=1" if not registry.spec(name).navigation else "default_corridor"
    verdicts = check_method(name, scenes=[scene], steps=20)
    assert all(v.ok for v in verdicts), [v.line() for v in verdicts]


def test_check_method_input_errors_are_one_line():
    r = _cli("check-method", "nope")
    assert r.returncode == 2 and "unknown method 'nope'" in r.stderr and len(r.stderr.strip().splitlines()) == 1
    r = _cli("check-method", "apf", "--scenes", "mars")
    assert r.returncode == 2 and "mars" in r.stderr and len(r.stderr.strip().splitlines()) == 1
