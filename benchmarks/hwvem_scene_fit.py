"""Calibrate the unpublished HWVEM mission scene (Table 2) on the baseline models only.

The paper's Figure 7 gives no coordinates, so the scene is one member of a small family of our
layouts (``hwvem_mission_family`` in ``swarmnav.world.generators``: tiny-circle offset,
rectangle offset, passage width, turn scale). Its parameters are fitted to the published P_s
means of the BASELINES only (VEM-A, IVEM-A, WVEM at N = 5, 20, 50: 9 cells), never to HWVEM-I /
HWVEM-II, which are then evaluated out of sample on held-out seeds.

    # baseline objective of every grid point (fit seeds), one worker, resumable stores under --out
    PYTHONPATH=src python benchmarks/hwvem_scene_fit.py --out out/fit --seeds 1-30 \
        --grid "tiny_offset=0.75|0.9|1.1|1.45" --grid "rect_offset=0.6|0.9" --grid "turn_scale=1|1.25|1.5"
    # all five models on held-out seeds (the fitted option hwvem_mission_fitted is rect_offset=0.6;
    # the reproduction scene hwvem_mission is the family's defaults, not fitted)
    swarmnav experiment hwvem-mission --set "n=5|20|50" --set scenario=hwvem_mission_fitted --seeds 101-200 \
        --workers 1 --out out/heldout

The objective is J = sum over the 9 baseline cells of (P_s_mean - paper P_s_mean)^2 [%^2]; each
grid point's cells and J are appended to ``OUT/fit.jsonl``."""

from __future__ import annotations

import argparse
import dataclasses
import inspect
import itertools
import json
import sys
import time
from pathlib import Path

from swarmnav.experiments import load_experiment, run_experiment
from swarmnav.experiments.report import paper_results
from swarmnav.world.generators import hwvem_mission_family

BASELINES = ("VEM-A", "IVEM-A", "WVEM")
SIZES = (5, 20, 50)

# The family's free numbers and their defaults (hwvem_mission), read off the generator itself.
DEFAULTS = {k: float(v.default) for k, v in inspect.signature(hwvem_mission_family).parameters.items() if k != "n"}


def scene_spec(p: dict[str, float]) -> str:
    """The generator spec string of one member of the family (usable as ``--set scenario=...``)."""
    return "hwvem_mission_family:" + ",".join(f"{k}={p[k]:g}" for k in DEFAULTS)


def paper_ps() -> dict[tuple[str, int], float]:
    ref = paper_results()["hwvem"]["table2"]
    return {(m, n): float(ref[f"N{n}"][m]["P_s"][0]) for n in SIZES for m in BASELINES}


def run_baselines(scene: str, out: Path, seeds: str) -> dict[tuple[str, int], dict[str, float]]:
    """The 9 baseline cells of hwvem-mission on ``scene``: P_s mean and quartiles per (model, N)."""
    exp = load_experiment("hwvem-mission", overrides={"n": "|".join(map(str, SIZES)), "scenario": scene},
                          seeds=seeds)
    exp = dataclasses.replace(exp, variants=tuple(v for v in exp.variants if v.name.split("[")[0] in BASELINES))
    _, summary = run_experiment(exp, out, workers=1, save_trajectories=False, progress=False)
    cells = {}
    for r in summary:
        model, n = r["variant"].split("[")[0], int(r["n"])
        cells[(model, n)] = {k: float(r[f"P_s_{k}"]) for k in ("mean", "p25", "p50", "p75")}
    return cells


def objective(cells: dict, ref: dict) -> float:
    return sum((cells[k]["mean"] - ref[k]) ** 2 for k in ref)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--param", action="append", default=[], metavar="KEY=VALUE", help="fixed family parameter")
    ap.add_argument("--grid", action="append", default=[], metavar="KEY=a|b|c", help="swept family parameter")
    ap.add_argument("--out", type=Path, default=Path("out/hwvem_fit"))
    ap.add_argument("--seeds", default="1-30")
    args = ap.parse_args(argv)
    fixed = {**DEFAULTS, **{k: float(v) for k, v in (kv.split("=", 1) for kv in args.param)}}
    if set(fixed) - set(DEFAULTS):
        ap.error(f"unknown parameter(s) {sorted(set(fixed) - set(DEFAULTS))} (known: {sorted(DEFAULTS)})")
    axes = {k: [float(x) for x in v.split("|")] for k, v in (g.split("=", 1) for g in args.grid)}
    if set(axes) - set(DEFAULTS):
        ap.error(f"unknown grid parameter(s) {sorted(set(axes) - set(DEFAULTS))}")
    ref = paper_ps()
    args.out.mkdir(parents=True, exist_ok=True)
    log = args.out / "fit.jsonl"
    for combo in itertools.product(*axes.values()):
        p = {**fixed, **dict(zip(axes, combo))}
        tag = "_".join(f"{k[:4]}{p[k]:g}" for k in DEFAULTS)
        t0 = time.perf_counter()
        cells = run_baselines(scene_spec(p), args.out / tag, args.seeds)
        j = objective(cells, ref)
        rec = {"params": p, "seeds": args.seeds, "J": j, "wall_s": time.perf_counter() - t0,
               "P_s": {f"{m}@{n}": cells[(m, n)] for (m, n) in ref}}
        with open(log, "a", encoding="utf-8") as f:
            f.write(json.dumps(rec) + "\n")
        row = " ".join(f"{m}@{n}={cells[(m, n)]['mean']:.1f}" for (m, n) in ref)
        print(f"J={j:8.1f}  {tag}  {row}  ({rec['wall_s']:.0f} s)", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
