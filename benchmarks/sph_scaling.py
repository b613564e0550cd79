"""Reproduce SPH Fig. 6: coordination time and planning time against swarm size and density.

    swarmnav experiment sph-scaling --set "density=0.15|0.25|0.35|0.45" --set preset=queue --workers 1 --out results/sph-scaling-queue
    python benchmarks/sph_scaling.py results/sph-scaling-queue

Reads the store's ``results.sqlite`` (every finished run, whatever invocation wrote it) and
prints one row per (swarm size, density):

- ``coord t (s)``: ``coordination_time``, the physical time until the swarm first moves as one
  body (the speed of its centre reaches 0.8 of its cruise median; docs/metrics.md), mean +- std;
- ``plan (ms)``: planning time per robot per replan (``time.plan_ms_median`` of each run, their
  median), and its 95th percentile (median over runs), wall clock: most replans of a flight are
  short searches in the open past the forest, so the median is the cheap case and p95 the forest;
- ``coord step (ms)``: wall-clock cost of one coordination step (visibility + SPH + ESDF force)
  for the whole swarm (``time.coord_ms_median``, median over runs);
- success (every robot within 3 m of the goal at the end, no contact), the share of robots within
  3 m at the end, and the swarm's mean speed;
- worst inter-robot and robot-obstacle distances [m] and trials with a contact;
- ``success r(N)``: the same rule with the goal disc grown to hold N robots at the density at
  which 15 hold 3 m, r(N) = 3 m sqrt(N / 15) (3.5 m for 20 robots, 4.2 m for 30, 6 m for 60,
  7.7 m for 100), from the stored trajectories: a 3 m disc cannot hold 30 or more robots at the
  spacing the SPH repulsion keeps. Reported beside, never instead of, the 3 m rule.

Wall-clock columns depend on the machine and its load; compare them across rows of one run.
The paper's Fig. 6 (Section IV-C): "As the swarm size increases, the coordination time slightly
increases, and the planning time remains nearly constant"; higher density lowers success.
"""

from __future__ import annotations

import json
import sqlite3
import sys
from collections import defaultdict
from pathlib import Path

import numpy as np


R_GOAL, N_REF, BODY = 3.0, 15, 0.2  # [m], robots, [m]: the Table II success rule


def _success_scaled(trajectory: Path, scenario: str, n: int, metrics: dict) -> float:
    """1 if every robot ends within R_GOAL sqrt(n / N_REF) of the goal and no contact, else 0."""
    from swarmnav.world import load_scenario

    contact = metrics["min_inter_robot_distance"] < 2 * BODY or metrics["min_robot_obstacle_distance"] < BODY
    end = np.load(trajectory)["positions"][-1]
    goal = load_scenario(scenario).goal_array
    inside = np.linalg.norm(end - goal, axis=1) <= R_GOAL * np.sqrt(n / N_REF)
    return float(bool(inside.all()) and not contact)


def main(argv: list[str]) -> int:
    if not argv:
        print("sph_scaling: give one or more result directories (swarmnav experiment --out DIR)", file=sys.stderr)
        return 2
    for arg in argv:
        db = Path(arg) / "results.sqlite"
        if not db.exists():
            print(f"sph_scaling: no results.sqlite in {arg}", file=sys.stderr)
            return 2
        cells: dict[tuple[int, float], list[dict]] = defaultdict(list)
        rows = sqlite3.connect(db).execute(
            "select n, scenario, metrics, trajectory from runs where status = 'done'").fetchall()
        for n, scenario, metrics, trajectory in rows:
            density = float(scenario.split("density=")[1].split(",")[0])
            m = json.loads(metrics)
            m["success_rn"] = _success_scaled(Path(arg) / trajectory, scenario, int(n), m) if trajectory else np.nan
            cells[(int(n), density)].append(m)
        print(f"\n{arg}: {len(rows)} runs")
        print(f"{'N':>4} {'d_obs':>6} {'runs':>4} {'coord t (s)':>12} {'plan (ms)':>10} {'plan p95':>9} {'coord step (ms)':>15} "
              f"{'success (%)':>11} {'in 3 m':>7} {'success r(N) (%)':>16} {'Vel (m/s)':>9}")
        for (n, density), ms in sorted(cells.items()):
            def col(key: str) -> np.ndarray:
                return np.array([m[key] for m in ms], dtype=float)
            ct = col("coordination_time")
            print(f"{n:>4} {density:>6g} {len(ms):>4} {ct.mean():>6.2f}+-{ct.std():<5.2f} "
                  f"{np.median(col('time.plan_ms_median')):>10.2f} {np.median(col('time.plan_ms_p95')):>9.2f} "
                  f"{np.median(col('time.coord_ms_median')):>15.2f} "
                  f"{100 * col('sph_success').mean():>11.0f} {col('sph_arrived_fraction').mean():>7.2f} "
                  f"{100 * col('success_rn').mean():>16.0f} "
                  f"{col('avg_velocity').mean():>9.2f} {col('min_inter_robot_distance').min():>7.3f} "
                  f"{col('min_robot_obstacle_distance').min():>7.3f} "
                  f"{int(np.sum((col('min_inter_robot_distance') < 2 * BODY) | (col('min_robot_obstacle_distance') < BODY))):>7}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
