"""SPH Table II, EGO-Swarm rows: our ``ego-swarm`` on the sph-forest trials beside the paper's.

    # 1. the trials (20 forests per density and half; resumable)
    for D in 0.15 0.25 0.35 0.45; do
      swarmnav experiment sph-forest --set method=ego-swarm --set density=$D --seeds 1-20 --workers 1 \
          --out results/ego-swarm-$D-1-20
    done                                    # and --seeds 21-40 --out results/ego-swarm-$D-21-40
    # 2. tabulate (any number of stores; rows are grouped by density)
    PYTHONPATH=src python benchmarks/ego_table2.py results/ego-swarm-*-1-20
    PYTHONPATH=src python benchmarks/ego_table2.py results/ego-swarm-*-21-40

Columns as Table II (mean +- population std over the trials; Rate = ``sph_success``), then the
worst inter-robot and robot-obstacle distances, ``contact`` (trials with two robots closer than
0.4 m or a robot closer than 0.2 m to an obstacle), ``late`` (no contact, but a robot not within
3 m of the goal at 90 s), the fallbacks per trial, the planning time per robot per replan
(wall clock, one core: the median over trials of each trial's median and 95th percentile), and
the jerk energy over the trials without contact (a contact stops the robot in one step, and that
stop alone adds ~1e5 m^2/s^5 to its jerk integral).
"""

from __future__ import annotations

import json
import sqlite3
import sys
from pathlib import Path

import numpy as np

#: SPH paper (RA-L 2025) Table II, EGO-Swarm rows: d_obs -> Dist, Time, Rate, Eng, Comm, Vel
PAPER = {
    0.15: ("25.5+-2.3", "26.4+-1.4", "100", "100+-10", "0.30+-0.03", "0.97"),
    0.25: ("28.9+-2.5", "29.4+-1.5", "100", "138+-12", "0.30+-0.03", "0.98"),
    0.35: ("29.9+-2.6", "30.3+-1.6", "90", "158+-15", "0.30+-0.03", "0.99"),
    0.45: ("32.5+-2.9", "34.9+-2.0", "75", "180+-18", "0.30+-0.03", "0.93"),
}
COLS = [("flight_distance", "Dist (m)"), ("flight_time", "Time (s)"), ("sph_success", "Rate (%)"),
        ("jerk_energy", "Eng m2/s5"), ("comm_mbps", "Comm Mbps"), ("avg_velocity", "Vel (m/s)")]


def rows(dirs: list[Path]) -> list[dict]:
    out = []
    for d in dirs:
        db = d / "results.sqlite"
        if not db.exists():
            print(f"ego_table2: no results.sqlite in {d}", file=sys.stderr)
            continue
        for scenario, metrics in sqlite3.connect(db).execute(
                "select scenario, metrics from runs where status = 'done' order by seed"):
            r = json.loads(metrics)
            r["density"] = float(scenario.split("density=")[1].split(",")[0])
            out.append(r)
    return out


def table(dirs: list[Path]) -> None:
    rs = rows(dirs)
    head = " ".join(f"{h:>14}" for _, h in COLS)
    print(f"{'d_obs':>6} {'runs':>4} {head} {'min r-r':>7} {'min r-o':>7} {'contact':>7} {'late':>4} "
          f"{'fallb.':>6} {'plan ms med':>11} {'p95':>5} {'Eng no-contact':>14}")
    for dens in sorted({r["density"] for r in rs}):
        mine = [r for r in rs if r["density"] == dens]
        cells = []
        for key, _ in COLS:
            v = np.array([float(r[key]) for r in mine])
            cells.append(f"{100 * v.mean():.0f}" if key == "sph_success" else f"{v.mean():.3g}+-{v.std():.2g}")
        hit = [r["min_inter_robot_distance"] < 0.4 or r["min_robot_obstacle_distance"] < 0.2 for r in mine]
        late = sum(1 for r, h in zip(mine, hit) if not h and r["sph_success"] < 1.0)
        med = np.median([r.get("time.plan_ms_median", np.nan) for r in mine])
        p95 = np.median([r.get("time.plan_ms_p95", np.nan) for r in mine])
        print(f"{dens:>6g} {len(mine):>4} " + " ".join(f"{c:>14}" for c in cells)
              + f" {min(r['min_inter_robot_distance'] for r in mine):>7.2f}"
              + f" {min(r['min_robot_obstacle_distance'] for r in mine):>7.2f} {sum(hit):>7} {late:>4}"
              + f" {np.mean([r['ego_fallbacks'] for r in mine]):>6.0f} {med:>11.1f} {p95:>5.1f}"
              + f" {np.mean([r['jerk_energy'] for r, h in zip(mine, hit) if not h] or [np.nan]):>14.3g}")
        if dens in PAPER:
            print(f"{'paper':>6} {'20':>4} " + " ".join(f"{c:>14}" for c in PAPER[dens]))


if __name__ == "__main__":
    table([Path(a) for a in sys.argv[1:]])
