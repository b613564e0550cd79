"""Table 2 and Table 5 of the HES paper with an oracle column, and Fig. 5's paired per-seed change
of the oracle against the rule (docs/oracle.md), from one ``hes-sim3`` sweep over both builds and
both deciders:

    swarmnav experiment hes-sim3 --set "preset=paper|swarmnav" --set "decision=rule|oracle" \\
        --seeds 21-30 --workers 1 --no-trajectories --out results/oracle-sim3-21-30
    python benchmarks/oracle_paper_tables.py results/oracle-sim3-21-30

Table 2 (Simulation 1) is the default corridor of Simulation 3 (the same scene, N, K and
parameters; ``hes-sim1`` flies the same runs), so its rows are read from the sweep's
``default_corridor`` runs. Means over seeds, ± the population standard deviation (as the paper).
The paired change follows ``swarmnav.experiments.paired`` (HES Fig. 5): per seed
100 (oracle − rule) / |rule| [%], a seed with rule = 0 reported by its difference instead.
"""

from __future__ import annotations

import csv
import math
import sys
import tomllib
from collections import defaultdict
from pathlib import Path

import numpy as np

from swarmnav.experiments.paired import change

REF = Path(__file__).resolve().parents[1] / "src/swarmnav/experiments/reference/paper_results.toml"
SCENES = ("default_corridor", "narrow_alternating_gates", "dense_cross_blocks", "off_axis_goal")
T2 = ("E_mean", "E_90", "sigma_E", "N_swarm", "N_event", "R_unsafe", "L_mean", "Y", "R_goal")
T5 = ("Y", "R_goal", "E_mean", "S_scene")


def load(outs: list[str]) -> dict:
    """(scene, build, decider) -> seed -> row of runs.csv (finished runs only)."""
    by: dict = defaultdict(dict)
    for out in outs:
        for r in csv.DictReader(open(Path(out) / "runs.csv", encoding="utf-8")):
            if r["status"] == "done":
                by[(r["scenario"], r.get("param.preset") or "paper", r["param.decision"])][int(r["seed"])] = r
    return by


def val(r: dict, k: str) -> float:
    v = r.get(k)
    return float(v) if v not in (None, "") else math.nan


def main(outs: list[str]) -> None:
    by = load(outs)
    ref = tomllib.loads(REF.read_text(encoding="utf-8"))["hes"]
    builds = sorted({b for (_, b, _) in by})
    seeds_of = lambda s, b: sorted(set(by[(s, b, "rule")]) & set(by[(s, b, "oracle")]))  # noqa: E731

    print("Table 2 (Simulation 1, default corridor): mean ± std over seeds\n")
    print("| decider | seeds | " + " | ".join(T2) + " |")
    print("|---|---|" + "---|" * len(T2))
    for name in ("rule", "qwen2.5:3b"):
        row = ref["table2"][name]
        cell = lambda v: f"{v[0]:.3f} ± {v[1]:.3f}" if isinstance(v, list) else f"{v:.3f}"  # noqa: E731
        print(f"| {name}, paper | 1-10 | " + " | ".join(cell(row[m]) for m in T2) + " |")
    for b in builds:
        seeds = seeds_of("default_corridor", b)
        for d in ("rule", "oracle"):
            runs = by[("default_corridor", b, d)]
            cells = []
            for m in T2:
                x = np.array([val(runs[s], m) for s in seeds])
                cells.append(f"{x.mean():.3f}" if m in ("Y", "R_goal") else f"{x.mean():.3f} ± {x.std():.3f}")
            print(f"| {d}, ours, {b} | {seeds[0]}-{seeds[-1]} | " + " | ".join(cells) + " |")

    print("\nTable 5 (Simulation 3): means over seeds; crashes per run\n")
    print("| scene | decider | seeds | " + " | ".join(T5) + " | crashes |")
    print("|---|---|---|" + "---|" * (len(T5) + 1))
    for scene in SCENES:
        row = ref["table5"][scene]
        for i, name in enumerate(("rule", "qwen3.5:4b")):
            print(f"| {scene} | {name}, paper | 1-10 | " + " | ".join(f"{row[m][i]:.3f}" for m in T5) + " | |")
        for b in builds:
            seeds = seeds_of(scene, b)
            if not seeds:
                continue
            for d in ("rule", "oracle"):
                runs = by[(scene, b, d)]
                mean = lambda m: np.mean([val(runs[s], m) for s in seeds])  # noqa: E731
                print(f"| {scene} | {d}, ours, {b} | {seeds[0]}-{seeds[-1]} | "
                      + " | ".join(f"{mean(m):.3f}" for m in T5) + f" | {mean('crashes'):.1f} |")

    print("\nFig. 5: paired per-seed change, oracle against rule: mean of oracle − rule; median % change over "
          "the seeds with rule != 0 [%]; seeds better / equal / worse\n")
    print("| scene | build | seeds | " + " | ".join(f"Δ{m}" for m in T5) + " | choice points / run | changed |")
    print("|---|---|---|" + "---|" * (len(T5) + 2))
    lower_better = {"E_mean"}
    for scene in SCENES:
        for b in builds:
            seeds = seeds_of(scene, b)
            if not seeds:
                continue
            rule, orc = by[(scene, b, "rule")], by[(scene, b, "oracle")]
            cells = []
            for m in T5:
                pct, diff, sign = [], [], [0, 0, 0]
                for s in seeds:
                    a, o = val(rule[s], m), val(orc[s], m)
                    p, d = change(a, o)
                    if p is not None and a != 0.0:
                        pct.append(p)
                    diff.append(d)
                    d = d * (-1 if m in lower_better else 1)
                    sign[0 if d > 0 else 1 if d == 0 else 2] += 1
                med = f"{np.median(pct):+.0f} %" if pct else "–"
                cells.append(f"{np.mean(diff):+.3f}; {med}; {sign[0]}/{sign[1]}/{sign[2]}")
            points = sum(val(orc[s], "hes_oracle_decisions") for s in seeds)
            changed = sum(val(orc[s], "hes_oracle_changed") for s in seeds)
            share = f"{changed / points:.2f}" if points else "–"
            print(f"| {scene} | {b} | {seeds[0]}-{seeds[-1]} | " + " | ".join(cells)
                  + f" | {points / len(seeds):.1f} | {share} |")
    wall = [val(r, "time.oracle_s") for (sc, b, d), runs in by.items() if d == "oracle" for r in runs.values()]
    print(f"\noracle lookahead wall time: {np.nansum(wall):.0f} s over {len(wall)} oracle runs")


if __name__ == "__main__":
    main(sys.argv[1:] or ["results/oracle-sim3-21-30"])
