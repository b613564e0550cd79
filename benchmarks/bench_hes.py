"""Speed of one HES run (1000 steps, N = 20, default_corridor, one core), alone or as a ratio
against another commit, and how a step's cost grows with the swarm size N.

Each measurement runs in a fresh subprocess pinned to one core: it warms up (Numba compiles
or loads its cache), then times the full ``swarmnav.run`` call (rollout + metrics) best of
``--repeat``. On a shared machine the CPU time is the steadier figure.

    PYTHONPATH=src python benchmarks/bench_hes.py                       # this tree
    PYTHONPATH=src python benchmarks/bench_hes.py --against 9201f1f     # ratio to a commit
    PYTHONPATH=src python benchmarks/bench_hes.py --scaling 20,100,500  # cost per step vs N

``--against REV`` checks REV out into a temporary git worktree and alternates the two trees'
measurements ``--rounds`` times, so both see the same machine load; the ratio printed is
(REV's best time) / (this tree's best time).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent.parent

# One timed measurement, run in a subprocess with PYTHONPATH set to the tree under test.
_CHILD = r"""
import json, os, sys, time
if hasattr(os, "sched_setaffinity"):
    os.sched_setaffinity(0, {sorted(os.sched_getaffinity(0))[0]})
import swarmnav
scene, steps, repeat, n = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4])
scn = swarmnav.load_scenario(scene)
scn = scn.with_n(n) if n > 0 else scn
swarmnav.run("hes", scn, seed=1, steps=20)  # warm-up: Numba cache, imports
walls, cpus = [], []
for _ in range(repeat):
    t, c = time.perf_counter(), time.process_time()
    res = swarmnav.run("hes", scn, seed=1, steps=steps)
    walls.append(time.perf_counter() - t)
    cpus.append(time.process_time() - c)
print(json.dumps({"wall": min(walls), "cpu": min(cpus), "n": int(res.positions.shape[1]),
                  "Y": res.metrics["Y"], "R_unsafe": res.metrics["R_unsafe"]}))
"""


def measure(src: Path, scene: str, steps: int, repeat: int, n: int = 0) -> dict:
    env = dict(os.environ, PYTHONPATH=str(src))
    out = subprocess.run([sys.executable, "-c", _CHILD, scene, str(steps), str(repeat), str(n)],
                         env=env, capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3, help="timed runs per measurement (best kept)")
    ap.add_argument("--rounds", type=int, default=3, help="--against: alternating measurements per tree")
    ap.add_argument("--scene", default="default_corridor")
    ap.add_argument("--steps", type=int, default=1000)
    ap.add_argument("--against", metavar="REV", help="a git revision to compare with")
    ap.add_argument("--scaling", metavar="N,N,...", help="time per step for these swarm sizes")
    ap.add_argument("--scaling-scene", default=str(HERE / "benchmarks" / "scenes" / "hes_scaling.toml"),
                    help="a scene large enough to hold the largest N")
    a = ap.parse_args(argv)
    here = HERE / "src"
    if a.scaling:
        print(f"hes, {a.scaling_scene}, {a.steps} steps, one core, best of {a.repeat}:")
        base = None
        for n in [int(s) for s in a.scaling.split(",")]:
            r = measure(here, a.scaling_scene, a.steps, a.repeat, n)
            per = r["cpu"] / a.steps * 1e3
            base = base or (per, n)
            print(f"  N = {r['n']:4d}: {per:7.3f} ms per step (cpu), {per / r['n'] * 1e3:6.1f} us per agent-step, "
                  f"cost ratio {per / base[0]:5.2f} for N ratio {n / base[1]:5.2f}")
        return 0
    if not a.against:
        r = measure(here, a.scene, a.steps, a.repeat)
        print(f"hes, {a.scene}, N = {r['n']}, {a.steps} steps, one core, best of {a.repeat}:")
        print(f"  wall {r['wall']:.3f} s   cpu {r['cpu']:.3f} s   (Y = {r['Y']:.0f}, R_unsafe = {r['R_unsafe']:.3f})")
        return 0
    with tempfile.TemporaryDirectory() as tmp:
        wt = Path(tmp) / "against"
        subprocess.run(["git", "-C", str(HERE), "worktree", "add", "--detach", "-q", str(wt), a.against], check=True)
        try:
            print(f"hes, {a.scene}, {a.steps} steps, one core; this tree vs {a.against}, "
                  f"{a.rounds} alternating rounds, best of {a.repeat} each:")
            best = {"this": [float("inf")] * 2, a.against: [float("inf")] * 2}
            for k in range(a.rounds):
                for name, src in (("this", here), (a.against, wt / "src")):
                    r = measure(src, a.scene, a.steps, a.repeat)
                    best[name] = [min(best[name][0], r["wall"]), min(best[name][1], r["cpu"])]
                    print(f"  round {k + 1} {name:>12}: wall {r['wall']:.3f} s  cpu {r['cpu']:.3f} s  "
                          f"(Y = {r['Y']:.0f}, R_unsafe = {r['R_unsafe']:.3f})")
            (tw, tc), (ow, oc) = best["this"], best[a.against]
            print(f"  best: this {tw:.3f} s wall / {tc:.3f} s cpu;  {a.against} {ow:.3f} s wall / {oc:.3f} s cpu")
            print(f"  speed-up (theirs / ours): wall {ow / tw:.2f}x, cpu {oc / tc:.2f}x")
        finally:
            subprocess.run(["git", "-C", str(HERE), "worktree", "remove", "--force", str(wt)], check=False)
    return 0


if __name__ == "__main__":
    sys.exit(main())
