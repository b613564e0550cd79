"""SPH's ``threads``: robots plan on a pool of threads, and a run is the same, bit for bit, whatever
the thread count (results collected by robot index; per-thread search work arrays; shared caches
locked; the 3-D field search kept in robot order). ``threads`` is execution only, so it is not part
of a run's key in the experiment store."""

import json
import subprocess
import sys
import threading

import numpy as np
import pytest

import swarmnav
from swarmnav.cli import main
from swarmnav.experiments import load_experiment, plan
from swarmnav.methods import registry
from swarmnav.methods.sph.method import map_bytes
from swarmnav.params import as_dict, identity
from swarmnav.planning.maps import grid_cells
from swarmnav.world import load_scenario

FOREST_2D = "random_forest:density=0.35,seed=1,length=12,r_min=1.0,r_max=2.0,min_passage=1.0"
FOREST_3D = "random_forest_3d:density=0.25,seed=7,n=8,h_min=3.0,length=12,overlap=true"


def _same(a, b) -> None:
    """Every recorded array, event, metric and committed plan of two runs identical."""
    for key in ("positions", "velocities", "clearance", "labels"):
        assert np.array_equal(getattr(a, key), getattr(b, key)), key
    assert a.events == b.events
    assert a.metrics == b.metrics
    for key in ("step", "robot", "offsets", "points", "times"):
        assert np.array_equal(getattr(a.plans, key), getattr(b.plans, key)), f"plans.{key}"


def _pool_threads() -> list[str]:
    return [t.name for t in threading.enumerate() if t.name.startswith("sph-plan")]


@pytest.mark.parametrize("extra", [{}, {"plan_neighbours": 0.6}], ids=["default", "neighbours-marked"])
def test_a_2d_forest_flies_the_same_with_one_two_and_three_threads(extra):
    scn = load_scenario(FOREST_2D, n=15)
    one = swarmnav.run("sph", scn, seed=2, steps=300, threads=1, **extra)
    assert one.metrics["sph_plans"] == 15 * 15  # 15 replans of 15 robots
    for threads in (2, 3):
        _same(one, swarmnav.run("sph", scn, seed=2, steps=300, threads=threads, **extra))
    assert _pool_threads() == []  # every run's pool ended with the run


@pytest.mark.parametrize("search", ["astar", "field"])
def test_a_3d_forest_flies_the_same_with_one_and_two_threads(search):
    scn = load_scenario(FOREST_3D)
    one = swarmnav.run("sph", scn, seed=2, steps=200, search_3d=search)
    _same(one, swarmnav.run("sph", scn, seed=2, steps=200, search_3d=search, threads=2))
    if search == "astar":
        _same(one, swarmnav.run("sph", scn, seed=2, steps=200, search_3d=search, threads=3))


def test_the_pool_ends_when_a_run_is_interrupted():
    def stop(done_steps):
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        swarmnav.run("sph", load_scenario(FOREST_2D, n=4), seed=1, steps=50, threads=2, progress=stop)
    assert _pool_threads() == []


@pytest.mark.parametrize("bad", [0, 65, 1.5])
def test_a_bad_thread_count_is_a_one_line_error(bad, tmp_path):
    with pytest.raises(swarmnav.ConfigError, match="threads"):
        registry.make("sph", threads=bad)
    p = subprocess.run([sys.executable, "-m", "swarmnav", "run", "--method", "sph", "--scenario", FOREST_2D,
                        "--steps", "5", "--set", f"threads={bad}", "--out", str(tmp_path / "r")],
                       capture_output=True, text=True)
    assert p.returncode == 2
    assert len(p.stderr.strip().splitlines()) == 1 and "threads" in p.stderr


def test_threads_from_the_cli_and_experiment_specs_leave_the_run_key_alone(tmp_path):
    out = tmp_path / "r"
    assert main(["run", "--method", "sph", "--scenario", FOREST_2D, "--steps", "5", "--out", str(out),
                 "--set", "threads=2"]) == 0
    assert json.loads((out / "config.json").read_text())["params"]["threads"] == 2
    # the store's run key covers what a run computes, not how: same keys with or without threads
    p = registry.make("sph", threads=2).params
    assert as_dict(p)["threads"] == 2 and "threads" not in identity(p)
    assert identity(p) == identity(registry.make("sph").params)
    plain, threaded = (plan(load_experiment("sph-scaling", overrides=o, seeds="1-2")) for o in ({}, {"threads": "2"}))
    assert [j.key for j in plain] == [j.key for j in threaded]
    assert all(j.variant.params["threads"] == "2" for j in threaded)


def test_the_map_limit_counts_every_threads_search_arrays():
    scn = load_scenario(FOREST_2D, n=15)
    one, two = (map_bytes(scn, registry.make("sph", threads=t).params) for t in (1, 2))
    assert two - one == 17 * grid_cells(scn.bounds, registry.make("sph").params.grid_resolution)
