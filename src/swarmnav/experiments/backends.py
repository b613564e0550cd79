"""Back ends that execute jobs: a local process pool and Ray.

A back end calls ``on_result(row)`` in the driver for every job, exactly once, in any order.
Each run seeds its own ``numpy.random.Generator`` from its seed and shares no state, so the
rows are identical whatever the back end or worker count.
"""

from __future__ import annotations

import ctypes
import os
import signal
from concurrent.futures import ProcessPoolExecutor, as_completed
from concurrent.futures.process import BrokenProcessPool
from pathlib import Path
from typing import Callable

from swarmnav.errors import ConfigError
from swarmnav.experiments.runner import Job, execute, failed_row

#: How many times a pool broken by a dying worker is rebuilt before the rest is marked failed.
MAX_POOL_RESTARTS = 3


def _die_with_parent() -> None:
    """Worker initialiser: on Linux, get SIGKILL when the driver dies, so a killed sweep
    leaves no orphaned workers behind."""
    try:
        libc = ctypes.CDLL("libc.so.6", use_errno=True)
        libc.prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        pass


def local(jobs: list[Job], *, workers: int, on_result: Callable[[dict], None], keep_trajectory: bool = True,
          ray_address: str | None = None) -> None:
    """Run on this machine: in-process for one worker, else a process pool of ``workers``.

    A worker killed mid-run breaks the pool; the runs that had finished are kept, the pool is
    rebuilt and the unfinished runs are submitted again (at most MAX_POOL_RESTARTS times,
    then the remainder is recorded as failed, to be retried by the next rerun).
    """
    if ray_address:
        raise ConfigError("--ray-address needs --backend ray")
    if workers == 1:
        for j in jobs:
            on_result(execute(j, keep_trajectory))
        return
    pending = list(jobs)
    for attempt in range(MAX_POOL_RESTARTS + 1):
        finished: set[str] = set()
        try:
            with ProcessPoolExecutor(max_workers=workers, initializer=_die_with_parent) as pool:
                futures = {pool.submit(execute, j, keep_trajectory): j for j in pending}
                for f in as_completed(futures):
                    row = f.result()
                    on_result(row)
                    finished.add(row["key"])
        except BrokenProcessPool:
            for f, j in futures.items():  # keep what completed before the pool broke
                if j.key not in finished and f.done() and not f.cancelled() and f.exception() is None:
                    on_result(f.result())
                    finished.add(j.key)
        pending = [j for j in pending if j.key not in finished]
        if not pending:
            return
    for j in pending:
        on_result(failed_row(j, "worker process died (pool broke repeatedly)"))


def ray(jobs: list[Job], *, workers: int, on_result: Callable[[dict], None], keep_trajectory: bool = True,
        ray_address: str | None = None) -> None:
    """Run on Ray: join ``ray_address`` if given, else start a local Ray with ``workers`` CPUs."""
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
        remote = ray_mod.remote(num_cpus=1, max_retries=2)(execute)
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
