"""The oracle-against-rule table of docs/oracle.md, from an ``hes-sim3`` sweep over
``decision=rule|oracle`` (and ``preset=paper|swarmnav``).

    swarmnav experiment hes-sim3 --set "preset=paper|swarmnav" --set "decision=rule|oracle" \\
        --seeds 1-5 --workers 1 --no-trajectories --out results/oracle-sim3
    python benchmarks/oracle_table.py results/oracle-sim3 [more sweep directories, e.g. other horizons]

Per scene, build and oracle horizon (the rule runs are read from any of the directories): Y and R_goal (the means of Table 5), crashes per run, for the rule and the
oracle; the paired per-seed change of R_goal (seeds better / worse); and the oracle's own figures:
decision points with a choice per run, of these the share it changed and the share where the
best and worst feasible actions' objectives differ by more than ``oracle_margin`` and their mean
difference [m], lookahead
steps and wall time per decision point.
"""

from __future__ import annotations

import csv
import sys
from collections import defaultdict
from pathlib import Path


def main(outs: list[str]) -> None:
    by = defaultdict(dict)  # (scene, preset) -> "rule" | oracle horizon [s] -> seed -> row
    for out in outs:
        for r in csv.DictReader(open(Path(out) / "runs.csv", encoding="utf-8")):
            if r["status"] != "done":
                continue
            preset = r.get("param.preset") or "paper"  # hes-sim3's own preset
            label = "rule" if r["param.decision"] == "rule" else float(r.get("param.oracle_horizon") or HORIZON)
            by[(r["scenario"], preset)].setdefault(label, {})[int(r["seed"])] = r
    f = lambda r, k: float(r[k]) if r.get(k) not in (None, "") else 0.0  # noqa: E731
    print("| scene | build | horizon [s] | seeds | rule Y | oracle Y | rule R_goal | oracle R_goal | R_goal per seed (+/-) "
          "| rule crashes | oracle crashes | choice points / run | changed | best != worst | best - worst J [m] "
          "| lookahead steps / point | ms / point |")
    print("|" + "---|" * 17)
    for (scene, preset), d in sorted(by.items()):
        rule = d.get("rule", {})
        for h in sorted(k for k in d if k != "rule"):
            orc = d[h]
            seeds = sorted(set(rule) & set(orc))
            if not seeds:
                continue
            n = len(seeds)
            mean = lambda runs, k: sum(f(runs[s], k) for s in seeds) / n  # noqa: E731
            better = sum(f(orc[s], "R_goal") > f(rule[s], "R_goal") for s in seeds)
            worse = sum(f(orc[s], "R_goal") < f(rule[s], "R_goal") for s in seeds)
            points = sum(f(orc[s], "hes_oracle_decisions") for s in seeds)
            changed = sum(f(orc[s], "hes_oracle_changed") for s in seeds)
            spread = sum(f(orc[s], "hes_oracle_spread") for s in seeds)
            steps = sum(f(orc[s], "hes_oracle_steps") for s in seeds)
            wall = sum(f(orc[s], "time.oracle_s") for s in seeds)
            gap = sum(f(orc[s], "hes_oracle_gap") * f(orc[s], "hes_oracle_decisions") for s in seeds)
            per = lambda x, fmt: format(x / points, fmt) if points else "–"  # noqa: E731
            print(f"| {scene} | {preset} | {h:g} | {seeds[0]}-{seeds[-1]} | {mean(rule, 'Y'):.1f} | {mean(orc, 'Y'):.1f} "
                  f"| {mean(rule, 'R_goal'):.3f} | {mean(orc, 'R_goal'):.3f} | +{better} / -{worse} "
                  f"| {mean(rule, 'crashes'):.1f} | {mean(orc, 'crashes'):.1f} | {points / n:.1f} | {per(changed, '.2f')} "
                  f"| {per(spread, '.2f')} | {per(gap, '.1f')} | {per(steps, '.0f')} | {per(1e3 * wall, '.0f')} |")


#: oracle_horizon's default [s] (a run that does not set it)
HORIZON = 20.0

if __name__ == "__main__":
    main(sys.argv[1:] or ["results/oracle-sim3"])
