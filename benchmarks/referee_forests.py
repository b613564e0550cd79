"""Every registered method on the 2-D forests of issue 32: does any agent leave the world?

Before the world was closed, HES on ``random_forest:density=0.35,seed=1`` scored Y = 1 with
agents at y = 17.1 m (bounds +-12 m): the swarm flew round the forest, outside the world. This
script flies every method on those forests for the same simulated time and prints, per run,
how far any agent got outside the bounds [m] (0: never), Y, R_goal, collisions and crashes.
It exits 1 if any agent of any run left the world.

    python benchmarks/referee_forests.py --workers 2
    python benchmarks/referee_forests.py --methods hes,apf --horizon 60
"""

from __future__ import annotations

import argparse
import sys
import time
from concurrent.futures import ProcessPoolExecutor

import numpy as np

SCENES = (
    "random_forest:density=0.35,seed=1",
    "random_forest:density=0.35,seed=1,length=12,r_min=1.0,r_max=2.0,min_passage=1.0",
    "random_forest:density=0.35,seed=3,length=12,r_min=1.0,r_max=2.0,min_passage=1.0",
)


def fly(job: tuple[str, str, float, int]) -> dict:
    method, scene, horizon, seed = job
    import swarmnav

    t0 = time.perf_counter()
    res = swarmnav.run(method, scene, seed=seed, horizon=horizon)
    scn = swarmnav.load_scenario(scene)
    P = res.positions
    d = scn.dim
    outside = np.maximum(np.maximum(scn.lower - P[..., :d], P[..., :d] - scn.upper), 0.0).max()
    m = res.metrics
    return {"method": method, "scene": scene, "outside_m": float(outside), "Y": m["Y"], "R_goal": m["R_goal"],
            "collisions": m["collisions"], "crashes": m["crashes"], "wall_s": time.perf_counter() - t0}


def main(argv: list[str] | None = None) -> int:
    from swarmnav.methods import registry

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--methods", default=",".join(registry.names()), help="comma-separated (default: all)")
    ap.add_argument("--horizon", type=float, default=100.0, help="simulated time per run [s] (default 100)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--workers", type=int, default=1)
    a = ap.parse_args(argv)
    jobs = [(m, s, a.horizon, a.seed) for m in a.methods.split(",") for s in SCENES]
    with ProcessPoolExecutor(a.workers) as pool:
        rows = list(pool.map(fly, jobs))
    print(f"| method | scene | farthest outside the bounds [m] | Y | R_goal | collisions | crashes |")
    print("|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['method']} | `{r['scene']}` | {r['outside_m']:.3f} | {r['Y']:.0f} | {r['R_goal']:.2f} | "
              f"{r['collisions']:.0f} | {r['crashes']:.0f} |")
    left = [r for r in rows if r["outside_m"] > 0.0]
    print(f"\n{len(rows)} runs, {a.horizon:g} s each; {len(left)} with an agent outside the world")
    return 1 if left else 0


if __name__ == "__main__":
    sys.exit(main())
