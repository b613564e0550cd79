"""NMPC on one Table II forest, step by step: progress, clearance and solver outcomes.

    PYTHONPATH=src python benchmarks/nmpc_probe.py [steps=2000] [density=0.15] [seed=1] [KEY=VALUE ...]

Flies the 15-robot sph-forest scene with the ``nmpc`` parameters given (e.g. ``prediction_horizon=2.0``,
``fallback=shift``) and prints, every 2.5 s of flight, the mean distance to the goal slots [m],
the mean speed [m/s], the least obstacle clearance and robot gap [m] and the IPOPT return
statuses so far; the first contact (clearance below the 0.2 m body radius) when it happens; the
first robot-robot contact with, for that pair at the control step before it, what each planned
against the other's broadcast prediction and how far the other then moved from that prediction;
then the method's summary and timings. The figures in docs/methods/nmpc.md quote it.
"""

import collections
import sys
import time

import numpy as np

from swarmnav.methods.base import Observation
from swarmnav.methods.nmpc import NmpcMethod
from swarmnav.methods.nmpc import solver as S
from swarmnav.sensing.geometry import signed_distance
from swarmnav.world import load_scenario


def _value(v: str):
    for cast in (int, float):
        try:
            return cast(v)
        except ValueError:
            pass
    return v


def main() -> None:
    args = dict(a.split("=", 1) for a in sys.argv[1:])
    steps, dens, seed = int(args.pop("steps", "2000")), args.pop("density", "0.15"), int(args.pop("seed", "1"))
    sc = load_scenario(f"random_forest:density={dens},seed={seed},length=12,r_min=1.0,r_max=2.0,min_passage=1.0")
    m = NmpcMethod(**{k: _value(v) for k, v in args.items()})
    rng = np.random.default_rng(seed)
    x = sc.spawn_positions(rng)
    v = np.zeros_like(x)
    m.reset(sc, x, v, rng)
    status: collections.Counter = collections.Counter()
    solve = S.solve

    def counted(*a, **k):
        r = solve(*a, **k)
        status[r.status] += 1
        return r

    S.solve = counted  # the method calls S.solve through the module
    t0, first, pair_first, views = time.process_time(), None, None, None
    for k in range(steps):
        old = None if m.pred is None else m.pred.copy()
        a, _ = m.act(Observation(k, k * m.dt, x, v), rng)
        if k % m.every == 0 and old is not None:
            views = (k, old[:, 1].copy(), m.pred[:, 0].copy())  # j as the others saw it one step on; as j planned it
        x, v = m.dynamics.step(x, v, a, m.dt)
        gap2 = np.linalg.norm(x[:, None] - x[None], axis=2) + 1e9 * np.eye(len(x))
        if pair_first is None and gap2.min() < 2 * sc.rules.body_radius and views is not None:
            pair_first = k
            i, j = np.unravel_index(int(gap2.argmin()), gap2.shape)
            ks, seen, plan = views
            print(f"first robot-robot contact at {k * m.dt:.2f} s: robots {i}, {j}, {gap2.min():.4f} m; at the control "
                  f"step {ks * m.dt:.2f} s before it, for {m.params.control_dt:g} s on: {i} planned "
                  f"{np.linalg.norm(plan[i] - seen[j]):.4f} m from {j}'s broadcast, {j} planned "
                  f"{np.linalg.norm(plan[j] - seen[i]):.4f} m from {i}'s; their plans "
                  f"{np.linalg.norm(plan[i] - plan[j]):.4f} m apart; {i} moved {np.linalg.norm(plan[i] - seen[i]):.4f} m "
                  f"and {j} {np.linalg.norm(plan[j] - seen[j]):.4f} m off their broadcasts", flush=True)
        clr = signed_distance(sc.geometry, x)
        if first is None and clr.min() < sc.rules.body_radius:
            first = k
            print(f"first contact at {k * m.dt:.2f} s: robot {int(clr.argmin())}, clearance {clr.min():.3f} m")
        if k % 250 == 0 or k == steps - 1:
            gap = np.linalg.norm(x[:, None] - x[None], axis=2) + 1e9 * np.eye(len(x))
            print(f"{k * m.dt:6.2f} s  to goal {np.linalg.norm(x - m.goals, axis=1).mean():6.2f} m  "
                  f"speed {np.linalg.norm(v, axis=1).mean():.2f} m/s  clearance {clr.min():.3f} m  "
                  f"gap {gap.min():.3f} m  {dict(status)}", flush=True)
    print(f"CPU {time.process_time() - t0:.1f} s")
    print("summary:", {k: round(val, 3) for k, val in m.summary().items()})
    print("timings [ms]:", {k: round(val, 1) for k, val in m.timings().items()})


if __name__ == "__main__":
    main()
