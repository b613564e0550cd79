"""The cost of maps from scans (``sense.map = scans``, docs/sensing.md): CPU time per control step
of SPH and EGO-Swarm on a Table II forest (density 0.35, 15 robots) with the known map and with
each robot's map built from its own scans.

    PYTHONPATH=src python benchmarks/bench_scan_maps.py [--horizon 20] [--seed 1]

One process, one run each after a 3-step warm-up that loads the compiled kernels; CPU time is
``time.process_time`` over the run divided by the control steps flown. The two maps fly different
flights (the planners see different obstacles), so the figure is the cost of the whole step as
flown, scans, map updates and the planning they lead to together.
"""

from __future__ import annotations

import argparse
import time

import swarmnav
from swarmnav.world import load_scenario

FOREST = "random_forest:density=0.35,seed={seed},length=12,r_min=1.0,r_max=2.0,min_passage=1.0"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--horizon", type=float, default=20.0, help="simulated seconds per run [s]")
    ap.add_argument("--seed", type=int, default=1, help="forest and run seed")
    a = ap.parse_args()
    scn = load_scenario(FOREST.format(seed=a.seed), n=15)
    print(f"forest seed {a.seed}, 15 robots, {a.horizon:g} s; CPU ms per control step")
    print("| method | dt [s] | known | scans | scans / known |")
    print("|---|---|---|---|---|")
    for method in ("sph", "ego-swarm"):
        cost = {}
        for mode in ("known", "scans"):
            swarmnav.run(method, scn, seed=a.seed, steps=3, **{"sense.map": mode})
            t0 = time.process_time()
            r = swarmnav.run(method, scn, seed=a.seed, horizon=a.horizon, plans=False, **{"sense.map": mode})
            cost[mode] = 1e3 * (time.process_time() - t0) / (len(r.positions) - 1)
            dt = float(r.config["dt"])
        print(f"| `{method}` | {dt:g} | {cost['known']:.2f} | {cost['scans']:.2f} | "
              f"{cost['scans'] / cost['known']:.2f} |")


if __name__ == "__main__":
    main()
