"""How many SPH robots one goal disc holds: N robots gather at one goal in open space.

    python benchmarks/sph_goal_crowd.py --n 10,15,20,30,60 --preset queue,guard,paper

Open plane (no obstacle), the swarm spawned in a 12 m x 12 m block whose centre is 26 m from
the goal, 90 s (9000 steps of 0.01 s), seed 1. Per preset and swarm size: the robots' distance to
the goal at the end (largest and median) [m], the share within the Table II disc (3 m), and the
largest distance 5 s earlier (equal: the crowd has settled).

Why it matters: the repulsion of Algorithm 1 (line 9, k_rep sum q_ij / |q_ij|^2) is 1/r with no
cut-off inside R = 20 m, so the robots already gathered push a late one out with about
(robots gathered) x k_rep / (crowd radius) m/s^2, against a pull that does not grow with N. The
disc that holds the crowd grows with N faster than sqrt(N): a fixed 3 m disc holds 15 robots,
not 30 (docs/methods/sph.md, *Final approach and band guard*).
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

R_GOAL = 3.0  # [m] the Table II rule (swarmnav.metrics.flight.FlightParams.r_goal)


def crowd(n: int, preset: str, horizon: float, seed: int, overrides: dict | None = None
          ) -> tuple[float, float, float, float, float]:
    """(largest, median distance to the goal at the end [m], share within R_GOAL, largest 5 s
    earlier [m], closest two robots over the run [m])."""
    import swarmnav
    from swarmnav.world import from_dict

    scn = from_dict({"name": "crowd", "world": {"bounds": [-40.0, -40.0, 60.0, 40.0]},
                     "swarm": {"n": n, "spawn": [-12.0, -6.0, 0.0, 6.0]}, "goal": {"position": [20.0, 0.0]}})
    res = swarmnav.run("sph", scn, seed=seed, horizon=horizon, preset=preset, **(overrides or {}))
    dt = horizon / (res.positions.shape[0] - 1)
    r = np.linalg.norm(res.positions - np.array([20.0, 0.0]), axis=2)
    earlier = r[max(0, len(r) - 1 - round(5.0 / dt))]
    return (float(r[-1].max()), float(np.median(r[-1])), float(np.mean(r[-1] <= R_GOAL)), float(earlier.max()),
            float(res.metrics["min_inter_robot_distance"]))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", default="10,15,20,30,60", help="swarm sizes, comma separated")
    ap.add_argument("--preset", default="queue,guard", help="SPH presets, comma separated")
    ap.add_argument("--horizon", type=float, default=90.0, help="simulated time [s]")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                    help="SPH parameter applied on top of every preset (repeatable), e.g. rep_cutoff=2")
    a = ap.parse_args(argv)
    try:
        sizes = [int(s) for s in a.n.split(",")]
        if any(s < 1 for s in sizes):
            raise ValueError
    except ValueError:
        print(f"sph_goal_crowd: --n wants positive robot counts like 15,20,30, got {a.n!r}", file=sys.stderr)
        return 2
    if not a.horizon > 5.0:
        print(f"sph_goal_crowd: --horizon must be more than 5 s, got {a.horizon}", file=sys.stderr)
        return 2
    from swarmnav.errors import ConfigError
    overrides = {}
    for kv in a.set:
        key, eq, value = kv.partition("=")
        if not eq:
            print(f"sph_goal_crowd: --set wants KEY=VALUE, got {kv!r}", file=sys.stderr)
            return 2
        overrides[key.strip()] = value.strip()  # the method's parameter record coerces it

    print(f"{'preset':<9} {'N':>4} {'largest [m]':>12} {'median [m]':>11} {'within 3 m':>11} "
          f"{'largest 5 s before [m]':>23} {'min r-r [m]':>12}")
    for preset in a.preset.split(","):
        for n in sizes:
            try:
                big, med, share, before, rr = crowd(n, preset, a.horizon, a.seed, overrides)
            except ConfigError as e:
                print(f"sph_goal_crowd: {e}", file=sys.stderr)
                return 2
            print(f"{preset:<9} {n:>4} {big:>12.2f} {med:>11.2f} {share:>11.2f} {before:>23.2f} {rr:>12.3f}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
