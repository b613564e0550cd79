"""SPH Table II with every method flown: one row per (method build, d_obs, forest set) from an
``sph-table2`` store, the paper's row beside it.

    # the trials (resumable; a costly planner's variants can fly apart, e.g. on another machine)
    swarmnav experiment sph-table2 --seeds 1-40 --variants 'sph/*,sph-paper/*,ego-swarm/*' --out results/table2
    swarmnav experiment sph-table2 --seeds 1-40 --variants 'lsc/*' --out results/table2
    swarmnav report results/table2                 # every column, and the paired differences
    PYTHONPATH=src python benchmarks/table2_six.py results/table2

Rate = trials with ``sph_success`` (every robot within 3 m of the goal at 90 s, no contact).
Dist, Time and Vel are over the successful trials (a failed trial's distance ends where it
stopped); Eng is their median (one crash stops a robot in one step and puts 10^4-10^5 into a
mean); Comm, crashes and the closest distances are over every trial. Forests 1-20 chose every
parameter set that was chosen by looking at results; 21-40 are held out.
"""

from __future__ import annotations

import collections
import csv
import re
import sys
import tomllib
from importlib import resources
from pathlib import Path

import numpy as np

FAMILIES = ("sph", "sph-paper", "ego-swarm", "ego-swarm-paper", "mader", "mader-paper", "lsc", "lsc-paper",
            "nmpc", "nmpc-paper")
PAPER_ROW = {"sph": "proposed", "sph-paper": "proposed", "ego-swarm": "ego_swarm", "ego-swarm-paper": "ego_swarm",
             "mader": "mader", "mader-paper": "mader", "lsc": "lsc", "lsc-paper": "lsc", "nmpc": "nmpc",
             "nmpc-paper": "nmpc"}
DENSITIES = ("0.15", "0.25", "0.35", "0.45")


def main(store: str) -> None:
    path = Path(store) / "runs.csv"
    if not path.exists():
        sys.exit(f"{store}: no runs.csv (run 'swarmnav experiment sph-table2 ... --out {store}' first)")
    with open(path, newline="", encoding="utf-8") as f:
        rows = [r for r in csv.DictReader(f) if r["status"] == "done"]
    paper = tomllib.loads(resources.files("swarmnav.experiments").joinpath(
        "reference", "paper_results.toml").read_text("utf-8"))["sph"]["table2"]
    groups = collections.defaultdict(list)
    for r in rows:
        fam, d = r["variant"].split("/")
        groups[(fam, d, "1–20" if int(r["seed"]) <= 20 else "21–40")].append(r)

    def col(rs, k):
        return np.array([float(r[k]) for r in rs]) if rs else np.array([np.nan])

    print("| method | d_obs | forests | trials | Rate [%] | Dist [m] | Time [s] | Vel [m/s] | Eng [m²/s⁵] | "
          "Comm [Mbit/s] | crashes per trial | closest pair [m] | least clearance [m] |")
    print("|---|---|---|--:|--:|---|---|--:|--:|--:|--:|--:|--:|")
    for fam in FAMILIES:
        for i, d in enumerate(DENSITIES):
            for seeds in ("1–20", "21–40"):
                rs = groups.get((fam, d, seeds))
                if not rs:
                    continue
                ok = [r for r in rs if float(r["sph_success"]) == 1.0]
                dist, tim = col(ok, "flight_distance"), col(ok, "flight_time")
                line = (f"| {fam} | {d} | {seeds} | {len(rs)} | {100 * len(ok) / len(rs):.0f} | "
                      f"{dist.mean():.1f} ± {dist.std():.1f} | {tim.mean():.1f} ± {tim.std():.1f} | "
                      f"{col(ok, 'avg_velocity').mean():.2f} | {np.median(col(ok, 'jerk_energy')):.3g} | "
                      f"{col(rs, 'comm_mbps').mean():.3f} | {col(rs, 'crashes').mean():.1f} | "
                      f"{col(rs, 'min_inter_robot_distance').min():.3f} | "
                        f"{col(rs, 'min_robot_obstacle_distance').min():.3f} |")
                print(re.sub(r"(?<=\| )nan( ± nan)?(?= \|)", "–", line))  # no successful trial: no value
            p = paper[PAPER_ROW[fam]]
            if fam.endswith("-paper") or not any(groups.get((fam, d, s)) for s in ("1–20", "21–40")):
                continue
            print(f"| *paper* | {d} | | 20 | {p['success_rate'][i]:g} | {p['dist_m'][i][0]} ± {p['dist_m'][i][1]} | "
                  f"{p['time_s'][i][0]} ± {p['time_s'][i][1]} | {p['velocity'][i]} | {p['jerk_energy'][i][0]} | "
                  f"{p['comm_mbps'][i][0]} | | | |")


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    main(sys.argv[1])
