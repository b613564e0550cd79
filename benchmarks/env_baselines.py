"""The table of docs/env.md: a random policy and the three baselines, evaluated with
``swarmnav.env.evaluate`` on the four HES scenes (issue 20).

Every policy flies the same 100 s horizon on the same seeds; HES, APF and the random policy at
the environment's defaults (damped double integrator, dt = 0.1 s), SPH with its own dynamics
(``method_options("sph")``: saturated, dt = 0.01 s). ``--protocol`` chooses the episode:
``run`` (``terminate_at_goal=False``: every agent flies to the step limit and is scored at
its last state, as ``swarmnav run``) or ``env`` (the RL default: arrived agents hover and the
episode ends when all have arrived).

    python benchmarks/env_baselines.py --seeds 1-10 --workers 2 --out results/env_baselines

Writes ``runs.csv`` (one row per policy, scene and seed) and prints the markdown table of means.
"""

from __future__ import annotations

import argparse
import csv
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

try:
    import swarmnav  # noqa: F401
except ImportError:  # running from a checkout without installing
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))

SCENES = ("default_corridor", "narrow_alternating_gates", "dense_cross_blocks", "off_axis_goal")
POLICIES = ("random", "apf", "hes", "sph")
COLUMNS = ("Y", "R_goal", "R_unsafe", "d_clr_min", "collisions", "E_mean", "return_mean")


def one(job: tuple[str, str, int, str]) -> dict:
    from swarmnav.env import evaluate

    policy, scene, seed, protocol = job
    t0 = time.perf_counter()
    res = evaluate(policy, scene, [seed], terminate_at_goal=protocol == "env")[0]
    return {"policy": policy, "scene": scene, "seed": seed, "wall_s": time.perf_counter() - t0,
            **{k: res.metrics[k] for k in COLUMNS}, "episode_steps": res.metrics["episode_steps"]}


def seeds_of(text: str) -> list[int]:
    lo, _, hi = text.partition("-")
    return list(range(int(lo), int(hi or lo) + 1))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default="1-10")
    ap.add_argument("--policies", default=",".join(POLICIES))
    ap.add_argument("--protocol", choices=("run", "env"), default="run")
    ap.add_argument("--workers", type=int, default=1)
    ap.add_argument("--out", default="results/env_baselines")
    a = ap.parse_args()
    jobs = [(p, s, k, a.protocol) for p in a.policies.split(",") for s in SCENES for k in seeds_of(a.seeds)]
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    with ProcessPoolExecutor(a.workers) as pool, open(out / "runs.csv", "w", newline="") as f:
        w = None
        for row in pool.map(one, jobs):
            if w is None:
                w = csv.DictWriter(f, fieldnames=list(row))
                w.writeheader()
            w.writerow(row)
            f.flush()
            rows.append(row)
            print(f"{row['policy']:>6} {row['scene']:<26} seed {row['seed']:>2}  Y {row['Y']:.0f}  "
                  f"R_goal {row['R_goal']:.2f}  R_unsafe {row['R_unsafe']:.3f}  {row['wall_s']:.1f} s",
                  file=sys.stderr)
    print(f"| scene | policy | seeds | {' | '.join(COLUMNS)} | wall [s/run] |")
    print("|---|---|---|" + "---|" * (len(COLUMNS) + 1))
    for s in SCENES:
        for p in a.policies.split(","):
            r = [x for x in rows if x["scene"] == s and x["policy"] == p]
            if not r:
                continue
            mean = lambda k: sum(x[k] for x in r) / len(r)  # noqa: E731
            cells = " | ".join(f"{mean(k):.3g}" for k in COLUMNS)
            print(f"| {s} | {p} | {len(r)} | {cells} | {mean('wall_s'):.1f} |")


if __name__ == "__main__":
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    main()
