"""Issue 7 acceptance: the 40-run hes-sim3 sweep on 2 workers, Ray parity, kill + resume parity.

Run: ``python benchmarks/bench_sweep.py [--skip-ray]``. Prints

1. wall time of ``swarmnav experiment hes-sim3 --set decision=rule --set preset=swarmnav --seeds 1-10 --workers 2``
   (target: < 60 s on the 2-core machine);
2. whether ``--backend ray`` gives identical per-run metrics;
3. whether a sweep SIGKILLed partway and rerun ends with exactly the uninterrupted runs.
"""

from __future__ import annotations

import csv
import os
import signal
import sqlite3
import subprocess
import sys
import tempfile
import time
from pathlib import Path

CMD = ["experiment", "hes-sim3", "--set", "decision=rule", "--set", "preset=swarmnav", "--seeds", "1-10", "--workers", "2", "--quiet"]


def swarmnav(*args: str) -> list[str]:
    return [sys.executable, "-m", "swarmnav.cli", *args]


def metrics(out: Path) -> dict[str, dict]:
    rows = csv.DictReader(open(out / "runs.csv"))
    return {r["key"]: {k: v for k, v in r.items() if k not in ("wall_time_s",) and not k.startswith("time.")}
            for r in rows}


def done(out: Path) -> int:
    try:
        with sqlite3.connect(out / "results.sqlite", timeout=1) as c:
            return c.execute("SELECT COUNT(*) FROM runs WHERE status='done'").fetchone()[0]
    except sqlite3.Error:
        return 0


def main() -> None:
    skip_ray = "--skip-ray" in sys.argv
    with tempfile.TemporaryDirectory() as d:
        d = Path(d)
        subprocess.run(swarmnav("run", "--method", "hes", "--scenario", "default_corridor", "--steps", "5",
                                "--out", str(d / "warm"), "--quiet"), check=True, stdout=subprocess.DEVNULL)
        t0 = time.perf_counter()
        subprocess.run(swarmnav(*CMD, "--out", str(d / "local")), check=True, stdout=subprocess.DEVNULL)
        t_local = time.perf_counter() - t0
        ref = metrics(d / "local")
        print(f"hes-sim3, 40 runs, --workers 2, local back end: {t_local:.1f} s   (target < 60 s); "
              f"{sum(r['status'] == 'done' for r in ref.values())}/40 done")
        if not skip_ray:
            t0 = time.perf_counter()
            subprocess.run(swarmnav(*CMD, "--backend", "ray", "--out", str(d / "ray")), check=True,
                           stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            t_ray = time.perf_counter() - t0
            same = metrics(d / "ray") == ref
            print(f"same sweep, --backend ray (local Ray, 2 CPUs): {t_ray:.1f} s; per-run metrics identical: {same}")
        out = d / "killed"
        p = subprocess.Popen(swarmnav(*CMD, "--out", str(out)), stdout=subprocess.DEVNULL, start_new_session=True)
        while done(out) < 15 and p.poll() is None:
            time.sleep(0.05)
        os.kill(p.pid, signal.SIGKILL)
        p.wait()
        kept = done(out)
        subprocess.run(swarmnav(*CMD, "--out", str(out)), check=True, stdout=subprocess.DEVNULL)
        same = metrics(out) == ref
        print(f"SIGKILL after {kept} finished runs, then rerun: {len(metrics(out))} runs, identical to the "
              f"uninterrupted sweep: {same}")


if __name__ == "__main__":
    main()
