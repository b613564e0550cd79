"""SPH real-time check: planning time per robot per replan and coordination time per control
step, against swarm size (issue 6: median planning time well under T_p = 0.2 s).

    PYTHONPATH=src python benchmarks/bench_sph.py [--sizes 15,30,60] [--density 0.35] [--steps 1000]
    PYTHONPATH=src python benchmarks/bench_sph.py --sizes 15,30,60,100 --spawn-length 8   # Fig. 6 sizes

Planning = map update + grid search + L-BFGS spline optimisation + sampling of one robot's
trajectory; coordination = visibility raycasts + SPH forces + ESDF force for the whole swarm.
Wall-clock figures depend on the machine and its load; the numbers of docs/history/sph.md
(*Table II under the first defaults*, Speed) were measured on the shared 2-core development machine
while other jobs ran.
"""

from __future__ import annotations

import argparse
import platform
import time

import numpy as np

from swarmnav.methods.sph import Sph
from swarmnav.sim import run
from swarmnav.world import load_scenario


FOREST = ("random_forest:density={density},seed={seed},length=12,r_min=1.0,r_max=2.0,min_passage=1.0,"
          "spawn_length={spawn}")  # as sph-forest (spawn 6 m deep) or sph-scaling (8 m: room for 100 robots)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="15,30,60")
    ap.add_argument("--density", type=float, default=0.35)
    ap.add_argument("--steps", type=int, default=1000)  # 10 s at the default 100 Hz
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--spawn-length", type=float, default=6.0)
    a = ap.parse_args()
    print(f"# {platform.processor() or platform.machine()}, numpy {np.__version__}")
    print(f"{'N':>4} {'plans':>6} {'plan med ms':>12} {'plan p95 ms':>12} {'plan max ms':>12} "
          f"{'coord med ms':>13} {'wall s':>8} {'sim s':>6}")
    warm = Sph(preset="paper")  # the README speed rows are the paper build
    run(warm, load_scenario(FOREST.format(density=a.density, seed=a.seed, spawn=a.spawn_length)),
        seed=a.seed, steps=20)  # compile the numba kernels outside the measurement
    for n in (int(s) for s in a.sizes.split(",")):
        scn = load_scenario(FOREST.format(density=a.density, seed=a.seed, spawn=a.spawn_length), n=n)
        m = Sph(preset="paper")
        t0 = time.perf_counter()
        run(m, scn, seed=a.seed, steps=a.steps)
        wall = time.perf_counter() - t0
        t = m.timings()
        plans = int(m.summary()["sph_plans"])
        print(f"{n:>4} {plans:>6} {t['plan_ms_median']:>12.2f} {t['plan_ms_p95']:>12.2f} {t['plan_ms_max']:>12.2f} "
              f"{t['coord_ms_median']:>13.3f} {wall:>8.1f} {a.steps * m.dt:>6.1f}")
    print(f"T_p = {Sph().params.T_p * 1e3:.0f} ms: a replan of one robot must take well under this.")


if __name__ == "__main__":
    main()
