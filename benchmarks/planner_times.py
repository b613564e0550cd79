"""Planning time per robot per replan of every Table II planner, on one core, on the same forest.

    PYTHONPATH=src python benchmarks/planner_times.py [--density 0.35] [--seeds 1,2,3] [--horizon 30]

Each planner flies the sph-forest scene (15 robots) for ``--horizon`` seconds per seed; its
``timings()`` hook times each robot's replan (map update, search, optimisation, sampling): one
row per run with the median, 95th percentile and max [ms], and the replans counted. One process, one core. Wall-clock
figures depend on the machine and its load; say which when quoting them.
"""

from __future__ import annotations

import argparse
import platform

import numpy as np

import swarmnav
from swarmnav import portable
from swarmnav.methods import registry
from swarmnav.sim import run
from swarmnav.world import load_scenario

FOREST = "random_forest:density={density},seed={seed},length=12,r_min=1.0,r_max=2.0,min_passage=1.0"
#: the build of each planner the Table II spec flies (sph-table2.toml); other registered
#: planners can be named with --methods
PLANNERS = {"sph": {"preset": "guard"}, "ego-swarm": {}}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--density", type=float, default=0.35)
    ap.add_argument("--seeds", default="1,2,3")
    ap.add_argument("--horizon", type=float, default=30.0, help="simulated seconds per run [s]")
    ap.add_argument("--methods", default=",".join(PLANNERS))
    a = ap.parse_args()
    print(f"# {platform.processor() or platform.machine()}, numpy {np.__version__}, swarmnav {swarmnav.__version__}, "
          f"numerics {portable.numerics()}")
    print(f"# d_obs = {a.density}, seeds {a.seeds}, {a.horizon:g} s each, 15 robots")
    print(f"{'planner':<10} {'seed':>4} {'median ms':>10} {'p95 ms':>8} {'max ms':>8} {'run wall s':>10}")
    for name in a.methods.split(","):
        for s in (int(x) for x in a.seeds.split(",")):
            m = registry.make(name, **PLANNERS.get(name, {}))
            res = run(m, load_scenario(FOREST.format(density=a.density, seed=s)), seed=s,
                      steps=int(round(a.horizon / m.dt)))
            t = m.timings()
            print(f"{name:<10} {s:>4} {t['plan_ms_median']:>10.2f} {t['plan_ms_p95']:>8.2f} {t['plan_ms_max']:>8.2f} "
                  f"{res.wall_time:>10.1f}")


if __name__ == "__main__":
    main()
