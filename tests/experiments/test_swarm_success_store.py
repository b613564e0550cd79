"""benchmarks/swarm_success_store.py recomputes the swarm test from stored trajectories: on a store
that records ``sph_swarm_success`` it must agree run by run, and a tampered record is caught."""

import json
import sqlite3
import subprocess
import sys
from pathlib import Path

import pytest

from swarmnav.cli import main

ROOT = Path(__file__).resolve().parents[2]
SPEC = """name = "tiny-swarm"
method = "apf"
scenario = "random_forest:density=0.1,seed={seed},length=6,r_min=1.0,r_max=2.0,min_passage=1.0"
horizon = 25.0
seeds = "1-3"
[matrix]
n = [3, 20]
"""


def _bench(store: Path) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(ROOT / "benchmarks" / "swarm_success_store.py"), str(store)],
                          capture_output=True, text=True, env={"PYTHONPATH": str(ROOT / "src"), "PATH": ""})


@pytest.fixture(scope="module")
def store(tmp_path_factory):
    d = tmp_path_factory.mktemp("swarm")
    (d / "spec.toml").write_text(SPEC)
    assert main(["experiment", "--spec", str(d / "spec.toml"), "--out", str(d / "o"), "--quiet"]) == 0
    return d / "o"


def test_recomputed_swarm_test_agrees_with_the_recorded_one(store):
    rows = sqlite3.connect(store / "results.sqlite").execute("select variant, metrics from runs").fetchall()
    recorded = {}
    for v, m in rows:
        recorded.setdefault(v, []).append(json.loads(m)["sph_swarm_success"])
    p = _bench(store)
    assert p.returncode == 0, p.stderr
    for v, vals in recorded.items():
        line = next(ln for ln in p.stdout.splitlines() if ln.startswith(f"apf: {v} "))
        assert line.split()[-1] == f"{int(sum(vals))}/{len(vals)}"


def test_a_record_the_trajectories_do_not_give_is_caught(store, tmp_path):
    import shutil

    copy = tmp_path / "copy"
    shutil.copytree(store, copy)
    db = sqlite3.connect(copy / "results.sqlite")
    key, m = db.execute("select key, metrics from runs limit 1").fetchone()
    m = json.loads(m)
    m["sph_swarm_success"] = 1.0 - m["sph_swarm_success"]
    db.execute("update runs set metrics = ? where key = ?", (json.dumps(m), key))
    db.commit()
    p = _bench(copy)
    assert p.returncode == 1 and "do not give" in p.stderr


def test_a_directory_without_a_store_is_one_line_exit_2(tmp_path):
    p = _bench(tmp_path)
    assert p.returncode == 2 and len(p.stderr.strip().splitlines()) == 1
