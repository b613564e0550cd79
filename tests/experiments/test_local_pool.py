"""The local process pool: every job reported exactly once, whatever happens to the workers.

Real worker processes (forked, so the patched ``execute`` below is what they run); a job
that SIGKILLs its own worker stands in for an out-of-memory kill or a crash in compiled code.
"""

import os
import signal

import pytest

from swarmnav.experiments import backends, load_experiment, plan

pytestmark = pytest.mark.skipif(backends.mp.get_start_method() != "fork", reason="the patch reaches workers by fork")


def _jobs(seeds="1-5"):
    return plan(load_experiment("apf-scenes", overrides={"steps": "5"}, seeds=seeds))


def _fake_execute(job, keep_trajectory=True):
    if job.seed == 2:
        os.kill(os.getpid(), signal.SIGKILL)
    return {"key": job.key, "status": "done", "pid": os.getpid()}


def test_a_job_that_kills_its_worker_fails_alone(monkeypatch):
    monkeypatch.setattr(backends, "execute", _fake_execute)
    jobs = _jobs()
    rows = []
    backends.local(jobs, workers=2, on_result=rows.append)
    assert sorted(r["key"] for r in rows) == sorted(j.key for j in jobs)  # each exactly once
    for j in jobs:
        (row,) = [r for r in rows if r["key"] == j.key]
        if j.seed == 2:
            assert row["status"] == "failed"
            assert f"died {backends.MAX_JOB_RETRIES + 1} times" in row["error"]
        else:
            assert row["status"] == "done"
    assert len({r["pid"] for r in rows if "pid" in r}) <= 2 + 4 * (backends.MAX_JOB_RETRIES + 1)


_KILLED = {}


def _kill_once(job, keep_trajectory=True):
    marker = _KILLED["dir"] / job.key
    if job.seed == 3 and not marker.exists():  # first attempt only: the retry succeeds
        marker.touch()
        os.kill(os.getpid(), signal.SIGKILL)
    return {"key": job.key, "status": "done"}


def test_a_worker_killed_once_is_replaced_and_its_job_rerun(monkeypatch, tmp_path):
    _KILLED["dir"] = tmp_path
    monkeypatch.setattr(backends, "execute", _kill_once)
    jobs = _jobs()
    rows = []
    backends.local(jobs, workers=3, on_result=rows.append)
    assert sorted(r["key"] for r in rows) == sorted(j.key for j in jobs)
    assert all(r["status"] == "done" for r in rows)
    assert len(list(tmp_path.iterdir())) == sum(j.seed == 3 for j in jobs)


def test_no_worker_outlives_the_sweep(monkeypatch):
    monkeypatch.setattr(backends, "execute", lambda job, keep=True: {"key": job.key, "status": "done"})
    before = set(_children())
    backends.local(_jobs("1-2"), workers=2, on_result=lambda r: None)
    assert set(_children()) <= before


def _children():
    me = os.getpid()
    out = []
    for d in os.listdir("/proc"):
        if d.isdigit():
            try:
                stat = open(f"/proc/{d}/stat").read().rsplit(")", 1)[1].split()
            except OSError:
                continue
            if int(stat[1]) == me and stat[0] != "Z":
                out.append(int(d))
    return out



def test_a_worker_that_dies_idle_costs_its_next_job_nothing(monkeypatch):
    """A worker killed between jobs: sending it the next job fails and the job goes to another
    worker without counting as a death (with no retries allowed it would otherwise fail)."""
    monkeypatch.setattr(backends, "execute", lambda job, keep=True: {"key": job.key, "status": "done"})
    monkeypatch.setattr(backends, "MAX_JOB_RETRIES", 0)
    slots, killed, driver = [], [], os.getpid()
    real_init, real_send = backends._Slot.__init__, backends.Connection.send

    def init(self, ctx, keep):
        real_init(self, ctx, keep)
        slots.append(self)

    def send(conn, obj):
        if os.getpid() == driver and obj is not None and not killed:  # kill the first job's worker first
            (slot,) = [s for s in slots if s.conn is conn]
            os.kill(slot.proc.pid, signal.SIGKILL)
            slot.proc.join()
            killed.append(slot.proc.pid)
        return real_send(conn, obj)

    monkeypatch.setattr(backends._Slot, "__init__", init)
    monkeypatch.setattr(backends.Connection, "send", send)
    jobs = _jobs("1-2")
    rows = []
    backends.local(jobs, workers=2, on_result=rows.append)
    assert killed
    assert sorted(r["key"] for r in rows) == sorted(j.key for j in jobs)
    assert all(r["status"] == "done" for r in rows)
