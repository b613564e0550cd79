"""MADER's solver cost before / after a change, on the same forests in one process (one core).

    PYTHONPATH=src python benchmarks/mader_solver_cost.py [--density 0.35] [--seeds 1,2,3] [--horizon 30]
        [--before precheck=false] [--after precheck=true] [--set KEY=VALUE ...]

Flies the 15-robot sph-forest scene (the Table II forest, as benchmarks/planner_times.py) for
``--horizon`` seconds per seed with the ``before`` and then the ``after`` parameters (each on top
of the ``--set`` ones), and prints per run: CPU seconds of the rollout (process time), replans,
IPOPT iterations per replan, replans proved infeasible before the solve, fallbacks, commits, and
whether the two runs' positions are bit-identical. The last line is the CPU ratio over all seeds.
"""

from __future__ import annotations

import argparse
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


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--density", type=float, default=0.35)
    ap.add_argument("--seeds", default="1,2,3")
    ap.add_argument("--horizon", type=float, default=30.0, help="simulated seconds per run [s]")
    ap.add_argument("--before", nargs="*", default=["precheck=false"])
    ap.add_argument("--after", nargs="*", default=["precheck=true"])
    ap.add_argument("--set", nargs="*", default=[], dest="common")
    a = ap.parse_args()
    print(f"# swarmnav {swarmnav.__version__}, numerics {portable.numerics()}")
    print(f"# d_obs = {a.density}, seeds {a.seeds}, {a.horizon:g} s each, 15 robots; before {a.before}, after {a.after}")
    print(f"{'seed':>4} {'build':>6} {'CPU s':>7} {'replans':>7} {'iter/replan':>11} {'proved infeasible':>17} "
          f"{'fallbacks':>9} {'commits':>7} {'same arrays':>11}")
    cpu = {"before": 0.0, "after": 0.0}
    for s in (int(x) for x in a.seeds.split(",")):
        pos = {}
        for tag, over in (("before", a.before), ("after", a.after)):
            solver._IPOPT_CACHE.clear()  # each run builds its own CasADi problems: same start for both
            m = registry.make("mader", **_kv(a.common + over))
            scene = load_scenario(FOREST.format(density=a.density, seed=s))
            t0 = time.process_time()
            res = run(m, scene, seed=s, steps=int(round(a.horizon / m.dt)))
            c = time.process_time() - t0
            cpu[tag] += c
            pos[tag] = res.positions
            mt = res.metrics
            same = "" if tag == "before" else str(bool(np.array_equal(pos["before"], pos["after"])))
            print(f"{s:>4} {tag:>6} {c:>7.1f} {mt['mader_plans']:>7.0f} {mt['mader_evals_mean']:>11.1f} "
                  f"{mt.get('mader_infeasible_starts', 0.0):>17.0f} {mt['mader_fallbacks']:>9.0f} "
                  f"{mt['mader_commits']:>7.0f} {same:>11}", flush=True)
    print(f"# CPU before {cpu['before']:.1f} s, after {cpu['after']:.1f} s: {cpu['before'] / max(cpu['after'], 1e-9):.2f}x")


if __name__ == "__main__":
    main()
