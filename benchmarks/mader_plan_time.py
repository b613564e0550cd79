"""MADER planning time per robot per replan (wall clock, one core) on a Table II forest.

    PYTHONPATH=src python benchmarks/mader_plan_time.py [STEPS] [DENSITY] [SEED] [KEY=VALUE ...]

Flies the 15-robot sph-forest scene for STEPS control steps of 0.01 s (default 60: each robot's
first replans) with the given parameters (e.g. ``algorithm=LD_SLSQP``, ``basis=bezier``) and
prints the method's timings() and summary().
"""

import sys
import time

import numpy as np

from swarmnav.methods.base import Observation
from swarmnav.methods.mader import MaderMethod
from swarmnav.world.generators import random_forest


def main() -> None:
    steps = int(sys.argv[1]) if len(sys.argv) > 1 else 60
    density = float(sys.argv[2]) if len(sys.argv) > 2 else 0.25
    seed = int(sys.argv[3]) if len(sys.argv) > 3 else 1
    scene = random_forest(density=density, seed=seed, length=12, r_min=1.0, r_max=2.0, min_passage=1.0)
    over = dict(a.split("=", 1) for a in sys.argv[4:])
    over = {k: (v if k in ("algorithm", "basis", "knots") else float(v)) for k, v in over.items()}
    m = MaderMethod(**over)
    rng = np.random.default_rng(seed)
    x = scene.spawn_positions(rng)
    v = np.zeros_like(x)
    m.reset(scene, x, v, rng)
    t0 = time.process_time()
    for k in range(steps):
        a, _ = m.act(Observation(k, k * m.dt, x, v), rng)
        x, v = m.dynamics.step(x, v, a, m.dt)
    print(f"{over} density {density} seed {seed}: {steps} steps, CPU {time.process_time() - t0:.1f} s")
    print("timings [ms]:", {k: round(v, 1) for k, v in m.timings().items()})
    print("summary:", {k: round(v, 3) for k, v in m.summary().items()})


if __name__ == "__main__":
    main()
