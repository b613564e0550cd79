"""Is there a way through each 3-D Table II forest? A full-knowledge grid search, per forest.

    PYTHONPATH=src python benchmarks/sph_forest3d_passage.py --density 0.45 --seeds 1-20
    PYTHONPATH=src python benchmarks/sph_forest3d_passage.py --density 0.45 --forest "h_min=5.5"   # no overlap
    PYTHONPATH=src python benchmarks/sph_forest3d_passage.py --density 0.45 --below 5,4.5,4   # under a lower roof?

For each forest of ``sph-forest-3d`` (12 m long, 15 robots) the SPH planner's own 3-D grid
search (0.1 m voxels, 0.3 m inflation = the body clearance, the 0.9 m costly band, weight 10),
given the whole forest at once instead of what the robot has seen, searches from the spawn
centre to the goal. A forest with no path at this clearance cannot be crossed by any robot
without a contact, whatever the swarm does. ``--forest`` replaces the spec's generator
options after density and seed (default: the spec's ``n=15,h_min=3.0,length=12,overlap=true``).
``--below`` searches again under a roof lowered to each given altitude [m] (a slab over the whole
forest) and prints the highest altitude of each path found: how high a robot must climb to cross.
Each line also gives the share of the forest's floor under trunks at the spawn altitude (1.5 m;
points every 5 cm over the forest, 12 m x 18 m in the spec): d_obs counts volume, and trunks
shorter than the ceiling cover more floor than d_obs.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from swarmnav.experiments.spec import parse_seeds
from swarmnav.planning.maps import OccupancyMaps
from swarmnav.methods.sph.params import SphParams
from swarmnav.world import Scenario, load_scenario
from swarmnav.sensing import signed_distance
from swarmnav.world.obstacles import Box

SPEC = "n=15,h_min=3.0,length=12,overlap=true"  # as experiments/specs/sph-forest-3d.toml


def way_through(sc: Scenario, seed: int, roof: float | None = None) -> np.ndarray | None:
    """The full-knowledge search's path through forest ``sc`` (None: no way through); with
    ``roof`` [m], under a slab that closes everything above that altitude."""
    obstacles = tuple(sc.obstacles)
    if roof is not None:
        b = sc.bounds
        obstacles += (Box((b[0] - 1.0, b[1] - 1.0, roof), (b[3] + 1.0, b[4] + 1.0, b[5] + 1.0)),)
    p = SphParams()  # the planner's own grid, clearances and weight
    maps = OccupancyMaps(obstacles, sc.bounds, 1, p.grid_resolution, p.inflation, 1e9, margin=p.d_thr,
                         wide=p.plan_clearance, wide_cost=p.plan_clearance_cost, weight_3d=p.search_weight_3d)
    start = sc.spawn_positions(np.random.default_rng(seed)).mean(axis=0)
    maps.observe(0, start)  # the whole forest is within the 1e9 m sensing range
    return maps.search(0, start, sc.goal_array, p.max_expand)


def floor_cover(sc: Scenario, altitude: float = 1.5) -> float:
    """Share of forest ``sc``'s floor inside a trunk at ``altitude`` [m], on points 5 cm apart. The
    floor is where random_forest_3d draws trunks: x from 0 to 4 m before the goal, y between the
    inner faces of the side walls (its first two obstacles)."""
    length, half = sc.goal[0] - 4.0, sc.obstacles[0].min[1]
    x, y = np.meshgrid(np.arange(0.025, length, 0.05), np.arange(-half + 0.025, half, 0.05))
    pts = np.column_stack([x.ravel(), y.ravel(), np.full(x.size, altitude)])
    return float(np.mean(signed_distance(sc.geometry, pts) < 0.0))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--density", type=float, default=0.45)
    ap.add_argument("--seeds", default="1-20", help="forests, e.g. 1-20")
    ap.add_argument("--forest", default=SPEC, help="generator options after density and seed")
    ap.add_argument("--below", default="", help="also search under roofs at these altitudes [m], e.g. 5,4.5")
    a = ap.parse_args(argv)
    roofs = [float(z) for z in a.below.split(",") if z]
    t0 = time.perf_counter()
    found, trunks = 0, []
    under = [0] * len(roofs)
    covers = []
    ss = parse_seeds(a.seeds)
    for s in ss:
        sc = load_scenario(f"random_forest_3d:density={a.density},seed={s},{a.forest}")
        path, k = way_through(sc, s), len(sc.obstacles) - 4  # trunks: all but the walls, ground and ceiling
        found += path is not None
        trunks.append(k)
        cover = floor_cover(sc)
        covers.append(cover)
        line = (f"  forest {s:3d}: {k:4d} trunks, floor covered {100 * cover:.0f} %, way through: "
                f"{'yes' if path is not None else 'no'}")
        if path is not None:
            line += f" (highest {path[:, 2].max():.1f} m)"
        for i, z in enumerate(roofs):
            low = way_through(sc, s, roof=z)
            under[i] += low is not None
            line += f"; under {z:g} m: " + (f"yes ({low[:, 2].max():.1f} m)" if low is not None else "no")
        print(line, flush=True)
    print(f"density {a.density:g}, {a.forest}: a way through at the 0.3 m body clearance in {found} of "
          f"{len(ss)} forests ({time.perf_counter() - t0:.0f} s); floor covered at 1.5 m: "
          f"{100 * min(covers):.0f}-{100 * max(covers):.0f} % (mean {100 * np.mean(covers):.0f} %)")
    for z, u in zip(roofs, under):
        print(f"  under a roof at {z:g} m: a way through in {u} of {len(ss)}")
    return 0

if __name__ == "__main__":
    raise SystemExit(main())
