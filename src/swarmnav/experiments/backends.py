"""Back ends that execute jobs: a local process pool and Ray.

A back end calls ``on_result(row)`` in the driver for every job, exactly once, in any order.
Each run seeds its own ``numpy.random.Generator`` from its seed and shares no state, so the
rows are identical whatever the back end or worker count; Ray workers start with the driver's
numerics (portable or native, docs/determinism.md), so a cluster of mixed CPUs agrees too.
"""

from __future__ import annotations

import ctypes
import multiprocessing as mp
import os
import signal
from collections import deque
from multiprocessing.connection import Connection, wait
from pathlib import Path
from typing import Callable

from swarmnav import portable
from swarmnav.errors import ConfigError
from swarmnav.experiments.jobs import Job, execute, failed_row

#: How many times a job whose worker process died under it is run again before it is recorded
#: as failed (to be retried by the next rerun of the sweep).
MAX_JOB_RETRIES = 2


def _die_with_parent() -> None:
    """On Linux, get SIGKILL when the driver dies, so a killed sweep leaves no orphaned workers."""
    try:
        libc = ctypes.CDLL("libc.so.6", use_errno=True)
        libc.prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        pass


def _worker(conn: Connection, keep_trajectory: bool) -> None:
    """Worker process: run the jobs the driver sends down ``conn`` until it sends None.

    Ctrl-C is the driver's to handle (it stops the workers), so a worker ignores SIGINT
    rather than printing a traceback per process.
    """
    _die_with_parent()
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    while (job := conn.recv()) is not None:
        conn.send(execute(job, keep_trajectory))


class _Slot:
    """One worker process, its private pipe, and the job it is running (None when idle)."""

    def __init__(self, ctx, keep_trajectory: bool):
        self.conn, child = ctx.Pipe()
        self.proc = ctx.Process(target=_worker, args=(child, keep_trajectory), daemon=True)
        self.proc.start()
        child.close()
        self.job: Job | None = None

    def stop(self) -> None:
        if self.proc.is_alive():
            self.proc.kill()
        self.proc.join()
        self.conn.close()


def local(jobs: list[Job], *, workers: int, on_result: Callable[[dict], None], keep_trajectory: bool = True,
          ray_address: str | None = None) -> None:
    """Run on this machine: in-process for one worker, else ``workers`` worker processes.

    Every worker has its own pipe, so a worker that dies (SIGKILL, out of memory, a crash in
    compiled code) takes down only the job it was running: the driver sees its pipe close,
    starts a replacement and runs that job again (at most MAX_JOB_RETRIES times, then records
    it as failed, to be retried by the next rerun). Nothing is shared between workers, so no
    lock can be left held by a dead one.
    """
    if ray_address:
        raise ConfigError("--ray-address needs --backend ray")
    if workers == 1:
        for j in jobs:
            on_result(execute(j, keep_trajectory))
        return
    todo = deque(jobs)
    deaths: dict[str, int] = {}
    ctx = mp.get_context()
    slots: list[_Slot] = []
    try:
        while todo or slots:
            while len(slots) < min(workers, len(todo) + sum(s.job is not None for s in slots)):
                slots.append(_Slot(ctx, keep_trajectory))
            for s in list(slots):
                if s.job is None and todo:
                    try:
                        s.conn.send(todo[0])
                    except OSError:  # it died idle: the job never started, so it costs no retry
                        s.stop()
                        slots.remove(s)
                        continue
                    s.job = todo.popleft()
            busy = [s for s in slots if s.job is not None]
            if not busy:
                break
            ready = set(wait([s.conn for s in busy] + [s.proc.sentinel for s in busy]))
            for s in busy:
                if s.conn not in ready and s.proc.sentinel not in ready:
                    continue
                try:  # a result sent just before the worker died is still in the pipe
                    row = s.conn.recv() if s.conn.poll() else None
                except Exception:  # noqa: BLE001 - EOF or a half-written result from a dying worker
                    row = None
                if row is not None:
                    s.job = None
                    on_result(row)
                    if s.proc.is_alive():
                        continue
                if s.job is not None:  # the worker died running it
                    n = deaths[s.job.key] = deaths.get(s.job.key, 0) + 1
                    if n > MAX_JOB_RETRIES:
                        on_result(failed_row(s.job, f"worker process died {n} times running it "
                                                    f"(exit code {s.proc.exitcode})"))
                    else:
                        todo.appendleft(s.job)
                    s.job = None
                s.stop()
                slots.remove(s)
        for s in slots:  # all done: let the idle workers exit on their own
            s.conn.send(None)
            s.proc.join(5)
    finally:
        for s in slots:
            s.stop()


def _numerics_env() -> dict[str, str]:
    """What a worker process must start with to run the driver's numerics: portable mode's
    variables (glibc reads its own only at process start), or the switch set to native."""
    return {**portable.environment(), portable.SWITCH: "1"} if portable.requested() else {portable.SWITCH: "0"}


def ray(jobs: list[Job], *, workers: int, on_result: Callable[[dict], None], keep_trajectory: bool = True,
        ray_address: str | None = None) -> None:
    """Run on Ray: join ``ray_address`` if given, else start a local Ray with ``workers`` CPUs.

    Each job's ``runtime_env`` gives its worker the driver's numerics, whoever started Ray: a
    worker imports NumPy before it runs a job, too late for swarmnav to pin it, and glibc reads
    its setting only at process start (docs/determinism.md)."""
    try:
        import ray as ray_mod
    except ImportError:
        raise ConfigError("--backend ray needs Ray: pip install 'swarmnav[ray]'") from None
    started = not ray_mod.is_initialized()
    if started:
        kwargs = dict(include_dashboard=False, log_to_driver=False, ignore_reinit_error=True)
        if ray_address:
            ray_mod.init(address=ray_address, **kwargs)
        else:
            # A local cluster binds to loopback, and its workers import swarmnav from wherever the
            # driver did (an installed package or a source checkout on sys.path).
            here = str(Path(__file__).resolve().parents[2])
            path = os.pathsep.join([here] + [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p])
            ray_mod.init(num_cpus=workers, _node_ip_address="127.0.0.1",
                         runtime_env={"env_vars": {"PYTHONPATH": path}}, **kwargs)
    try:
        remote = ray_mod.remote(num_cpus=1, max_retries=2, runtime_env={"env_vars": _numerics_env()})(execute)
        refs = {remote.remote(j, keep_trajectory): j for j in jobs}
        pending = list(refs)
        while pending:
            ready, pending = ray_mod.wait(pending, num_returns=1)
            for r in ready:
                try:
                    row = ray_mod.get(r)
                except Exception as e:  # noqa: BLE001 - a lost task is a failed run, not a crash
                    lines = [ln for ln in str(e).splitlines() if ln.strip()]
                    row = failed_row(refs[r], f"ray: {type(e).__name__}: {lines[-1] if lines else ''}")
                on_result(row)
    finally:
        if started:
            ray_mod.shutdown()


BACKENDS = {"local": local, "ray": ray}
