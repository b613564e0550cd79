"""The shipped examples run as their comments say (shortened horizons)."""

from __future__ import annotations

import csv
import json
import os
import subprocess
import sys
from pathlib import Path

from swarmnav.cli import main

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"


def test_the_scene_file_runs_and_reaches_the_goal(tmp_path):
    out = tmp_path / "mine"
    assert main(["run", "--method", "hes", "--scenario-file", str(EXAMPLES / "my_scene.toml"), "--horizon", "60",
                 "--out", str(out), "--quiet"]) == 0
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["Y"] == 1.0 and metrics["R_goal"] == 1.0  # HES crosses both walls in 60 s


def test_the_spec_runs_every_variant(tmp_path, monkeypatch):
    monkeypatch.chdir(ROOT)  # the spec names its scene relative to where swarmnav runs
    out = tmp_path / "compare"
    assert main(["experiment", "--spec", "examples/compare.toml", "--seeds", "1", "--set", "horizon=5",
                 "--out", str(out), "--quiet"]) == 0
    with open(out / "runs.csv") as f:
        rows = list(csv.DictReader(f))
    assert sorted(r["variant"] for r in rows) == ["apf", "hes", "hes-paper", "sph"]
    assert all(r["status"] == "done" for r in rows)
    steps = {r["variant"]: int(r["steps"]) for r in rows}
    assert steps == {"apf": 50, "hes": 50, "hes-paper": 50, "sph": 500}  # 5 s of each method's own dt


def test_the_python_script_runs(tmp_path):
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src") + os.pathsep + os.environ.get("PYTHONPATH", "")}
    p = subprocess.run([sys.executable, str(EXAMPLES / "quickstart.py"), "--horizon", "5", "--out", str(tmp_path)],
                       capture_output=True, text=True, env=env, timeout=600)
    assert p.returncode == 0, p.stderr
    assert "hes  Y = " in p.stdout and "apf  Y = " in p.stdout
    for method in ("hes", "apf"):
        assert (tmp_path / method / "trajectory.png").stat().st_size > 10_000
        assert json.loads((tmp_path / method / "config.json").read_text())["steps"] == 50
