"""Both success tests of every run in a results store, the swarm test recomputed from the stored
trajectories: for stores flown before ``sph_swarm_success`` existed (docs/metrics.md, *Success for a
swarm*), so one rule can be read over every method without flying the trials again.

    PYTHONPATH=src python benchmarks/swarm_success_store.py results/table2 [--variants 'lsc/*']

Per run: each robot has arrived if its stored position was inside r(N) = 3 m x sqrt(max(N, 15) / 15)
of the scene's goal at some stored step; the run passes if every robot arrived and the run's stored
contact figures (closest two robots >= 2 body radii, closest obstacle >= 1 body radius, no crash)
are clean: the same definition as ``swarmnav.metrics.flight``. A run that already records
``sph_swarm_success`` is checked against the recomputed value (they must agree). Runs stored with
``--no-trajectories`` are skipped and counted.
"""

from __future__ import annotations

import argparse
import collections
import fnmatch
import json
import sqlite3
import sys
from pathlib import Path

import numpy as np


def recompute(store: Path, traj: str, scenario: str, n: int, metrics: dict, body_radius: float) -> float:
    from swarmnav.metrics.flight import swarm_goal_radius
    from swarmnav.world import load_scenario

    positions = np.load(store / traj)["positions"]
    goal = load_scenario(scenario, n=positions.shape[1]).goal_array
    r = swarm_goal_radius(positions.shape[1])
    arrived = (np.linalg.norm(positions - goal, axis=2) <= r).any(axis=0)
    clean = (metrics["min_inter_robot_distance"] >= 2 * body_radius
             and metrics["min_robot_obstacle_distance"] >= body_radius and metrics.get("crashes", 0.0) == 0.0)
    return float(bool(arrived.all()) and clean)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("store", type=Path)
    ap.add_argument("--variants", default="*", help="glob patterns, comma separated (default: every variant)")
    a = ap.parse_args(argv)
    db_path = a.store / "results.sqlite"
    if not db_path.is_file():
        print(f"swarm_success_store: {a.store} holds no results.sqlite", file=sys.stderr)
        return 2
    pats = [p.strip() for p in a.variants.split(",") if p.strip()]
    rows = sqlite3.connect(db_path).execute(
        "select variant, seed, scenario, n, metrics, trajectory, config, method from runs where status = 'done'").fetchall()
    table: dict[str, list[tuple[float, float]]] = collections.defaultdict(list)
    skipped = disagree = 0
    for variant, seed, scenario, n, metrics, traj, config, method in rows:
        if not any(fnmatch.fnmatchcase(variant, p) for p in pats):
            continue
        m = json.loads(metrics)
        if not traj:
            skipped += 1
            continue
        body = float(json.loads(config).get("rules", {}).get("body_radius", 0.2)) if config else 0.2
        swarm = recompute(a.store, traj, scenario, n, m, body)
        if "sph_swarm_success" in m and m["sph_swarm_success"] != swarm:
            disagree += 1
        table[variant if variant.startswith(method) else f"{method}: {variant}"].append((m["sph_success"], swarm))
    print(f"{'variant (method: when the name does not say)':<46} {'runs':>5} {'3 m test':>9} {'swarm test':>11}")
    for v in sorted(table):
        t = np.array(table[v])
        print(f"{v:<46} {len(t):>5} {int(t[:, 0].sum()):>5}/{len(t):<3} {int(t[:, 1].sum()):>7}/{len(t):<3}")
    if skipped:
        print(f"# {skipped} runs without a stored trajectory skipped")
    if disagree:
        print(f"swarm_success_store: {disagree} runs record a sph_swarm_success that the trajectories do not give",
              file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
