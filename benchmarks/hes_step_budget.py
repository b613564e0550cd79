"""Where the time of a HES step goes: compiled kernels against the Python that drives them.

Runs one HES simulation (default: default_corridor, N = 20, 1000 steps, the default build)
three times in this process after a warm-up:

1. plain, timed (CPU time): the step as users get it;
2. with every Numba kernel that a ``swarmnav`` module calls from Python wrapped in a timer:
   the kernels' own time, Numba's argument dispatch included (the wrapper's own overhead is
   measured on an empty kernel and subtracted);
3. with a profile hook counting the Python function calls (numpy's included).

It prints the time per step, the kernels' share, what is left for the Python around them, the
kernels that cost most, and, given ``--target-ms`` (a step time to reach, e.g. a third of an
older commit's step measured by ``bench_hes.py``), how much Python time the target leaves per
step. Kernels called from other kernels count inside their caller.

    PYTHONPATH=src python benchmarks/hes_step_budget.py
    PYTHONPATH=src python benchmarks/hes_step_budget.py --target-ms 0.156 --scene narrow_alternating_gates
"""

from __future__ import annotations

import argparse
import sys
import time
from collections import defaultdict

import numpy as np
from numba import njit
from numba.core.registry import CPUDispatcher

import swarmnav


@njit(cache=False)
def _empty(a, b, c, d):
    return 0


def _wrap_kernels(totals: dict, counts: dict) -> list:
    """Replace every Numba dispatcher held as a global of a swarmnav module by a timing wrapper;
    returns the (module, name, original) triples to restore."""
    wrappers, undo = {}, []
    for modname, mod in list(sys.modules.items()):
        if mod is None or not modname.startswith("swarmnav"):
            continue
        for name, obj in list(vars(mod).items()):
            if not isinstance(obj, CPUDispatcher):
                continue
            if id(obj) not in wrappers:
                key = f"{obj.py_func.__module__.removeprefix('swarmnav.')}.{obj.__name__}"

                def timed(*args, _f=obj, _k=key, **kw):
                    t = time.process_time()
                    out = _f(*args, **kw)
                    totals[_k] += time.process_time() - t
                    counts[_k] += 1
                    return out

                wrappers[id(obj)] = timed
            setattr(mod, name, wrappers[id(obj)])
            undo.append((mod, name, obj))
    return undo


def _wrapper_cost(calls: int = 20000) -> float:
    """CPU seconds the timing wrapper adds per call (on an empty kernel)."""
    x = np.zeros(4)
    _empty(x, x, x, x)
    totals, counts = defaultdict(float), defaultdict(int)

    def timed(*args):
        t = time.process_time()
        out = _empty(*args)
        totals["e"] += time.process_time() - t
        counts["e"] += 1
        return out

    t0 = time.process_time()
    for _ in range(calls):
        _empty(x, x, x, x)
    bare = time.process_time() - t0
    t0 = time.process_time()
    for _ in range(calls):
        timed(x, x, x, x)
    return max((time.process_time() - t0 - bare) / calls, 0.0)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", default="default_corridor")
    ap.add_argument("--steps", type=int, default=1000)
    ap.add_argument("--repeat", type=int, default=3, help="plain timed runs (best kept)")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="HES parameters")
    ap.add_argument("--target-ms", type=float, help="a step time to reach [ms per step]")
    a = ap.parse_args(argv)
    params = dict(s.split("=", 1) for s in a.set)
    scn = swarmnav.load_scenario(a.scene)
    run = lambda: swarmnav.run("hes", scn, seed=1, steps=a.steps, **params)  # noqa: E731
    swarmnav.run("hes", scn, seed=1, steps=a.steps, **params)  # warm-up: every kernel compiled or loaded

    best = np.inf
    for _ in range(a.repeat):
        t = time.process_time()
        run()
        best = min(best, time.process_time() - t)

    totals, counts = defaultdict(float), defaultdict(int)
    undo = _wrap_kernels(totals, counts)
    try:
        run()
    finally:
        for mod, name, obj in undo:
            setattr(mod, name, obj)
    over = _wrapper_cost()
    kern = {k: max(v - counts[k] * over, 0.0) for k, v in totals.items()}

    calls = [0]

    def hook(frame, event, arg):
        if event in ("call", "c_call"):
            calls[0] += 1

    sys.setprofile(hook)
    try:
        run()
    finally:
        sys.setprofile(None)

    k = a.steps
    step_us = best / k * 1e6
    kern_us = sum(kern.values()) / k * 1e6
    print(f"hes on {a.scene}, {scn.n} agents, {k} steps{', ' + ' '.join(a.set) if a.set else ''}; CPU time, one process:")
    print(f"  step (whole run / steps, metrics included): {step_us:7.1f} us")
    print(f"  compiled kernels (dispatch included):        {kern_us:7.1f} us  ({100 * kern_us / step_us:4.1f} %)")
    print(f"  the rest (Python, numpy calls, rollout):     {step_us - kern_us:7.1f} us  "
          f"over {calls[0] / k:.0f} Python-level calls per step")
    print("  costliest kernels [us per step, calls per step]:")
    for name, v in sorted(kern.items(), key=lambda kv: -kv[1])[:10]:
        print(f"    {name:45s} {v / k * 1e6:6.1f}  {counts[name] / k:5.2f}")
    if a.target_ms is not None:
        left = a.target_ms * 1e3 - kern_us
        print(f"  target {a.target_ms * 1e3:.1f} us per step: leaves {left:.1f} us for the rest "
              f"({left / max(step_us - kern_us, 1e-9):.2f} of today's), "
              f"{1e3 * left / max(calls[0] / k, 1):.0f} ns per Python-level call at today's call count")
    return 0


if __name__ == "__main__":
    sys.exit(main())
