"""HES acceptance grid: scenes x seeds 1-10 (N = 20, K = 1000), rule decisions, next to the paper.

Runs every (scene, seed) on a 2-process pool and prints one row per scene with the mean (and
worst case where it matters) of Y, R_goal, E_mean, R_unsafe (and per agent), d_clr_min, N_swarm, N_event and
S_scene, beside the paper's Table 5 values; then the acceptance checks of issue 3.

    PYTHONPATH=src python benchmarks/hes_acceptance.py                 # the four benchmark scenes
    PYTHONPATH=src python benchmarks/hes_acceptance.py --scenes tests/methods/hes/scenes/*.toml
    PYTHONPATH=src python benchmarks/hes_acceptance.py --set v_s=3.0 --seeds 1-3
"""

from __future__ import annotations

import argparse
import os
import sys
import time
import tomllib
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
SCENES = ["default_corridor", "narrow_alternating_gates", "dense_cross_blocks", "off_axis_goal"]
COLS = ["Y", "R_goal", "E_mean", "R_unsafe", "R_unsafe_agent", "d_clr_min", "N_swarm", "N_event", "S_scene", "L_mean", "collisions"]
W = {c: max(10, len(c) + 1) for c in COLS}  # column widths


def one(job):
    scene, seed, sets = job
    import swarmnav

    r = swarmnav.run("hes", scene, seed=seed, steps=1000, **sets)
    return scene, seed, dict(r.metrics), r.wall_time


def paper_table5() -> dict:
    ref = tomllib.loads((Path("/work/shared/reference/paper_results.toml")).read_text()) \
        if Path("/work/shared/reference/paper_results.toml").exists() else {}
    return ref.get("hes", {}).get("table5", {})


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", nargs="*", default=SCENES)
    ap.add_argument("--seeds", default="1-10")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    ap.add_argument("--per-seed", action="store_true", help="also print every run")
    a = ap.parse_args(argv)
    from swarmnav.experiments.spec import parse_seeds

    seeds = parse_seeds(a.seeds)
    sets = dict(s.split("=", 1) for s in a.set)
    jobs = [(sc, s, sets) for sc in a.scenes for s in seeds]
    t0 = time.perf_counter()
    with ProcessPoolExecutor(max_workers=a.workers) as pool:
        res = list(pool.map(one, jobs))
    ref = paper_table5()
    print(f"HES rule, seeds {a.seeds}, N=20, K=1000{'  set ' + str(sets) if sets else ''}")
    head = f"{'scene':28s}" + "".join(f"{c:>{W[c]}s}" for c in COLS)
    print(head)
    ok = True
    for sc in a.scenes:
        rows = [m for (s, _, m, _) in res if s == sc]
        if a.per_seed:
            for (s, seed, m, w) in res:
                if s == sc:
                    print(f"  seed {seed:2d}{'':18s}" + "".join(f"{m[c]:{W[c]}.3f}" for c in COLS) + f"  ({w:.2f} s)")
        mean = {c: float(np.mean([m[c] for m in rows])) for c in COLS}
        print(f"{Path(sc).stem:28s}" + "".join(f"{mean[c]:{W[c]}.3f}" for c in COLS))
        name = Path(sc).stem
        if name in ref:
            r = ref[name]
            print(f"{'  paper (rule)':28s}" + "".join(
                f"{r[c][0]:{W[c]}.3f}" if c in r else " " * W[c] for c in COLS))
        ymin = min(m["Y"] for m in rows)
        if name == "default_corridor":
            chk = (ymin == 1 and min(m["R_goal"] for m in rows) == 1 and mean["R_unsafe"] <= 0.117
                   and mean["N_swarm"] > 1)
            print(f"  check: Y=1 & R_goal=1 every seed, R_unsafe<=0.117, N_swarm>1 -> {'PASS' if chk else 'FAIL'}")
            ok &= chk
        elif name == "off_axis_goal":
            chk = ymin == 1
            print(f"  check: Y=1 every seed -> {'PASS' if chk else 'FAIL'}")
            ok &= chk
        elif name in ("narrow_alternating_gates", "dense_cross_blocks"):
            chk = mean["Y"] >= 0.8 and mean["R_unsafe"] <= 0.2
            print(f"  check: Y>=0.8, R_unsafe<=0.2 -> {'PASS' if chk else 'FAIL'}")
            ok &= chk
    walls = [w for (_, _, _, w) in res]
    print(f"{len(res)} runs in {time.perf_counter() - t0:.1f} s (rollout {np.mean(walls):.2f} s/run)")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.path.insert(0, str(ROOT / "src"))
    os.environ.setdefault("PYTHONPATH", str(ROOT / "src"))
    sys.exit(main())
