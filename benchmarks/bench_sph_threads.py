"""SPH with planning threads (issue 36): wall and CPU time of one large trial with ``threads`` = 1
and 2, the speed-up, and a digest that shows both runs are the same; and how much of the planning
runs without the GIL (what bounds the speed-up).

    PYTHONPATH=src python benchmarks/bench_sph_threads.py                  # 100 robots, 90 s, threads 1 and 2
    PYTHONPATH=src python benchmarks/bench_sph_threads.py --n 30 --horizon 20 --threads 1,2,3

Trials (each in a fresh subprocess, one after the other, so no run warms another):

- ``threads T``: the ``sph-scaling`` trial (the Table II forest, 8 m x 8 m spawn area) at
  ``--density`` with ``--n`` robots, forest and run seed ``--seed``, ``--horizon`` seconds, default
  build, ``threads = T``;
- ``gil`` (``--gil-horizon`` seconds, default the same, 0 skips it): the trial with one thread, every compiled
  kernel that releases the GIL (the A* searches, the L-BFGS spline) timed, to give the share of the
  planning time that can run in parallel and the share of the run that planning is.

Columns: ``wall s`` = wall-clock time of the run (after a 3-step warm-up that loads the compiled
kernels); ``cpu s`` = CPU time of the process, all threads (``time.process_time``); ``x real`` =
simulated / wall time; ``speed-up`` = wall time with one thread / with T; ``plan ms`` = median
wall-clock time per robot per replan; ``digest`` = the first 12 hex digits of the SHA-256 of the
run's positions, velocities and metrics (equal digests: bit-identical runs). Wall time depends on
what else the machine runs: the load average is printed first.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SCALING = ("random_forest:density={density},seed={seed},length=12,r_min=1.0,r_max=2.0,min_passage=1.0,"
           "spawn_length=8")  # sph-scaling
#: the compiled kernels declared nogil=True (module, name)
NOGIL = [("swarmnav.planning.maps", k) for k in ("_astar", "_astar3", "_astar3h", "_cost_to_go3", "_descend3",
                                                 "_nearest_free", "_nearest_free3", "_mark_discs", "_mark_balls")]
NOGIL.append(("swarmnav.planning.bspline", "_lbfgs_spline"))


def worker(a) -> None:
    """One trial in this process (``--worker``): prints one JSON line."""
    sys.path.insert(0, str(ROOT / "src"))
    import swarmnav  # before NumPy: swarmnav pins its numerics as it loads

    swarmnav.portable.restart()  # glibc's part of portable mode needs a restart (docs/determinism.md)
    import hashlib
    import importlib
    import time

    import numpy as np

    from swarmnav.methods.sph import Sph
    from swarmnav.world import load_scenario

    scn = load_scenario(SCALING.format(density=a.density, seed=a.seed), n=a.n)
    swarmnav.run(Sph(threads=a.threads), scn, seed=a.seed, steps=3)  # load the compiled kernels first
    spent: dict[str, float] = {}
    if a.gil:  # time every GIL-releasing kernel (module globals: the callers look them up at each call)
        for module, name in NOGIL:
            mod = importlib.import_module(module)

            def timed(*args, _f=getattr(mod, name), _name=name):
                t = time.perf_counter()
                try:
                    return _f(*args)
                finally:
                    spent[_name] = spent.get(_name, 0.0) + time.perf_counter() - t

            setattr(mod, name, timed)
    m = Sph(threads=a.threads)
    t0, c0 = time.perf_counter(), time.process_time()
    r = swarmnav.run(m, scn, seed=a.seed, horizon=a.horizon, plans=False)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    h = hashlib.sha256(np.ascontiguousarray(r.positions).tobytes())
    h.update(np.ascontiguousarray(r.velocities).tobytes())
    h.update(json.dumps(sorted(r.metrics.items())).encode())
    print(json.dumps({"wall": wall, "cpu": cpu, "sim": (r.positions.shape[0] - 1) * m.dt,
                      "plan": m.timings()["plan_ms_median"], "plan_total": sum(m._plan_ms) / 1e3,
                      "nogil": sum(spent.values()), "kernels": spent, "digest": h.hexdigest()[:12]}))


def trial(a, threads: int, horizon: float, gil: bool = False) -> dict:
    cmd = [sys.executable, __file__, "--worker", "--n", str(a.n), "--horizon", str(horizon), "--density",
           str(a.density), "--seed", str(a.seed), "--threads-one", str(threads)] + (["--gil"] if gil else [])
    p = subprocess.run(cmd, capture_output=True, text=True, env={**os.environ, "PYTHONPATH": str(ROOT / "src")})
    if p.returncode != 0:
        sys.exit(f"bench_sph_threads: the trial failed: {(p.stderr.strip().splitlines() or ['?'])[-1]}")
    return json.loads(p.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=100, help="robots")
    ap.add_argument("--density", type=float, default=0.35)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--horizon", type=float, default=90.0, help="simulated seconds of each trial")
    ap.add_argument("--threads", default="1,2", help="thread counts to fly, the first is the baseline")
    ap.add_argument("--gil-horizon", type=float, default=-1.0,
                    help="simulated seconds of the GIL trial (default: --horizon; 0: skip)")
    ap.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--threads-one", dest="threads_one", type=int, default=1, help=argparse.SUPPRESS)
    ap.add_argument("--gil", action="store_true", help=argparse.SUPPRESS)
    a = ap.parse_args()
    if a.worker:
        a.threads = a.threads_one
        worker(a)
        return
    load = ", ".join(f"{x:.2f}" for x in os.getloadavg())
    print(f"# sph-scaling, {a.n} robots, d_obs {a.density:g}, seed {a.seed}, {a.horizon:g} s, default build; "
          f"{os.cpu_count()} CPUs, load average {load} (1, 5, 15 min)")
    print(f"{'threads':>7} {'wall s':>7} {'cpu s':>7} {'x real':>7} {'speed-up':>8} {'plan ms':>8} {'digest':>13}",
          flush=True)
    base = None
    for t in [int(s) for s in a.threads.split(",") if s]:
        r = trial(a, t, a.horizon)
        base = base or r
        same = "same" if r["digest"] == base["digest"] else "DIFFERENT"
        print(f"{t:>7} {r['wall']:>7.1f} {r['cpu']:>7.1f} {r['sim'] / r['wall']:>7.2f} "
              f"{base['wall'] / r['wall']:>7.2f}x {r['plan']:>8.2f} {r['digest']:>13} {same}", flush=True)
    if a.gil_horizon < 0:
        a.gil_horizon = a.horizon
    if a.gil_horizon > 0:
        g = trial(a, 1, a.gil_horizon, gil=True)
        free = g["nogil"] / g["plan_total"]
        share = g["plan_total"] / g["wall"]
        par = free * share
        print(f"# GIL ({a.gil_horizon:g} s, one thread): planning {share:.0%} of the run's wall time, "
              f"{free:.0%} of it in GIL-free kernels ({', '.join(f'{k} {v:.1f} s' for k, v in g['kernels'].items())}); "
              f"so {par:.0%} of the run may overlap: at most {1 / (1 - par / 2):.2f}x on 2 free cores (Amdahl)")


if __name__ == "__main__":
    main()
