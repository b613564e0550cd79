"""Is there a way through each 3-D Table II forest? A full-knowledge grid search, per forest.

    PYTHONPATH=src python benchmarks/sph_forest3d_passage.py --density 0.45 --seeds 1-20
    PYTHONPATH=src python benchmarks/sph_forest3d_passage.py --density 0.45 --forest "h_min=5.5"   # no overlap

For each forest of ``sph-forest-3d`` (12 m long, 15 robots) the SPH planner's own 3-D grid
search (0.1 m voxels, 0.3 m inflation = the body clearance, the 0.9 m costly band, weight 10),
given the whole forest at once instead of what the robot has seen, searches from the spawn
centre to the goal. A forest with no path at this clearance cannot be crossed by any robot
without a contact, whatever the swarm does. ``--forest`` replaces the spec's generator
options after density and seed (default: the spec's ``n=15,h_min=3.0,length=12,overlap=true``).
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from swarmnav.experiments.spec import parse_seeds
from swarmnav.methods.sph.gridsearch import OccupancyMaps
from swarmnav.methods.sph.params import SphParams
from swarmnav.world import load_scenario

SPEC = "n=15,h_min=3.0,length=12,overlap=true"  # as experiments/specs/sph-forest-3d.toml


def has_way(spec: str, seed: int) -> tuple[bool, int]:
    """Whether the full-knowledge search finds a path, and the forest's number of trunks."""
    sc = load_scenario(spec)
    p = SphParams()  # the planner's own grid, clearances and weight
    maps = OccupancyMaps(sc.obstacles, sc.bounds, 1, p.grid_resolution, p.inflation, 1e9, margin=p.d_thr,
                         wide=p.plan_clearance, wide_cost=p.plan_clearance_cost, weight_3d=p.search_weight_3d)
    start = sc.spawn_positions(np.random.default_rng(seed)).mean(axis=0)
    maps.observe(0, start)  # the whole forest is within the 1e9 m sensing range
    return maps.search(0, start, sc.goal_array, p.max_expand) is not None, len(sc.obstacles) - 4


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--density", type=float, default=0.45)
    ap.add_argument("--seeds", default="1-20", help="forests, e.g. 1-20")
    ap.add_argument("--forest", default=SPEC, help="generator options after density and seed")
    a = ap.parse_args(argv)
    t0 = time.perf_counter()
    found, trunks = 0, []
    ss = parse_seeds(a.seeds)
    for s in ss:
        ok, k = has_way(f"random_forest_3d:density={a.density},seed={s},{a.forest}", s)
        found += ok
        trunks.append(k)
        print(f"  forest {s:3d}: {k:4d} trunks, way through: {'yes' if ok else 'no'}", flush=True)
    print(f"density {a.density:g}, {a.forest}: a way through at the 0.3 m body clearance in {found} of "
          f"{len(ss)} forests ({time.perf_counter() - t0:.0f} s)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
