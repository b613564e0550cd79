"""Seconds per VEM step at N = 10^5 in the periodic box, ours against the usual NumPy + cKDTree form.

Pinned to one core. "Ours" is one full step of the registered ``vem`` method: ``act`` (cell-list
neighbour list, eq. 6 heading, noise, eq. 7 velocity) plus ``Kinematic`` (eq. 8, periodic wrap).
"Plain" is the Vicsek step as it is usually written in public code: a periodic
``scipy.spatial.cKDTree`` per step, ``query_pairs`` for the neighbour pairs, ``np.bincount`` for the
sums of sin and cos, ``arctan2`` plus uniform noise, then move and wrap. Both run the HWVEM
Section 3.1 box (rho = 4.102 /m^2, r = 1 m, v0 = 0.03 m/step) with noise eta = 0.1 so both draw N
random numbers per step.

    PYTHONPATH=src python benchmarks/bench_vicsek.py            # N = 100000
    PYTHONPATH=src python benchmarks/bench_vicsek.py --n 10000 --reps 20
"""

from __future__ import annotations

import argparse
import math
import os
import statistics
import time

import numpy as np
from scipy.spatial import cKDTree

from swarmnav.methods.base import Observation
from swarmnav.methods.vicsek import VicsekFamily
from swarmnav.world.generators import periodic_box

RHO, R, V0, ETA = 4.102, 1.0, 0.03, 0.1


def plain_vicsek_step(pos: np.ndarray, theta: np.ndarray, box: float, rng: np.random.Generator):
    """The common public form: KD-tree pairs, bincount sums (self included), arctan2 + noise."""
    n = len(pos)
    pairs = cKDTree(pos, boxsize=box).query_pairs(R, output_type="ndarray")
    i, j = pairs[:, 0], pairs[:, 1]
    s, c = np.sin(theta), np.cos(theta)
    S = s + np.bincount(i, s[j], n) + np.bincount(j, s[i], n)
    C = c + np.bincount(i, c[j], n) + np.bincount(j, c[i], n)
    theta = np.arctan2(S, C) + rng.uniform(-ETA / 2, ETA / 2, n)
    pos = np.mod(pos + V0 * np.column_stack([np.cos(theta), np.sin(theta)]), box)
    pos[pos >= box] = 0.0  # np.mod can round up to box; cKDTree needs [0, box)
    return pos, theta


def time_steps(step, reps: int) -> tuple[list[float], list[float]]:
    """Wall and CPU seconds of each of ``reps`` calls (CPU time is the fairer figure on a
    shared machine: another process on the same core inflates wall time, not CPU time)."""
    wall, cpu = [], []
    for _ in range(reps):
        t0, c0 = time.perf_counter(), time.process_time()
        step()
        wall.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)
    return wall, cpu


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=100_000)
    ap.add_argument("--reps", type=int, default=10)
    ap.add_argument("--cpu", type=int, default=None, help="core to pin to (default: the first allowed)")
    args = ap.parse_args()
    cpu = args.cpu if args.cpu is not None else min(os.sched_getaffinity(0))
    os.sched_setaffinity(0, {cpu})
    os.environ.setdefault("NUMBA_NUM_THREADS", "1")

    scn = periodic_box(args.n, RHO)
    box = scn.bounds[2]
    rng = np.random.default_rng(0)
    x0 = scn.spawn_positions(rng)

    m = VicsekFamily("vem", v0=V0, eta=ETA, c_rep=0.0, c_att=0.0, r=R)
    m.reset(scn, x0.copy(), np.zeros_like(x0), rng)
    st = {"x": x0.copy(), "v": np.zeros_like(x0), "k": 0}

    def ours():
        cmd, _ = m.act(Observation(st["k"], float(st["k"]), st["x"], st["v"]), rng)
        st["x"], st["v"] = m.dynamics.step(st["x"], st["v"], cmd, 1.0)
        st["k"] += 1

    pl = {"x": x0.copy(), "th": m.theta.copy()}

    def plain():
        pl["x"], pl["th"] = plain_vicsek_step(pl["x"], pl["th"], box, rng)

    ours()  # compile the numba kernels (cached on disk afterwards)
    plain()
    w_ours, c_ours = time_steps(ours, args.reps)
    w_plain, c_plain = time_steps(plain, args.reps)
    _, start, end, _, _ = m._neighbours(st["x"])
    mean_deg = float(np.mean(end - start))
    med = statistics.median
    a, b = med(c_ours), med(c_plain)
    print(f"VEM step, N = {args.n}, periodic box D = {box:.1f} m (rho = {RHO}, r = {R} m, "
          f"{mean_deg:.1f} neighbours per agent), one core (cpu {cpu}), median of {args.reps}:")
    print(f"  {'':38s} {'CPU ms/step':>12s} {'wall ms/step':>13s}")
    print(f"  {'swarmnav vem (numba cell list, CSR)':38s} {a * 1e3:12.1f} {med(w_ours) * 1e3:13.1f}")
    print(f"  {'plain NumPy + cKDTree':38s} {b * 1e3:12.1f} {med(w_plain) * 1e3:13.1f}")
    print(f"  {'ratio plain / ours':38s} {b / a:12.2f} {med(w_plain) / med(w_ours):13.2f}")
    print(f"  => {1 / a:.1f} steps/s, {args.n / a / 1e6:.2f} M agent-steps/s of CPU time")
    if not math.isfinite(a):
        raise SystemExit(1)


if __name__ == "__main__":
    main()
