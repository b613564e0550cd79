"""Record the MPC problems of one NMPC flight, then replay them with other solver settings.

    PYTHONPATH=src python benchmarks/nmpc_replay.py record OUT.pkl [steps=1500] [density=0.35] [seed=1] [KEY=VALUE ...]
    PYTHONPATH=src python benchmarks/nmpc_replay.py replay OUT.pkl [KEY=VALUE ...]

``record`` flies the 15-robot sph-forest scene and stores every robot's Problem at every control
step (with the warm start it was given). ``replay`` solves the same problems in the same order with
the solver settings given (``max_iter``, ``tol``, ``hessian``, ``warm_dual``, ...), each robot
warm-started from its own previous replayed solve, and prints the CPU time per solve (median, p95,
mean), IPOPT iterations and the share of failed solves, and where IPOPT spent its time.
Open loop: the states are the recorded flight's, so only the solver changes.
"""

import collections
import dataclasses
import pickle
import sys
import time

import numpy as np

from swarmnav.methods.base import Observation
from swarmnav.methods.nmpc import NmpcMethod
from swarmnav.methods.nmpc import solver as S
from swarmnav.world import load_scenario


def _value(v: str):
    for cast in (int, float):
        try:
            return cast(v)
        except ValueError:
            pass
    return v


def record(path, args):
    steps, dens, seed = int(args.pop("steps", "1500")), args.pop("density", "0.35"), int(args.pop("seed", "1"))
    sc = load_scenario(f"random_forest:density={dens},seed={seed},length=12,r_min=1.0,r_max=2.0,min_passage=1.0")
    m = NmpcMethod(**{k: _value(v) for k, v in args.items()})
    rng = np.random.default_rng(seed)
    x = sc.spawn_positions(rng)
    v = np.zeros_like(x)
    m.reset(sc, x, v, rng)
    rec = []
    solve = S.solve

    def counted(pb, w, U0, *a, **k):
        r = solve(pb, w, U0, *a, **k)
        rec.append((pb, U0, r.status, r.iterations))
        return r

    S.solve = counted
    t0 = time.process_time()
    for k in range(steps):
        a, _ = m.act(Observation(k, k * m.dt, x, v), rng)
        x, v = m.dynamics.step(x, v, a, m.dt)
    print(f"recorded {len(rec)} problems, CPU {time.process_time() - t0:.1f} s, "
          f"{collections.Counter(r[2] for r in rec)}")
    with open(path, "wb") as f:
        pickle.dump({"weights": m.weights, "params": m.params, "n": sc.n, "rec": rec}, f)


def coarsen(pb: S.Problem, every: int) -> S.Problem:
    """The same problem over the same horizon with a step ``every`` times longer."""
    pb = S.Problem(*[getattr(pb, f.name, None) for f in dataclasses.fields(S.Problem)])  # older records
    if every == 1:
        return pb
    return dataclasses.replace(pb, h=pb.h * every, q=pb.q[:, every - 1::every])


def replay(path, args):
    with open(path, "rb") as f:
        d = pickle.load(f)
    n, rec, w = d["n"], d["rec"], d["weights"]
    limit = int(args.pop("limit", len(rec)))
    every = int(args.pop("every", "1"))
    feas_tol = float(args.pop("feas_tol", "1e-4"))
    opt = S.Options(**{k: (v == "1" if k == "warm_dual" else _value(v)) for k, v in args.items()})
    prev: dict = {}
    ms, its, status = [], [], collections.Counter()
    for idx, (pb, U0, st0, it0) in enumerate(rec[:limit]):
        i = idx % n
        pb = coarsen(pb, every)
        H, D = pb.q.shape[1], pb.p0.shape[0]
        r0 = prev.get(i)
        U = np.zeros((H, D)) if r0 is None or r0.U is None else np.concatenate([r0.U[1:], r0.U[-1:]])
        t0 = time.process_time()
        r = S.solve(pb, w, U, feas_tol=feas_tol, options=opt, duals=S.shift_duals(r0, H, pb.q.shape[0], D))
        ms.append(1e3 * (time.process_time() - t0))
        its.append(r.iterations)
        status[r.status if r.U is not None else "FAIL " + r.status] += 1
        prev[i] = r if r.U is not None else None
    ms, its = np.array(ms), np.array(its)
    fails = sum(c for s, c in status.items() if s.startswith("FAIL"))
    print(f"every={every} {opt}: {len(ms)} solves, CPU/solve median {np.median(ms):.1f} ms, "
          f"p95 {np.percentile(ms, 95):.1f} ms, mean {ms.mean():.1f} ms; iterations mean {its.mean():.1f}; "
          f"failed {100 * fails / len(ms):.1f} %  {dict(status)}", flush=True)


if __name__ == "__main__":
    mode, path = sys.argv[1], sys.argv[2]
    kv = dict(a.split("=", 1) for a in sys.argv[3:])
    (record if mode == "record" else replay)(path, kv)
