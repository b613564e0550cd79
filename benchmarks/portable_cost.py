"""What portable numerics cost: wall time of the same runs in portable and in native mode.

Portable mode (docs/determinism.md) runs NumPy's baseline loops, OpenBLAS's Prescott kernels on
one thread, numba's generic-CPU code and glibc's SSE2 libm. Its settings act when the libraries
load, so every figure comes from a fresh process: native children start with SWARMNAV_PORTABLE=0
and none of portable mode's variables, portable children with ``swarmnav.portable.environment()``
(so no restart is needed). Each child does one short run first (numba's cache, first calls) and
then times the run ``--repeats`` times; modes alternate child by child, so a machine shared with
other work slows both alike. The table gives the fastest run of each (the least disturbed) and
portable / native.

    PYTHONPATH=src python benchmarks/portable_cost.py [--repeats 5] [--rounds 3]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
from pathlib import Path

ORIGINAL_ENV = dict(os.environ)  # before swarmnav exports its settings into this process

try:
    import swarmnav  # noqa: F401
except ImportError:  # running from a checkout without installing
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))

from swarmnav import portable  # noqa: E402

SRC = str(Path(portable.__file__).resolve().parents[1])
#: (method, scene, steps): the runs an issue about speed would name.
CASES = [
    ("hes", "default_corridor", 300),
    ("sph", "default_corridor", 300),
    ("apf", "default_corridor", 3000),
    ("hwvem", "periodic_box:n=1000", 1000),
]

CHILD = """
import json, sys, time
import swarmnav
method, scene, steps, repeats = sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4])
swarmnav.run(method, scene, seed=1, steps=3)  # loads the numba cache (compiles on a first ever run)
times, numerics = [], None
for _ in range(repeats):
    t0 = time.perf_counter()
    r = swarmnav.run(method, scene, seed=1, steps=steps)
    times.append(time.perf_counter() - t0)
    numerics = r.config["numerics"]
print(json.dumps({"times": times, "numerics": numerics}))
"""


def env(mode: str) -> dict[str, str]:
    base = {k: v for k, v in ORIGINAL_ENV.items() if k not in {*portable.PINS, *portable.UNSET, "GLIBC_TUNABLES"}}
    base["PYTHONPATH"] = SRC + os.pathsep + ORIGINAL_ENV.get("PYTHONPATH", "")
    if mode == "native":
        return {**base, portable.SWITCH: "0"}
    return {**base, **portable.environment(), portable.SWITCH: "1"}


def measure(mode: str, case: tuple[str, str, int], repeats: int) -> list[float]:
    method, scene, steps = case
    p = subprocess.run([sys.executable, "-c", CHILD, method, scene, str(steps), str(repeats)], env=env(mode),
                       capture_output=True, text=True, timeout=3600)
    if p.returncode != 0:
        sys.exit(f"{mode} {method} failed:\n{p.stderr}")
    out = json.loads(p.stdout)
    if out["numerics"] != mode:
        sys.exit(f"a {mode} child ran {out['numerics']} numerics: {p.stderr.strip()}")
    return out["times"]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5, help="timed runs per child")
    ap.add_argument("--rounds", type=int, default=3, help="children per mode and case, alternating")
    a = ap.parse_args()
    print(f"{'run':42s} {'native [s]':>10s} {'portable [s]':>12s} {'portable/native':>15s}")
    ratios = []
    for case in CASES:
        times: dict[str, list[float]] = {"native": [], "portable": []}
        for _ in range(a.rounds):
            for mode in times:
                times[mode] += measure(mode, case, a.repeats)
        nat, por = min(times["native"]), min(times["portable"])
        ratios.append(por / nat)
        name = f"{case[0]} {case[1]}, {case[2]} steps"
        print(f"{name:42s} {nat:10.3f} {por:12.3f} {por / nat:15.2f}", flush=True)
    print(f"{'geometric mean':42s} {'':10s} {'':12s} {statistics.geometric_mean(ratios):15.2f}")


if __name__ == "__main__":
    main()
