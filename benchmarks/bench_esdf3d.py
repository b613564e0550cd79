"""Speed of the 3-D ESDF on one core (issue 13: a 40 x 20 x 6 m world at 0.1 m in <= 0.5 s).

Run: ``python benchmarks/bench_esdf3d.py``. Builds a forest of 100 vertical trunks (radius
0.3-0.6 m, heights 2-6 m) plus three boxes and three spheres in a 40 x 20 x 6 m world, then
prints the node count, the median build time of several repeats (numba compilation excluded
by a warm-up build), the query rate of the trilinear lookup, and — for context — the rate of
the exact point kernel (``signed_distance``) on the same nodes. Pinned to CPU 0 where
``os.sched_setaffinity`` exists.
"""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path

import numpy as np

try:
    import swarmnav  # noqa: F401
except ImportError:  # running from a checkout without installing
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))

from swarmnav.sensing import Esdf, signed_distance
from swarmnav.world.obstacles import Box, Cylinder, Geometry, Sphere

TARGET_S = 0.5  # issue 13: build <= 0.5 s on one core
BOUNDS = (0.0, 0.0, 0.0, 40.0, 20.0, 6.0)  # [m]
RESOLUTION = 0.1  # [m]


def forest(seed: int = 0) -> Geometry:
    rng = np.random.default_rng(seed)
    obs: list = [Cylinder(tuple(rng.uniform([0, 0], [40, 20])), float(rng.uniform(0.3, 0.6)),
                          (0.0, float(rng.uniform(2.0, 6.0)))) for _ in range(100)]
    for _ in range(3):
        lo = rng.uniform([0, 0, 0], [36, 16, 3])
        obs.append(Box(tuple(lo), tuple(lo + rng.uniform([1, 1, 0.5], [4, 4, 3]))))
        obs.append(Sphere(tuple(rng.uniform([0, 0, 1], [40, 20, 5])), float(rng.uniform(0.5, 1.5))))
    return Geometry.from_obstacles(obs, dim=3)


def main(repeats: int = 7) -> None:
    if hasattr(os, "sched_setaffinity"):
        os.sched_setaffinity(0, {0})
    geom = forest()
    Esdf.build(geom, (0, 0, 0, 2, 2, 2), RESOLUTION)  # compile
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        esdf = Esdf.build(geom, BOUNDS, RESOLUTION)
        times.append(time.perf_counter() - t0)
    med = float(np.median(times))
    n_nodes = esdf.values.size
    print(f"3-D ESDF {esdf.shape[::-1]} nodes (x, y, z) = {n_nodes / 1e6:.2f} M, "
          f"{geom.n_circles} cylinders + {geom.n_polygons} boxes + {geom.n_spheres} spheres")
    print(f"build: median {med:.3f} s of {repeats} (min {min(times):.3f} s)  target <= {TARGET_S} s  "
          f"-> {'OK' if med <= TARGET_S else 'MISSED'}")

    rng = np.random.default_rng(1)
    pts = rng.uniform(BOUNDS[:3], BOUNDS[3:], (1_000_000, 3))
    esdf.query(pts[:10])
    t0 = time.perf_counter()
    esdf.query(pts)
    tq = time.perf_counter() - t0
    print(f"query (value + gradient, trilinear): {tq * 1e3:.1f} ms per 1e6 points ({tq * 1e3:.0f} ns/point)")

    sub = pts[:200_000]
    signed_distance(geom, sub[:10])
    t0 = time.perf_counter()
    signed_distance(geom, sub)
    ts = time.perf_counter() - t0
    print(f"exact signed_distance for context: {ts / len(sub) * 1e9:.0f} ns/point "
          f"(all {n_nodes / 1e6:.1f} M nodes one by one would take ~{ts / len(sub) * n_nodes:.2f} s)")


if __name__ == "__main__":
    main()
