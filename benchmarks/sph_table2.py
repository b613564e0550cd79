"""Reproduce SPH Table II: print the measured row per density next to the paper's.

    # 1. run the trials (20 forests per density; resumable; ~10 min each on 2 cores)
    swarmnav experiment sph-forest --set "density=0.15|0.25|0.35|0.45" --set preset=paper --workers 1 --out out/sph-forest-issue6-100hz
    swarmnav experiment sph-forest --set "density=0.15|0.25|0.35|0.45" --set preset=paper --set dt=0.02 --workers 1 --out out/sph-forest-issue6b  # 50 Hz
    swarmnav experiment sph-forest --set "density=0.15|0.25|0.35|0.45" --set method=apf --workers 1 --out out/sph-forest-apf-issue6
    swarmnav experiment sph-forest --set "density=0.15|0.25|0.35|0.45" --set method=hes --workers 1 --out out/sph-forest-hes
    # 2. tabulate
    PYTHONPATH=src python benchmarks/sph_table2.py out/sph-forest-issue6-100hz out/sph-forest-apf-issue6 out/sph-forest-hes

SPH's default ``dt = 0.01`` is the paper's >= 100 Hz swarm controller; ``--set dt=0.02`` the
released code's 50 Hz (docs/methods/sph.md, Control rate).
Columns as Table II (mean +- population std over the finished trials; Rate = success rate),
plus the worst inter-robot and robot-obstacle distances over all trials, and why trials failed:
``wait %`` = robot-steps with a slowed reference clock (``sph_waiting_fraction``). Reads the
store's ``results.sqlite``, so an interrupted sweep tabulates its finished runs. ``contact`` = trials with two robots closer than 0.4 m or a robot closer than 0.2 m to an
obstacle (the 0.2 m body radius), ``late`` = trials without contact where some robot was not
within 3 m of the goal at the end. ``Rate r=0.125`` is the success rate under the released code's
body (its particles are drawn as 0.25 m spheres, its map inflates obstacles by 0.099 m): every
robot within 3 m of the goal at the end, no two robots closer than 0.25 m and none closer than
0.125 m to an obstacle; reported beside, never instead of, the 0.2 m rule.
"""

from __future__ import annotations

import json
import sqlite3
import sys
import tomllib
from importlib import resources
from pathlib import Path

import numpy as np

COLS = [("flight_distance", "Dist (m)", "dist_m"), ("flight_time", "Time (s)", "time_s"),
        ("sph_success", "Rate (%)", "success_rate"), ("jerk_energy", "Eng m2/s5", "jerk_energy"),
        ("comm_mbps", "Comm Mbps", "comm_mbps"), ("avg_velocity", "Vel (m/s)", "velocity")]


def _paper() -> dict:
    text = resources.files("swarmnav.experiments").joinpath("reference", "paper_results.toml").read_text("utf-8")
    return tomllib.loads(text)["sph"]["table2"]["proposed"]


def _fmt_ref(v) -> str:
    return f"{v[0]:g}+-{v[1]:g}" if isinstance(v, list) else f"{v:g}"


def _rows(out_dir: Path) -> list[dict]:
    """Every finished run of the store (``results.sqlite``: also the runs of an interrupted sweep),
    as its metrics plus ``scenario`` and ``method``."""
    db = out_dir / "results.sqlite"
    if not db.exists():
        raise SystemExit(f"sph_table2: no results.sqlite in {out_dir}")
    rows = []
    for scenario, method, metrics in sqlite3.connect(db).execute(
            "select scenario, method, metrics from runs where status = 'done' order by seed"):
        r = json.loads(metrics)
        if "sph_success" not in r and "success_rate" in r:  # stores from before the key's rename
            r["sph_success"] = r["success_rate"]
        r.update(scenario=scenario, method=method)
        rows.append(r)
    return rows


def table(out_dir: Path) -> None:
    rows = _rows(out_dir)
    paper = _paper()
    dens = sorted({float(r["scenario"].split("density=")[1].split(",")[0]) for r in rows})
    method = rows[0]["method"] if rows else "?"
    print(f"\n{out_dir} ({method})")
    print(f"{'d_obs':>6} {'runs':>4} " + " ".join(f"{h:>18}" for _, h, _ in COLS) + f" {'min r-r':>8} {'min r-o':>8} {'contact':>7} {'late':>5} {'Rate r=0.125':>12} {'wait %':>6}")
    for d in dens:
        mine = [r for r in rows if f"density={d:g}," in r["scenario"]]
        cells = []
        for key, _, _ in COLS:
            v = np.array([float(r[key]) for r in mine])
            cells.append(f"{100 * v.mean():.0f}" if key == "sph_success" else f"{v.mean():.3g}+-{v.std():.2g}")
        rr = min(float(r["min_inter_robot_distance"]) for r in mine)
        ro = min(float(r["min_robot_obstacle_distance"]) for r in mine)
        hit = [float(r["min_inter_robot_distance"]) < 0.4 or float(r["min_robot_obstacle_distance"]) < 0.2 for r in mine]
        late = sum(1 for r, h in zip(mine, hit) if not h and float(r["sph_success"]) < 1.0)
        small = [float(r["sph_arrived_fraction"]) >= 1.0 and float(r["min_inter_robot_distance"]) >= 0.25
                 and float(r["min_robot_obstacle_distance"]) >= 0.125 for r in mine]
        wait = [float(r["sph_waiting_fraction"]) for r in mine if "sph_waiting_fraction" in r]
        print(f"{d:>6g} {len(mine):>4} " + " ".join(f"{c:>18}" for c in cells)
              + f" {rr:>8.3f} {ro:>8.3f} {sum(hit):>7} {late:>5} {100 * np.mean(small):>12.0f}"
              + f" {100 * np.mean(wait) if wait else float('nan'):>6.0f}")
        if d in paper["d_obs"]:
            k = paper["d_obs"].index(d)
            ref = [_fmt_ref(paper[p][k]) for _, _, p in COLS]
            print(f"{'paper':>6} {'20':>4} " + " ".join(f"{c:>18}" for c in ref))


if __name__ == "__main__":
    for arg in sys.argv[1:] or ["out/sph-forest"]:
        table(Path(arg))
