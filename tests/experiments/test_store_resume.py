"""The results store and resume: nothing lost, nothing run twice, identical numbers.

The kill tests run the real CLI in a subprocess and SIGKILL the driver or one worker
partway through; the rerun must end with exactly the runs of an uninterrupted sweep.
"""

import csv
import os
import signal
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

import pytest

import swarmnav
from swarmnav.experiments import Store, load_experiment, plan, run_experiment

SEEDS = "1-6"
STEPS = "150"


def _env():
    src = str(Path(swarmnav.__file__).resolve().parents[1])
    return {**os.environ, "PYTHONPATH": src + os.pathsep + os.environ.get("PYTHONPATH", "")}


def _cli(out, workers=2):
    return [sys.executable, "-m", "swarmnav.cli", "experiment", "apf-scenes", "--seeds", SEEDS, "--set",
            f"steps={STEPS}", "--workers", str(workers), "--out", str(out), "--quiet"]


def _done(out):
    db = Path(out) / "results.sqlite"
    if not db.exists():
        return 0
    try:
        with sqlite3.connect(db, timeout=1) as c:
            return c.execute("SELECT COUNT(*) FROM runs WHERE status='done'").fetchone()[0]
    except sqlite3.OperationalError:
        return 0


def _metrics(out):
    rows = list(csv.DictReader(open(Path(out) / "runs.csv")))
    drop = {"wall_time_s"}
    return {r["key"]: {k: v for k, v in r.items() if k not in drop} for r in rows}


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The uninterrupted sweep, by the same command as the interrupted ones: the CLI runs in
    portable numerics (docs/determinism.md), which this test process, having loaded NumPy
    first, cannot, so an in-process sweep would differ in the last bits."""
    out = tmp_path_factory.mktemp("ref")
    subprocess.run(_cli(out, workers=1), env=_env(), check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return _metrics(out)


def test_uninterrupted_sweep_is_complete(reference):
    assert len(reference) == 24
    assert all(r["status"] == "done" for r in reference.values())


def test_rerun_runs_nothing_twice(tmp_path, reference):
    exp = load_experiment("apf-scenes", overrides={"steps": STEPS}, seeds="1-2")
    run_experiment(exp, tmp_path, workers=1, progress=False)
    first = {r["key"]: r["finished_at"] for r in Store(tmp_path).rows()}
    seen = []
    run_experiment(exp, tmp_path, workers=1, progress=False, on_row=seen.append)
    assert seen == []  # everything was already done
    assert {r["key"]: r["finished_at"] for r in Store(tmp_path).rows()} == first
    # widening the seed range runs only the new seeds
    exp4 = load_experiment("apf-scenes", overrides={"steps": STEPS}, seeds="1-4")
    run_experiment(exp4, tmp_path, workers=1, progress=False, on_row=seen.append)
    assert sorted({r["seed"] for r in seen}) == [3, 4] and len(seen) == 8


def test_failed_runs_are_retried(tmp_path):
    exp = load_experiment("apf-scenes", overrides={"steps": "20"}, seeds="1")
    jobs = plan(exp)
    store = Store(tmp_path)
    store.set_meta("x", 1)
    from swarmnav.experiments.jobs import failed_row

    store.put(failed_row(jobs[0], "boom"))
    seen = []
    run_experiment(exp, tmp_path, workers=1, progress=False, on_row=seen.append)
    assert jobs[0].key in {r["key"] for r in seen}
    assert Store(tmp_path).count() == {"done": 4}


def test_config_key_changes_with_any_setting():
    base = plan(load_experiment("apf-scenes", seeds="1"))
    other = plan(load_experiment("apf-scenes", seeds="1", overrides={"k_att": "2.5"}))
    same = plan(load_experiment("apf-scenes", seeds="1", overrides={"k_att": "2.0"}))  # the default value
    assert {j.key for j in base} == {j.key for j in same}
    assert not {j.key for j in base} & {j.key for j in other}


def _kill_partway(out, who):
    p = subprocess.Popen(_cli(out), env=_env(), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                         start_new_session=True)
    deadline = time.time() + 120
    while _done(out) < 3 and time.time() < deadline and p.poll() is None:
        time.sleep(0.05)
    assert p.poll() is None, "the sweep finished before it could be killed; make it longer"
    if who == "driver":
        os.kill(p.pid, signal.SIGKILL)
        p.wait(30)
    else:
        kids = [int(d) for d in os.listdir("/proc") if d.isdigit() and _ppid(int(d)) == p.pid]
        assert kids, "no worker processes found"
        os.kill(kids[0], signal.SIGKILL)
        assert p.wait(120) in (0, 1)  # the driver survives a dead worker and finishes
    return _done(out)


def _ppid(pid):
    try:
        return int(Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[1])
    except (OSError, IndexError, ValueError):
        return -1


@pytest.mark.parametrize("who", ["driver", "worker"])
def test_sigkill_then_rerun_equals_uninterrupted(tmp_path, reference, who):
    kept = _kill_partway(tmp_path, who)
    assert kept >= 3
    rows = Store(tmp_path).rows()
    assert all(r["status"] in ("done", "failed") and (r["status"] == "failed" or r["metrics"]) for r in rows)
    for r in rows:  # every committed row's trajectory file is complete
        if r["trajectory"]:
            import numpy as np

            with np.load(tmp_path / r["trajectory"]) as z:
                assert z["positions"].shape == (int(STEPS) + 1, 20, 2)
    subprocess.run(_cli(tmp_path), env=_env(), check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    assert _metrics(tmp_path) == reference
    assert not list(tmp_path.rglob("*.tmp"))


def test_driver_kill_leaves_no_orphan_workers(tmp_path):
    p = subprocess.Popen(_cli(tmp_path), env=_env(), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.time() + 120
    while _done(tmp_path) < 2 and time.time() < deadline:
        time.sleep(0.05)
    kids = [int(d) for d in os.listdir("/proc") if d.isdigit() and _ppid(int(d)) == p.pid]
    os.kill(p.pid, signal.SIGKILL)
    p.wait(30)
    time.sleep(1.0)
    alive = [k for k in kids if Path(f"/proc/{k}").exists() and "Z" not in Path(f"/proc/{k}/stat").read_text().split()[2]]
    assert alive == []


def _apf(steps="5", seeds="1", **sets):
    return load_experiment("apf-scenes", overrides={"steps": steps, **sets}, seeds=seeds)


def test_a_different_sweep_into_the_same_store_is_refused_unless_forced(tmp_path):
    from swarmnav.errors import ConfigError

    run_experiment(_apf(), tmp_path, progress=False)
    first = Store(tmp_path).meta("experiment:apf-scenes")
    seen = []
    with pytest.raises(ConfigError, match=r"holds a different sweep of 'apf-scenes' \(every variant configured "
                                          r"differently: --set steps=5 then, steps=6 now\); --force"):
        run_experiment(_apf("6"), tmp_path, progress=False, on_row=seen.append)
    with pytest.raises(ConfigError, match=r"other variants: 4 stored, 8 now"):
        run_experiment(_apf(k_att="1|2"), tmp_path, progress=False, on_row=seen.append)
    assert seen == [] and Store(tmp_path).meta("experiment:apf-scenes") == first  # refused before anything ran
    # more seeds of the same variants is the same sweep; so is resuming it
    run_experiment(_apf(seeds="1-2"), tmp_path, progress=False, on_row=seen.append)
    assert sorted({r["seed"] for r in seen}) == [2]
    # forced: the new spec is the store's record; the old runs stay stored but out of the CSVs
    runs, _ = run_experiment(_apf("6"), tmp_path, progress=False, force=True)
    assert {r["steps"] for r in runs} == {6} and len(runs) == 4
    assert len(Store(tmp_path).rows()) == 12


def test_another_experiment_into_a_store_is_refused_unless_forced(tmp_path, capsys):
    from swarmnav.cli import main

    run_experiment(_apf(), tmp_path, progress=False)
    spec = tmp_path / "other.toml"
    spec.write_text('name = "other"\nmethod = "apf"\nscenario = "off_axis_goal"\nsteps = 5\nseeds = "1"\n')
    args = ["experiment", "--spec", str(spec), "--out", str(tmp_path), "--quiet"]
    assert main(args) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"swarmnav: error: {tmp_path} holds the results of experiment 'apf-scenes'; --force adds 'other' "
                   f"beside it (swarmnav report --experiment NAME picks one), or choose another --out"]
    assert main([*args, "--force"]) == 0
    assert main(["report", str(tmp_path), "--no-viewers", "--experiment", "apf-scenes"]) == 0
    assert "| off_axis_goal | 1/1 |" in (tmp_path / "report.md").read_text()
    assert main(["report", str(tmp_path), "--no-viewers"]) == 0  # the last one run
    assert "| default | 1/1 |" in (tmp_path / "report.md").read_text()


def test_a_store_from_before_variant_keys_still_resumes_and_refuses(tmp_path):
    from swarmnav.errors import ConfigError

    run_experiment(_apf(), tmp_path, progress=False)
    store = Store(tmp_path)
    meta = store.meta("experiment:apf-scenes")
    for v in meta["variants"]:
        del v["config"]
    del meta["overrides"]
    store.set_meta("experiment:apf-scenes", meta)
    seen = []
    run_experiment(_apf(), tmp_path, progress=False, on_row=seen.append)  # the same sweep: resumes, runs nothing
    assert seen == []
    store.set_meta("experiment:apf-scenes", meta)
    with pytest.raises(ConfigError, match=r"every variant configured differently\); --force"):
        run_experiment(_apf("6"), tmp_path, progress=False)
    from swarmnav.experiments.report import write_report

    md = write_report(tmp_path)[0].read_text()
    assert "Seeds: 1. Overrides (`--set`): not recorded (a store written before swarmnav kept them)." in md
