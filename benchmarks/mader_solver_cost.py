"""MADER's solver cost before / after a change, on the same forests in one session (one core).

    PYTHONPATH=src python benchmarks/mader_solver_cost.py [--density 0.35] [--seeds 1,2,3] [--horizon 30]
        [--before precheck=false] [--after precheck=true] [--set KEY=VALUE ...] [--before-src DIR]

Flies the 15-robot sph-forest scene (the Table II forest, as benchmarks/planner_times.py) for
``--horizon`` seconds per seed with the ``before`` and then the ``after`` parameters (each on top
of the ``--set`` ones), and prints per run: CPU seconds of the rollout (process time), replans,
IPOPT iterations per replan, replans proved infeasible before the solve, fallbacks, commits, and
whether the two runs' positions are bit-identical. The last line is the CPU ratio over all seeds.
``--before-src DIR`` flies the ``before`` runs with another copy of the package (DIR is its
``src``, e.g. ``git archive 2377a02 src | tar -x -C /tmp/base`` then ``/tmp/base/src``), in a
child process, one run at a time: a change of code measured against the code before it.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

import swarmnav
from swarmnav import portable

portable.restart()  # portable numerics, as the swarmnav command runs them (docs/determinism.md)

import numpy as np  # noqa: E402

from swarmnav.methods import registry  # noqa: E402
from swarmnav.methods.mader import solver  # noqa: E402
from swarmnav.sim import run  # noqa: E402
from swarmnav.world import load_scenario  # noqa: E402

FOREST = "random_forest:density={density},seed={seed},length=12,r_min=1.0,r_max=2.0,min_passage=1.0"


def _kv(items: list[str]) -> dict[str, str]:
    return dict(s.split("=", 1) for s in items)


def _fly(density: float, seed: int, horizon: float, params: list[str]) -> tuple[float, dict, np.ndarray]:
    """One run: CPU [s] of the rollout, its metrics, its positions. A 5-step run first compiles
    what Numba compiles (a fresh copy of the package has no cache), then the CasADi problems are
    dropped, so every timed run builds its own."""
    scene = load_scenario(FOREST.format(density=density, seed=seed))
    run(registry.make("mader", **_kv(params)), scene, seed=seed, steps=5)
    solver._IPOPT_CACHE.clear()
    m = registry.make("mader", **_kv(params))
    t0 = time.process_time()
    res = run(m, scene, seed=seed, steps=int(round(horizon / m.dt)))
    return time.process_time() - t0, res.metrics, res.positions


def _fly_in(src: str, density: float, seed: int, horizon: float, params: list[str]) -> tuple[float, dict, np.ndarray]:
    """:func:`_fly` in a child process that imports the package from ``src``."""
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "run.npz")
        cmd = [sys.executable, os.path.abspath(__file__), "--single", out, "--density", str(density),
               "--seeds", str(seed), "--horizon", str(horizon), "--before", *params]
        subprocess.run(cmd, check=True, env={**os.environ, "PYTHONPATH": os.path.abspath(src)})
        z = np.load(out)
        return float(z["cpu"]), json.loads(str(z["metrics"])), z["positions"]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--density", type=float, default=0.35)
    ap.add_argument("--seeds", default="1,2,3")
    ap.add_argument("--horizon", type=float, default=30.0, help="simulated seconds per run [s]")
    ap.add_argument("--before", nargs="*", default=["precheck=false"])
    ap.add_argument("--after", nargs="*", default=["precheck=true"])
    ap.add_argument("--set", nargs="*", default=[], dest="common")
    ap.add_argument("--before-src", default=None, help="fly the before runs with the package in this src directory")
    ap.add_argument("--single", default=None, help=argparse.SUPPRESS)  # child: one before run into this .npz
    a = ap.parse_args()
    if a.single:
        cpu, metrics, pos = _fly(a.density, int(a.seeds), a.horizon, a.common + a.before)
        np.savez(a.single, cpu=cpu, metrics=json.dumps(metrics), positions=pos)
        return
    print(f"# swarmnav {swarmnav.__version__}, numerics {portable.numerics()}")
    print(f"# d_obs = {a.density}, seeds {a.seeds}, {a.horizon:g} s each, 15 robots; before {a.before}"
          f"{' with ' + a.before_src if a.before_src else ''}, after {a.after}")
    print(f"{'seed':>4} {'build':>6} {'CPU s':>7} {'replans':>7} {'iter/replan':>11} {'proved infeasible':>17} "
          f"{'fallbacks':>9} {'commits':>7} {'same arrays':>11}")
    cpu = {"before": 0.0, "after": 0.0}
    for s in (int(x) for x in a.seeds.split(",")):
        pos = {}
        for tag, over in (("before", a.before), ("after", a.after)):
            if tag == "before" and a.before_src:
                c, mt, pos[tag] = _fly_in(a.before_src, a.density, s, a.horizon, a.common + over)
            else:
                c, mt, pos[tag] = _fly(a.density, s, a.horizon, a.common + over)
            cpu[tag] += c
            same = "" if tag == "before" else str(bool(np.array_equal(pos["before"], pos["after"])))
            print(f"{s:>4} {tag:>6} {c:>7.1f} {mt['mader_plans']:>7.0f} {mt['mader_evals_mean']:>11.1f} "
                  f"{mt.get('mader_infeasible_starts', 0.0):>17.0f} {mt['mader_fallbacks']:>9.0f} "
                  f"{mt['mader_commits']:>7.0f} {same:>11}", flush=True)
    print(f"# CPU before {cpu['before']:.1f} s, after {cpu['after']:.1f} s: {cpu['before'] / max(cpu['after'], 1e-9):.2f}x")


if __name__ == "__main__":
    main()
