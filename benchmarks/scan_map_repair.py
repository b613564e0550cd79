"""Why EGO-Swarm's plans fail on maps from scans (docs/sensing.md, What maps from scans do).

Forest 1 of Table II at density 0.35, seed 1, the first 15 s of EGO-Swarm: how many of its rebound
optimisations end with a curve that is not free on the robot's map, with the known map, with maps
from scans (``sense.scan_fill`` 0, 2 and 4 m), and, as a diagnostic only, with maps from scans plus
the whole footprint of every obstacle a return has touched. Prints one line per setting.

    PYTHONPATH=src python benchmarks/scan_map_repair.py [--horizon 15]
"""

from __future__ import annotations

import argparse

import numpy as np

import swarmnav
from swarmnav.methods.ego_swarm import method as ego_method
from swarmnav.methods.ego_swarm import optimizer
from swarmnav.planning import scanned
from swarmnav.sensing import signed_distance
from swarmnav.world import load_scenario
from swarmnav.world.obstacles import Geometry

SCENE = "random_forest:density=0.35,seed=1,length=12,r_min=1.0,r_max=2.0,min_passage=1.0"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--horizon", type=float, default=15.0, help="simulated seconds [s]")
    args = ap.parse_args()
    counts = {"free": 0, "blocked": 0}
    solve = optimizer.rebound_optimize

    def counted(*a, **k):
        out = solve(*a, **k)
        counts["free" if out.ok else "blocked"] += 1
        return out

    ego_method.rebound_optimize = counted  # count the outcomes; the planner is unchanged
    shapes = [Geometry.from_obstacles([o], dim=2) for o in load_scenario(SCENE).solid_obstacles]
    sweep = scanned.Scanner.sweep

    def footprints(self, obs, x):  # diagnostic: a touched obstacle's whole footprint enters the map
        gained = sweep(self, obs, x)
        m = self.maps
        for r in np.flatnonzero(gained):
            grid = m.grids[r].reshape(-1)
            hits = np.argwhere(m.esdf(r).values == 0.0)[:, ::-1] * m.resolution + m.origin
            for j, g in enumerate(shapes):
                if np.any(signed_distance(g, np.ascontiguousarray(hits)) < 0.1):
                    flat, level = m.footprints[j]
                    grid[flat] = np.maximum(grid[flat], level)
        return gained

    settings = [("known map", {}, False), ("scans", {"sense.map": "scans"}, False),
                ("scans, scan_fill 2 m", {"sense.map": "scans", "sense.scan_fill": 2.0}, False),
                ("scans, scan_fill 4 m", {"sense.map": "scans", "sense.scan_fill": 4.0}, False),
                ("scans + touched footprints (diagnostic)", {"sense.map": "scans"}, True)]
    for name, opts, oracle in settings:
        counts.update(free=0, blocked=0)
        scanned.Scanner.sweep = footprints if oracle else sweep
        swarmnav.run("ego-swarm", SCENE, seed=1, horizon=args.horizon, **opts)
        total = counts["free"] + counts["blocked"]
        print(f"{name:42s} curves not free: {counts['blocked']:5d} of {total:5d} ({counts['blocked'] / max(total, 1):.1%})")
    scanned.Scanner.sweep = sweep


if __name__ == "__main__":
    main()
