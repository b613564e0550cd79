"""Perception's cost (issue 37): perfect perception must cost under 5 % over the step of the code
before imperfect perception existed, and fly the same arrays; an imperfect one's cost beside it.

    PYTHONPATH=src python benchmarks/bench_perception.py --before 98be19e

Each trial runs in a fresh subprocess (one at a time) after a 3-step warm-up that loads the
compiled kernels; the CPU time (``time.process_time``) of ``--repeats`` runs is taken at its
minimum. Columns: CPU seconds per simulated second flown (a run its method ends early counts the
steps it flew) before (``--before REV``: ``git archive REV src``), with perfect perception now,
their ratio, whether positions and velocities are bit-identical (a SHA-256 digest), and the same
run under ``--sense``.
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
TRIALS = [  # (method, scene, simulated seconds): the methods that read a range sensor
    ("hes", "narrow_alternating_gates", 30.0),
    ("apf", "narrow_alternating_gates", 30.0),
    ("vasarhelyi", "narrow_alternating_gates", 30.0),
]


def worker(a) -> None:
    sys.path.insert(0, a.src)
    import swarmnav

    swarmnav.portable.restart()
    import hashlib
    import time

    import numpy as np

    from swarmnav.world import load_scenario

    scn = load_scenario(a.scene)
    options = json.loads(a.options)
    swarmnav.run(a.method, scn, seed=1, steps=3, **options)
    best, digest, flown = float("inf"), "", 0.0
    for _ in range(a.repeats):
        t0 = time.process_time()
        r = swarmnav.run(a.method, scn, seed=1, horizon=a.horizon, plans=False, **options)
        best = min(best, time.process_time() - t0)
        h = hashlib.sha256(np.ascontiguousarray(r.positions).tobytes())
        h.update(np.ascontiguousarray(r.velocities).tobytes())
        digest, flown = h.hexdigest()[:12], (len(r.positions) - 1) * float(r.config["dt"])
    print(json.dumps({"cpu": best, "sim": flown, "digest": digest}))


def trial(src, method, scene, horizon, options, repeats) -> dict:
    cmd = [sys.executable, __file__, "--worker", "--src", src, "--method", method, "--scene", scene,
           "--horizon", str(horizon), "--options", json.dumps(options), "--repeats", str(repeats)]
    p = subprocess.run(cmd, capture_output=True, text=True, env={**os.environ, "PYTHONPATH": src})
    if p.returncode != 0:
        sys.exit(f"bench_perception: the trial failed: {(p.stderr.strip().splitlines() or ['?'])[-1]}")
    return json.loads(p.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--before", default="", help="git revision before imperfect perception")
    ap.add_argument("--sense", default='{"sense.pos_noise": 0.05, "sense.range_noise": 0.02, "sense.dropout": 0.1}')
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--src", default=str(ROOT / "src"), help=argparse.SUPPRESS)
    ap.add_argument("--method", default="", help=argparse.SUPPRESS)
    ap.add_argument("--scene", default="", help=argparse.SUPPRESS)
    ap.add_argument("--horizon", type=float, default=10.0, help=argparse.SUPPRESS)
    ap.add_argument("--options", default="{}", help=argparse.SUPPRESS)
    a = ap.parse_args()
    if a.worker:
        worker(a)
        return
    sense = json.loads(a.sense)
    src = str(ROOT / "src")
    with tempfile.TemporaryDirectory() as tmp:
        old = None
        if a.before:
            archive = subprocess.run(["git", "-C", str(ROOT), "archive", a.before, "src"], capture_output=True, check=True)
            subprocess.run(["tar", "-x", "-C", tmp], input=archive.stdout, check=True)
            old = str(Path(tmp) / "src")
        print(f"# CPU s per simulated s, min of {a.repeats}; before = {a.before or '-'}; perception = {sense}")
        print(f"{'method':>11} {'before':>8} {'perfect':>8} {'perfect/before':>15} {'arrays':>9} {'imperfect':>10} "
              f"{'imp/perfect':>12}")
        for method, scene, horizon in TRIALS:
            now = trial(src, method, scene, horizon, {}, a.repeats)
            line = f"{method:>11} "
            if old:
                was = trial(old, method, scene, horizon, {}, a.repeats)
                same = "same" if was["digest"] == now["digest"] else "DIFFERENT"
                line += (f"{was['cpu'] / was['sim']:>8.4f} {now['cpu'] / now['sim']:>8.4f} "
                         f"{now['cpu'] / was['cpu']:>15.3f} {same:>9} ")
            else:
                line += f"{'-':>8} {now['cpu'] / now['sim']:>8.4f} {'-':>15} {'-':>9} "
            noisy = trial(src, method, scene, horizon, sense, a.repeats)
            line += f"{noisy['cpu'] / noisy['sim']:>10.4f} {noisy['cpu'] / noisy['sim'] / (now['cpu'] / now['sim']):>12.2f}"
            print(line, flush=True)


if __name__ == "__main__":
    main()
