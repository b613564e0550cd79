"""Foundation speed figures (issue 2): APF rollout, neighbour search and dynamics at scale.

Run: ``python benchmarks/bench_foundation.py``. Pinned to one core; best of several repeats
after a warm-up (numba compilation excluded). Prints each figure next to its target.
"""

from __future__ import annotations

import os
import time

import numpy as np

import swarmnav
from swarmnav.dynamics import DampedDoubleIntegrator
from swarmnav.methods.apf import separation
from swarmnav.sensing import neighbor_lists, neighbor_pairs


def best_of(fn, repeats: int = 5) -> float:
    best = np.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def main() -> None:
    if hasattr(os, "sched_setaffinity"):
        os.sched_setaffinity(0, {sorted(os.sched_getaffinity(0))[0]})
    scn = swarmnav.load_scenario("default_corridor")
    swarmnav.run("apf", scn, seed=1, steps=20)  # warm-up: numba compile / cache load
    walls = []
    for _ in range(5):
        walls.append(swarmnav.run("apf", scn, seed=1, steps=1000).wall_time)
    t_apf = min(walls)
    print(f"apf, N=20, 360-ray LiDAR, 1000 steps (rollout loop): {t_apf:.3f} s   target < 0.3 s  "
          f"({0.3 / t_apf:.1f}x margin)")

    n = 100_000
    rng = np.random.default_rng(0)
    side = np.sqrt(n)  # density 1 agent / m^2
    x = rng.uniform(0, side, (n, 2))
    v = rng.normal(size=(n, 2))
    t_pairs = best_of(lambda: neighbor_pairs(x, 1.0), 3)
    i, _ = neighbor_pairs(x, 1.0)
    t_csr = best_of(lambda: neighbor_lists(x, 1.0), 3)
    t_per = best_of(lambda: neighbor_pairs(x % side, 1.0, box=side), 3)
    print(f"neighbour pairs, N=1e5, r=1 m ({len(i)} pairs): {t_pairs * 1e3:.1f} ms; CSR lists {t_csr * 1e3:.1f} ms; "
          f"periodic {t_per * 1e3:.1f} ms   (no N x N matrix: {n * n * 8 / 2**30:.0f} GiB avoided)")
    dyn = DampedDoubleIntegrator()
    a = rng.normal(size=(n, 2))
    t_dyn = best_of(lambda: dyn.step(x, v, a, 0.1), 5)
    t_sep = best_of(lambda: separation(x, 1.5, 1.0, 0.05), 3)
    print(f"damped double integrator step, N=1e5: {t_dyn * 1e3:.2f} ms; APF separation force N=1e5: {t_sep * 1e3:.1f} ms")


if __name__ == "__main__":
    main()
