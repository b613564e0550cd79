"""Perception's cost (issue 37): perfect perception must cost under 5 % over the step of the code
before imperfect perception existed, and fly the same arrays; an imperfect one's cost beside it.

    PYTHONPATH=src python benchmarks/bench_perception.py --before 98be19e

Trials as benchmarks/bench_network.py (its worker and measurement: a fresh subprocess per trial,
one at a time, the least CPU time of ``--repeats`` runs after a warm-up). Columns: CPU seconds
per simulated second before (``--before REV``), with perfect perception now, their ratio,
whether positions and velocities are bit-identical, and the same run under ``--sense``.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_network import ROOT, trial  # noqa: E402  (the same worker: it passes run options through)

TRIALS = [  # (method, scene, n, simulated seconds): the methods that read a range sensor
    ("hes", "narrow_alternating_gates", None, 30.0),
    ("apf", "narrow_alternating_gates", None, 30.0),
    ("vasarhelyi", "narrow_alternating_gates", None, 30.0),
]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--before", default="", help="git revision before imperfect perception")
    ap.add_argument("--sense", default='{"sense.pos_noise": 0.05, "sense.range_noise": 0.02, "sense.dropout": 0.1}')
    ap.add_argument("--repeats", type=int, default=3)
    a = ap.parse_args()
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
        for method, scene, n, horizon in TRIALS:
            now = trial(src, method, scene, n, horizon, {}, a.repeats)
            line = f"{method:>11} "
            if old:
                was = trial(old, method, scene, n, horizon, {}, a.repeats)
                same = "same" if was["digest"] == now["digest"] else "DIFFERENT"
                line += (f"{was['cpu'] / was['sim']:>8.4f} {now['cpu'] / now['sim']:>8.4f} "
                         f"{now['cpu'] / was['cpu']:>15.3f} {same:>9} ")
            else:
                line += f"{'-':>8} {now['cpu'] / now['sim']:>8.4f} {'-':>15} {'-':>9} "
            noisy = trial(src, method, scene, n, horizon, sense, a.repeats)
            line += f"{noisy['cpu'] / noisy['sim']:>10.4f} {noisy['cpu'] / now['cpu']:>12.2f}"
            print(line, flush=True)


if __name__ == "__main__":
    main()
