"""IPOPT options for MADER's problems, replayed on problems recorded in closed loop (one core).

    PYTHONPATH=src python benchmarks/mader_ipopt_options.py [--density 0.35] [--seed 1] [--steps 1000]
        [--replay 200:500]

Flies the 15-robot sph-forest scene (the Table II forest) for ``--steps`` control steps with the
default build, recording every IPOPT problem with its initial guess and result; then solves the
``--replay`` slice of them again under each option set of VARIANTS (the CasADi problems are built
before the clock starts). Per variant: CPU [ms per solve], IPOPT iterations (mean, median),
solves that hit max_iter, feasible plans (feasible: every constraint within eps_tol, our own
test), and how far the plans differ from the default options' ones. The same problems, the same
process: the ratios are comparable, the absolute times depend on the machine's load.
"""

from __future__ import annotations

import argparse
import time

import swarmnav
from swarmnav import portable

portable.restart()  # portable numerics, as the swarmnav command runs them (docs/determinism.md)

import numpy as np  # noqa: E402

from swarmnav.methods.mader import MaderMethod  # noqa: E402
from swarmnav.methods.mader import solver as S  # noqa: E402
from swarmnav.sim import run  # noqa: E402
from swarmnav.world import load_scenario  # noqa: E402

FOREST = "random_forest:density={density},seed={seed},length=12,r_min=1.0,r_max=2.0,min_passage=1.0"
#: (name, IPOPT options on top of ours, max_iter or None: the parameter's)
VARIANTS = [
    ("default", {}, None),
    ("tol=1e-4", {"tol": 1e-4}, None),
    ("acceptable_tol=1e-3, iter 5", {"acceptable_tol": 1e-3, "acceptable_iter": 5}, None),
    ("mu_strategy=monotone", {"mu_strategy": "monotone"}, None),
    ("mu_oracle=probing", {"mu_oracle": "probing"}, None),
    ("mu_oracle=loqo", {"mu_oracle": "loqo"}, None),
    ("mu_init=1e-2", {"mu_init": 1e-2}, None),
    ("nlp_scaling_method=none", {"nlp_scaling_method": "none"}, None),
    ("warm_start_init_point=yes", {"warm_start_init_point": "yes"}, None),
    ("hessian_approximation=l-bfgs", {"hessian_approximation": "limited-memory"}, None),
    ("linear_solver=spral", {"linear_solver": "spral"}, None),
    ("max_iter=100", {}, 100),
]


def _record(density: float, seed: int, steps: int) -> list[tuple]:
    rec = []
    solve = S.solve_ipopt

    def recording(pb, free0, n0, d0, *args, **kw):
        res = solve(pb, free0, n0, d0, *args, **kw)
        rec.append((pb, free0, n0, d0, args, kw, res))
        return res

    S.solve_ipopt = recording
    try:
        run(MaderMethod(precheck=False), load_scenario(FOREST.format(density=density, seed=seed)), seed=seed, steps=steps)
    finally:
        S.solve_ipopt = solve
    return rec


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--density", type=float, default=0.35)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--steps", type=int, default=1000)
    ap.add_argument("--replay", default="200:500", help="slice of the recorded problems to solve again")
    a = ap.parse_args()
    rec = _record(a.density, a.seed, a.steps)
    lo, hi = (int(x) for x in a.replay.split(":"))
    rec = rec[lo:hi]
    print(f"# swarmnav {swarmnav.__version__}, numerics {portable.numerics()}; d_obs {a.density}, forest {a.seed}, "
          f"problems {lo}:{hi} of the first {a.steps} steps")
    print(f"{'options':<30} {'ms/solve':>8} {'iter mean':>9} {'median':>6} {'capped':>6} {'feasible':>8} "
          f"{'plan diff p95 [m]':>17}")
    for name, opts, max_iter in VARIANTS:
        o = tuple(sorted(opts.items()))
        calls = []
        for pb, free0, n0, d0, args, kw, res in rec:
            args = (max_iter if max_iter else args[0], *args[1:])
            calls.append((pb, free0, n0, d0, args, {**kw, "options": o}, res))
        for pb, free0, n0, d0, args, kw, _ in calls:  # build every CasADi problem before timing
            P = len(pb.seg)
            S._ipopt_solver(pb.start.shape[1], pb.num_pol, P, pb.verts.shape[1] if P else 0, args[2], args[0],
                            args[1], args[5], pb.radius is not None, pb.norm_limits, o)
        t0 = time.process_time()
        out = [S.solve_ipopt(pb, free0, n0, d0, *args, **kw) for pb, free0, n0, d0, args, kw, _ in calls]
        cpu = time.process_time() - t0
        its = np.array([r.evaluations for r in out])
        cap = int(sum(r.evaluations >= c[4][0] for r, c in zip(out, calls)))
        dev = [np.abs(r.ctrl - c[6].ctrl).max() for r, c in zip(out, calls) if r.ctrl is not None and c[6].ctrl is not None]
        feas = sum(r.ctrl is not None for r in out)
        print(f"{name:<30} {1e3 * cpu / len(out):>8.1f} {its.mean():>9.1f} {np.median(its):>6.0f} {cap:>6} "
              f"{feas:>4}/{len(out):<3} {np.percentile(dev, 95) if dev else 0.0:>17.1e}", flush=True)


if __name__ == "__main__":
    main()
