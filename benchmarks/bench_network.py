"""The network's cost (issue 37): the ideal network must cost under 5 % over the step of the code
before the network existed, and fly the same arrays; a lossy, late network's own cost beside it.

    PYTHONPATH=src python benchmarks/bench_network.py --before 77b163b
    PYTHONPATH=src python benchmarks/bench_network.py --before 77b163b --methods vem,ivem,hwvem,ego-swarm
    PYTHONPATH=src python benchmarks/bench_network.py --before 77b163b --methods hes

Each trial runs in a fresh subprocess (one core, one at a time) after a 3-step warm-up that loads
the compiled kernels; the CPU time (``time.process_time``) of ``--repeats`` runs is taken at its
minimum, before and after alternating, so that a busy machine slows both alike. Columns: CPU
seconds per simulated second before (``--before REV``: ``git archive REV src``), with the ideal
network now, their ratio, whether the positions and velocities are bit-identical (a SHA-256
digest), and the same run on a network (``--net``) for what the network itself costs.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
TRIALS = [  # (method, scene, n, simulated seconds)
    ("vasarhelyi", "narrow_alternating_gates", None, 30.0),
    ("olfati-saber", "narrow_alternating_gates", None, 30.0),
    ("sph", "random_forest:density=0.35,seed=1,length=12,r_min=1.0,r_max=2.0,min_passage=1.0", 15, 20.0),
    # the Vicsek family: dt = 1 step, so the horizon is in steps; the alignment models in the
    # periodic box of Section 3.1, those with an information UAV on the mission of Section 3.2
    ("vem", "periodic_box:n=400,rho=4.102", None, 1000.0),
    ("ivem", "periodic_box:n=400,rho=4.102", None, 1000.0),
    ("vem-a", "hwvem_mission", 100, 700.0),
    ("ivem-a", "hwvem_mission", 100, 700.0),
    ("wvem", "hwvem_mission", 100, 700.0),
    ("hwvem", "hwvem_mission", 100, 700.0),
    ("ego-swarm", "random_forest:density=0.25,seed=1,length=12,r_min=1.0,r_max=2.0,min_passage=1.0", 15, 20.0),
    ("hes", "narrow_alternating_gates", None, 30.0),
]
#: method parameters of a trial (every run of it, before and now): HES's paper build, the build
#: that flies a network (the default build's passage mode, stall planner and trail following read
#: other agents' true states and refuse one; docs/methods/hes-network.md)
PARAMS = {"hes": {"preset": "paper"}}


def worker(a) -> None:
    sys.path.insert(0, a.src)
    import swarmnav

    swarmnav.portable.restart()
    import hashlib
    import time

    import numpy as np

    from swarmnav.world import load_scenario

    scn = load_scenario(a.scene, n=a.n or None)
    net = json.loads(a.net)
    swarmnav.run(a.method, scn, seed=1, steps=3, **net)
    best, digest = float("inf"), ""
    for _ in range(a.repeats):
        t0 = time.process_time()
        r = swarmnav.run(a.method, scn, seed=1, horizon=a.horizon, plans=False, **net)
        best = min(best, time.process_time() - t0)
        h = hashlib.sha256(np.ascontiguousarray(r.positions).tobytes())
        h.update(np.ascontiguousarray(r.velocities).tobytes())
        digest = h.hexdigest()[:12]
    print(json.dumps({"cpu": best, "sim": float(r.config["horizon"]), "digest": digest}))


def trial(src, method, scene, n, horizon, net, repeats) -> dict:
    net = {**PARAMS.get(method, {}), **net}
    cmd = [sys.executable, __file__, "--worker", "--src", src, "--method", method, "--scene", scene,
           "--n", str(n or 0), "--horizon", str(horizon), "--net", json.dumps(net), "--repeats", str(repeats)]
    p = subprocess.run(cmd, capture_output=True, text=True, env={**os.environ, "PYTHONPATH": src})
    if p.returncode != 0:
        sys.exit(f"bench_network: the trial failed: {(p.stderr.strip().splitlines() or ['?'])[-1]}")
    return json.loads(p.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--before", required=False, default="", help="git revision before the network")
    ap.add_argument("--net", default='{"net.latency": 0.15, "net.jitter": 0.05, "net.loss": 0.3}')
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--methods", default="", help="comma-separated methods of the trials to run (default: all)")
    ap.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--src", default=str(ROOT / "src"), help=argparse.SUPPRESS)
    ap.add_argument("--method", default="", help=argparse.SUPPRESS)
    ap.add_argument("--scene", default="", help=argparse.SUPPRESS)
    ap.add_argument("--n", type=int, default=0, help=argparse.SUPPRESS)
    ap.add_argument("--horizon", type=float, default=10.0, help=argparse.SUPPRESS)
    a = ap.parse_args()
    if a.worker:
        worker(a)
        return
    net = json.loads(a.net)
    with tempfile.TemporaryDirectory() as tmp:
        old = None
        if a.before:
            archive = subprocess.run(["git", "-C", str(ROOT), "archive", a.before, "src"], capture_output=True, check=True)
            subprocess.run(["tar", "-x", "-C", tmp], input=archive.stdout, check=True)
            old = str(Path(tmp) / "src")
        print(f"# CPU s per simulated s, min of {a.repeats}; before = {a.before or '-'}; network = {net}")
        print(f"{'method':>13} {'before':>8} {'ideal':>8} {'ideal/before':>13} {'arrays':>9} {'network':>8} {'net/ideal':>10}")
        chosen = set(a.methods.split(",")) if a.methods else {t[0] for t in TRIALS}
        unknown = chosen - {t[0] for t in TRIALS}
        if unknown:
            sys.exit(f"bench_network: no trial of {', '.join(sorted(unknown))}")
        for method, scene, n, horizon in (t for t in TRIALS if t[0] in chosen):
            now = trial(a.src, method, scene, n, horizon, {}, a.repeats)
            line = f"{method:>13} "
            if old:
                was = trial(old, method, scene, n, horizon, {}, a.repeats)
                same = "same" if was["digest"] == now["digest"] else "DIFFERENT"
                line += f"{was['cpu'] / was['sim']:>8.4g} {now['cpu'] / now['sim']:>8.4g} {now['cpu'] / was['cpu']:>13.3f} {same:>9} "
            else:
                line += f"{'-':>8} {now['cpu'] / now['sim']:>8.4g} {'-':>13} {'-':>9} "
            lossy = trial(a.src, method, scene, n, horizon, net, a.repeats)
            line += f"{lossy['cpu'] / lossy['sim']:>8.4g} {lossy['cpu'] / now['cpu']:>10.2f}"
            print(line, flush=True)


if __name__ == "__main__":
    main()
