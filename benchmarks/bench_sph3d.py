"""SPH in 3-D, real-time check (issue 13): planning time per robot per replan at M = 30 in a
3-D forest of about 40 x 20 x 6 m (target: median <= 10 ms).

    PYTHONPATH=src python benchmarks/bench_sph3d.py [--sizes 30] [--density 0.15] [--steps 1000] [--seed 1]

The world is ``random_forest_3d`` with a 26 m forest: bounds 40 x 19 x 6 m (walls, ground and
ceiling included). Planning = voxel map update + 26-connected A* to the goal + L-BFGS spline
optimisation + sampling of one robot's trajectory; coordination = 3-D visibility raycasts +
SPH forces + trilinear ESDF force for the whole swarm per control step. The run covers the first
``steps`` control steps (10 s at 100 Hz), after a short warm-up run that compiles the kernels.
Wall-clock figures depend on the machine and its load.
"""

from __future__ import annotations

import argparse
import platform
import time

import numpy as np

from swarmnav.methods.sph import Sph
from swarmnav.sim import run
from swarmnav.world import load_scenario

FOREST = "random_forest_3d:density={density},seed={seed},length=26"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="30")
    ap.add_argument("--density", type=float, default=0.15)
    ap.add_argument("--steps", type=int, default=1000)
    ap.add_argument("--seed", type=int, default=1)
    a = ap.parse_args()
    print(f"# {platform.processor() or platform.machine()}, numpy {np.__version__}")
    scn = load_scenario(FOREST.format(density=a.density, seed=a.seed))
    lo, hi = np.array(scn.bounds[:3]), np.array(scn.bounds[3:])
    print(f"# {scn.name}: {' x '.join(f'{e:g}' for e in hi - lo)} m, {len(scn.obstacles)} obstacles")
    print(f"{'N':>4} {'plans':>6} {'plan med ms':>12} {'plan p95 ms':>12} {'plan max ms':>12} "
          f"{'coord med ms':>13} {'reset s':>8} {'wall s':>8} {'sim s':>6}")
    run(Sph(preset="paper"), scn, seed=a.seed, steps=20)  # compile the numba kernels outside the measurement
    for n in (int(s) for s in a.sizes.split(",")):
        scn = load_scenario(FOREST.format(density=a.density, seed=a.seed), n=n)
        m = Sph(preset="paper")  # the README speed rows are the paper build
        t0 = time.perf_counter()
        run(m, scn, seed=a.seed, steps=1)
        reset = time.perf_counter() - t0  # ESDF + voxel footprints + the first plans
        m = Sph(preset="paper")  # the README speed rows are the paper build
        t0 = time.perf_counter()
        run(m, scn, seed=a.seed, steps=a.steps)
        wall = time.perf_counter() - t0
        t = m.timings()
        plans = int(m.summary()["sph_plans"])
        print(f"{n:>4} {plans:>6} {t['plan_ms_median']:>12.2f} {t['plan_ms_p95']:>12.2f} {t['plan_ms_max']:>12.2f} "
              f"{t['coord_ms_median']:>13.3f} {reset:>8.2f} {wall:>8.1f} {a.steps * m.dt:>6.1f}")
    print(f"target: plan median <= 10 ms per robot per replan (T_p = {Sph().params.T_p * 1e3:.0f} ms)")


if __name__ == "__main__":
    main()
