"""SPH at swarm scale (issue 36): CPU seconds per simulated second for 15-100 robots, the
coordination and planning cost per step, and the 15-robot Table II trial; optionally the same
trials on an older commit, in the same run, with a digest that shows both fly the same.

    PYTHONPATH=src python benchmarks/bench_sph_scale.py                       # 90 s trials, this checkout
    PYTHONPATH=src python benchmarks/bench_sph_scale.py --horizon 20 --before 8f7b9e5 --preset guard

Trials (one core, one process at a time, each in a fresh subprocess so no run warms another):

- ``scaling N``: the ``sph-scaling`` geometry (Fig. 6: the Table II forest, 8 m x 8 m spawn area)
  at ``--density``, N = ``--sizes``, forest and run seed ``--seed``, ``--horizon`` seconds;
- ``table2 15``: the ``sph-forest`` trial (Table II: 15 robots, 6 m x 8 m spawn area), same
  density and seed, ``--table2-horizon`` seconds (90 s, the spec's horizon; 0 skips it).

Columns: ``cpu/sim`` = CPU time of the run (``time.process_time``, after a 3-step warm-up that
loads the compiled kernels) / simulated time; ``x real`` its inverse (how many times faster than
real time); ``coord ms`` = median wall-clock cost of one coordination step (visibility + SPH +
ESDF force, whole swarm); ``plan ms`` / ``p95`` = wall-clock time per robot per replan, median
and 95th percentile; ``digest`` = the first 12 hex digits of the SHA-256 of the run's positions
and velocities. With ``--before REV`` each trial is flown first by the code of git revision REV
(``git archive REV src`` into a temporary directory) and the ratio column is before / after CPU.
Wall-clock columns depend on the machine and its load; CPU time less so (both cores of the
development machine were busy with other jobs when docs/methods/sph.md's figures were measured).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
FOREST = ("random_forest:density={density},seed={seed},length=12,r_min=1.0,r_max=2.0,min_passage=1.0"
          "{spawn}")  # sph-forest; sph-scaling adds spawn_length=8


def worker(a) -> None:
    """One trial in this process (``--worker``): prints one JSON line."""
    sys.path.insert(0, a.src)
    import swarmnav  # before NumPy: swarmnav pins its numerics as it loads

    swarmnav.portable.restart()  # glibc's part of portable mode needs a restart (docs/determinism.md)
    import hashlib
    import time

    import numpy as np

    from swarmnav.methods.sph import Sph
    from swarmnav.world import load_scenario

    spawn = ",spawn_length=8" if a.geometry == "scaling" else ""
    scn = load_scenario(FOREST.format(density=a.density, seed=a.seed, spawn=spawn), n=a.n)
    build = {"preset": a.preset} if a.preset else {}
    swarmnav.run(Sph(**build), scn, seed=a.seed, steps=3)  # load the compiled kernels outside the measurement
    m = Sph(**build)
    t0 = time.process_time()
    r = swarmnav.run(m, scn, seed=a.seed, horizon=a.horizon, plans=False)
    cpu = time.process_time() - t0
    h = hashlib.sha256(np.ascontiguousarray(r.positions).tobytes())
    h.update(np.ascontiguousarray(r.velocities).tobytes())
    t = m.timings()
    print(json.dumps({"cpu": cpu, "sim": (r.positions.shape[0] - 1) * m.dt, "coord": t["coord_ms_median"],
                      "plan": t["plan_ms_median"], "p95": t["plan_ms_p95"], "digest": h.hexdigest()[:12]}))


def trial(src: str, geometry: str, n: int, horizon: float, a) -> dict:
    cmd = [sys.executable, __file__, "--worker", "--src", src, "--geometry", geometry, "--n", str(n),
           "--horizon", str(horizon), "--density", str(a.density), "--seed", str(a.seed)] + (
        ["--preset", a.preset] if a.preset else [])
    p = subprocess.run(cmd, capture_output=True, text=True, env={**os.environ, "PYTHONPATH": src})
    if p.returncode != 0:
        sys.exit(f"bench_sph_scale: the trial failed: {(p.stderr.strip().splitlines() or ['?'])[-1]}")
    return json.loads(p.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="15,30,60,100")
    ap.add_argument("--density", type=float, default=0.35)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--horizon", type=float, default=90.0, help="simulated seconds of each scaling trial")
    ap.add_argument("--table2-horizon", type=float, default=90.0, help="of the 15-robot Table II trial (0: skip)")
    ap.add_argument("--before", default="", help="git revision to fly the same trials with first")
    ap.add_argument("--preset", default="", help="SPH preset flown by both (default: each revision's default build; "
                    "--preset guard flies the same build on revisions before the crowd parts of 30+ robot swarms)")
    ap.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--src", default=str(ROOT / "src"), help=argparse.SUPPRESS)
    ap.add_argument("--geometry", default="scaling", help=argparse.SUPPRESS)
    ap.add_argument("--n", type=int, default=15, help=argparse.SUPPRESS)
    a = ap.parse_args()
    if a.worker:
        worker(a)
        return
    rows = [("scaling", int(s), a.horizon) for s in a.sizes.split(",") if s]
    if a.table2_horizon > 0:
        rows.append(("table2", 15, a.table2_horizon))
    with tempfile.TemporaryDirectory() as tmp:
        old = None
        if a.before:
            archive = subprocess.run(["git", "-C", str(ROOT), "archive", a.before, "src"], capture_output=True, check=True)
            subprocess.run(["tar", "-x", "-C", tmp], input=archive.stdout, check=True)
            old = str(Path(tmp) / "src")
        print(f"# d_obs {a.density:g}, seed {a.seed}, one core; CPU s per simulated s (x real = its inverse)"
              + (f"; before = {a.before}" if old else ""))
        head = f"{'trial':>8} {'N':>4} {'sim s':>6} {'code':>7} {'cpu s':>7} {'cpu/sim':>8} {'x real':>7} " \
               f"{'coord ms':>9} {'plan ms':>8} {'p95':>7} {'digest':>13}"
        print(head + (f" {'before/after':>12}" if old else ""), flush=True)
        for geometry, n, horizon in rows:
            runs = ([("before", old)] if old else []) + [("after" if old else "this", a.src)]
            got = {}
            for label, src in runs:
                r = got[label] = trial(src, geometry, n, horizon, a)
                line = (f"{geometry:>8} {n:>4} {r['sim']:>6.1f} {label:>7} {r['cpu']:>7.1f} {r['cpu'] / r['sim']:>8.3f} "
                        f"{r['sim'] / r['cpu']:>7.2f} {r['coord']:>9.3f} {r['plan']:>8.2f} {r['p95']:>7.2f} "
                        f"{r['digest']:>13}")
                if label == "after":
                    same = "same" if r["digest"] == got["before"]["digest"] else "DIFFERENT"
                    line += f" {got['before']['cpu'] / r['cpu']:>7.2f}x {same}"
                print(line, flush=True)


if __name__ == "__main__":
    main()
