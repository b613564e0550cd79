"""Digests of HES runs, to check that a change keeps runs identical (or within a tolerance).

``run`` writes one JSON line per (scene, seed): a SHA-256 of the recorded positions and
velocities (bit-exact identity) and the metrics the HES acceptance checks read. ``compare``
reads two such files and prints how many runs are bit-identical, and per scene whether Y and
R_goal are unchanged and how far E_mean and R_unsafe moved (the tolerances of a change that
may alter results at rounding level only: E_mean 0.05 m, R_unsafe 0.02).

    PYTHONPATH=src python benchmarks/hes_digest.py run --out new.jsonl              # 4 paper + 15 unseen scenes
    PYTHONPATH=src python benchmarks/hes_digest.py run --out f.jsonl --set preset=paper
    PYTHONPATH=src python benchmarks/hes_digest.py compare old.jsonl new.jsonl

To digest another commit, run this script with PYTHONPATH pointing at that commit's ``src``
(e.g. a ``git worktree``); it uses only ``swarmnav.run``, which every version has.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys
from collections import defaultdict
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PAPER = ["default_corridor", "narrow_alternating_gates", "dense_cross_blocks", "off_axis_goal"]
UNSEEN = sorted(str(p) for p in (ROOT / "tests" / "methods" / "hes" / "scenes").glob("*.toml"))
KEYS = ("Y", "R_goal", "E_mean", "R_unsafe", "collisions", "N_event", "N_swarm")
TOL = {"E_mean": 0.05, "R_unsafe": 0.02}


def one(job):
    scene, seed, sets = job
    import numpy as np

    import swarmnav

    r = swarmnav.run("hes", scene, seed=seed, steps=1000, **sets)
    h = hashlib.sha256(np.ascontiguousarray(r.positions).tobytes())
    h.update(np.ascontiguousarray(r.velocities).tobytes())
    return {"scene": Path(scene).stem if scene.endswith(".toml") else scene, "seed": seed,
            "sha": h.hexdigest()[:16], **{k: float(r.metrics.get(k, float("nan"))) for k in KEYS}}


def run(a) -> int:
    sets = dict(s.split("=", 1) for s in a.set)
    scenes = a.scenes or PAPER + UNSEEN
    lo, hi = (int(v) for v in a.seeds.split("-"))
    jobs = [(sc, s, sets) for sc in scenes for s in range(lo, hi + 1)]
    with ProcessPoolExecutor(max_workers=a.workers) as pool, open(a.out, "w") as f:
        for row in pool.map(one, jobs):
            f.write(json.dumps(row) + "\n")
    print(f"{len(jobs)} runs -> {a.out}")
    return 0


def load(path):
    return {(r["scene"], r["seed"]): r for r in map(json.loads, Path(path).read_text().splitlines())}


def compare(a) -> int:
    old, new = load(a.old), load(a.new)
    common = sorted(set(old) & set(new))
    same = sum(old[k]["sha"] == new[k]["sha"] for k in common)
    print(f"{len(common)} runs in both; bit-identical trajectories: {same} / {len(common)}")
    by = defaultdict(list)
    for k in common:
        by[k[0]].append(k)
    ok_all = True
    print(f"{'scene':28s} {'same':>5s} {'Y old/new':>11s} {'R_goal old/new':>15s} {'dE_mean':>8s} {'dR_unsafe':>9s}")
    for sc, ks in by.items():
        mean = lambda d, key: sum(d[k][key] for k in ks) / len(ks)  # noqa: E731
        y0, y1, g0, g1 = mean(old, "Y"), mean(new, "Y"), mean(old, "R_goal"), mean(new, "R_goal")
        de = mean(new, "E_mean") - mean(old, "E_mean")
        du = mean(new, "R_unsafe") - mean(old, "R_unsafe")
        ok = y0 == y1 and g0 == g1 and abs(de) <= TOL["E_mean"] and abs(du) <= TOL["R_unsafe"]
        ok_all &= ok
        n_same = sum(old[k]["sha"] == new[k]["sha"] for k in ks)
        print(f"{sc:28s} {n_same:3d}/{len(ks):<2d} {y0:5.2f}/{y1:<5.2f} {g0:7.3f}/{g1:<7.3f} {de:+8.4f} {du:+9.4f}"
              f"{'' if ok else '  <- outside tolerance'}")
    print("within tolerance on every scene" if ok_all else "OUTSIDE tolerance on some scene")
    return 0 if ok_all else 1


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("run")
    r.add_argument("--out", required=True)
    r.add_argument("--scenes", nargs="*")
    r.add_argument("--seeds", default="1-10")
    r.add_argument("--workers", type=int, default=1)
    r.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    c = sub.add_parser("compare")
    c.add_argument("old")
    c.add_argument("new")
    a = ap.parse_args(argv)
    return run(a) if a.cmd == "run" else compare(a)


if __name__ == "__main__":
    sys.exit(main())
