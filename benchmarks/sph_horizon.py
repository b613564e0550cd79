"""SPH success of stored runs at earlier horizons: the Table II rule (every robot within 3 m of the
goal, no robots closer than 0.4 m, none closer than 0.2 m to an obstacle) applied to the first T
seconds of each stored trajectory, so one run at the longest horizon answers every shorter one.

    swarmnav experiment sph-narrow --set preset=queue --set horizon=90 --workers 1 --out results/sph-narrow-queue-90
    python benchmarks/sph_horizon.py results/sph-narrow-queue-90 --at 60,75,90

Per horizon: successes / runs, trials late (no contact, some robot outside 3 m), trials with a
contact, and the robots outside 3 m summed over the trials.
"""

from __future__ import annotations

import argparse
import json
import sqlite3
import sys
from pathlib import Path

import numpy as np

R_GOAL, BODY = 3.0, 0.2  # [m] the rule of swarmnav.metrics.flight (FlightParams defaults)


def _min_pair(pos: np.ndarray) -> np.ndarray:
    """(K,) smallest robot-robot distance at every step [m]."""
    n = pos.shape[1]
    i, j = np.triu_indices(n, 1)
    return np.linalg.norm(pos[:, i] - pos[:, j], axis=2).min(axis=1)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("store", type=Path)
    ap.add_argument("--at", default="60,90", help="horizons [s], comma separated")
    a = ap.parse_args(argv)
    try:
        horizons = [float(t) for t in a.at.split(",")]
    except ValueError:
        print(f"sph_horizon: --at wants seconds like 60,90, got {a.at!r}", file=sys.stderr)
        return 2
    db = a.store / "results.sqlite"
    if not db.exists():
        print(f"sph_horizon: no results.sqlite in {a.store}", file=sys.stderr)
        return 2
    from swarmnav.world import load_scenario

    rows = sqlite3.connect(db).execute(
        "select seed, steps, trajectory, scenario, config from runs where status = 'done' order by seed").fetchall()
    if not rows or any(t is None for _, _, t, _, _ in rows):
        print(f"sph_horizon: {a.store} has no stored trajectories (run without --no-trajectories)", file=sys.stderr)
        return 2
    runs = []
    for seed, steps, traj, scen, cfg in rows:
        z = np.load(a.store / traj)
        pos, clear = z["positions"], z["min_clearance"]
        horizon = steps * json.loads(cfg)["params"]["dt"]
        dt = horizon / (pos.shape[0] - 1)
        goal = load_scenario(scen).goal_array
        runs.append((seed, pos, clear, dt, goal, _min_pair(pos), horizon))
    print(f"{a.store}: {len(runs)} runs, stored horizon {runs[0][6]:g} s")
    print(f"{'T (s)':>6} {'success':>8} {'late':>5} {'contact':>7} {'robots out':>10}  failing seeds")
    for T in horizons:
        ok = late = touched = out = 0
        failing = []
        for seed, pos, clear, dt, goal, pair, horizon in runs:
            if T > horizon + 1e-9:
                print(f"sph_horizon: {T:g} s is beyond the stored {horizon:g} s", file=sys.stderr)
                return 2
            k = int(round(T / dt))
            outside = int((np.linalg.norm(pos[k] - goal, axis=1) > R_GOAL).sum())
            contact = pair[: k + 1].min() < 2 * BODY or clear[: k + 1].min() < BODY
            out += outside
            if contact:
                touched += 1
            elif outside:
                late += 1
            else:
                ok += 1
                continue
            failing.append(seed)
        print(f"{T:6g} {ok:>4}/{len(runs):<3} {late:>5} {touched:>7} {out:>10}  {failing}")
    return 0

if __name__ == "__main__":
    sys.exit(main())
