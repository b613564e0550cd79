"""Wall time of the two flocking methods: one Table II run (15 robots, 90 s of 0.02 s steps on the
``sph-forest`` forest at density 0.25, seed 1) and one 3-D run (``sph_cluttered_3d``, 30 robots,
100 s), the median of ``--repeat`` runs each after a warm-up (Numba compiled, caches filled).

Run: ``python benchmarks/bench_flocking.py [--repeat 3]``. docs/methods/flocking.md (*Speed*)
quotes its figures.
"""

from __future__ import annotations

import argparse
import statistics
import time

import swarmnav

FOREST = "random_forest:density=0.25,seed=1,length=12,r_min=1.0,r_max=2.0,min_passage=1.0"
CASES = [(FOREST, 90.0, "Table II forest, 15 robots, 90 s"), ("sph_cluttered_3d", 100.0, "3-D, 30 robots, 100 s")]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    for scene, horizon, label in CASES:
        for method in ("olfati-saber", "vasarhelyi"):
            swarmnav.run(method, scene, seed=1, steps=5)  # warm-up
            times = []
            for _ in range(args.repeat):
                t = time.perf_counter()
                swarmnav.run(method, scene, seed=1, horizon=horizon)
                times.append(time.perf_counter() - t)
            print(f"{method:13s} {label:34s} median {statistics.median(times):6.2f} s  "
                  f"({' '.join(f'{x:.2f}' for x in times)})", flush=True)


if __name__ == "__main__":
    main()
