"""Stored reference runs: every registered method on a few scenes, hashed array by array.

Re-record them from the current code, from the repository root (one command, any x86-64 Linux):

    python tests/data/reference_runs.py

It records in portable mode (docs/determinism.md), so the file holds on any x86-64 machine: it
restarts itself once with glibc's setting if needed, and refuses to write from a process whose
numerics are native. ``tests/sim/test_reference_runs.py`` reruns every case in a fresh portable
process (``--cases -``: cases as JSON on stdin, records as JSON on stdout) and demands identical
arrays (SHA-256 of the raw bytes of positions, velocities, clearance and labels) and identical
metrics. The file was first written before the world learnt a third dimension, so it proves that
2-D runs did not move.
"""

from __future__ import annotations

import hashlib
import json
import math
import sys
from pathlib import Path

if __name__ == "__main__":  # record this checkout's code, whatever swarmnav is installed
    sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "src"))

import swarmnav  # noqa: E402  (before NumPy: swarmnav pins it as it loads)
import numpy as np  # noqa: E402
from swarmnav import portable  # noqa: E402
from swarmnav.methods import registry  # noqa: E402

HERE = Path(__file__).parent
FILE = HERE / "reference_runs.json"
NAV_SCENES = ("default_corridor", "narrow_alternating_gates", "random_forest:density=0.25,seed=1", "sph_narrow")
MIN_TIME = 3.0  # [s] of simulated time per case (HES at 10 Hz: 30 steps; SPH at 100 Hz: 300)
MIN_STEPS = 30


def cases() -> list[tuple[str, str, int, int]]:
    out = []
    for m in registry.names():
        steps = max(MIN_STEPS, math.ceil(MIN_TIME / registry.make(m).dt))
        if registry.spec(m).navigation:
            out += [(m, s, 3, steps) for s in NAV_SCENES]
        if getattr(registry.make(m), "periodic", True):  # the planners refuse a periodic box
            out.append((m, "periodic_box:n=40,rho=1.0,seed=2", 5, MIN_STEPS))
    return out


def digest(a: np.ndarray) -> str:
    return hashlib.sha256(np.ascontiguousarray(a).tobytes()).hexdigest()


def record(method: str, scene: str, seed: int, steps: int) -> dict:
    r = swarmnav.run(method, scene, seed=seed, steps=steps)
    return {
        "method": method, "scene": scene, "seed": seed, "steps": steps,
        "shape": list(r.positions.shape),
        "positions": digest(r.positions), "velocities": digest(r.velocities),
        "clearance": digest(r.clearance), "labels": digest(r.labels),
        "events": len(r.events),
        "metrics": {k: (v if math.isfinite(v) else repr(v)) for k, v in sorted(r.metrics.items())},
    }


def portable_or_exit() -> None:
    """Make this process portable (one restart if glibc needs it), or exit saying why not."""
    portable.restart()
    r = portable.report()
    if r["numerics"] != "portable":
        why = "; ".join(r["problems"]) or f"{portable.SWITCH}=0"
        sys.exit(f"reference runs are recorded and checked with portable numerics, but this process "
                 f"is native: {why}")


if __name__ == "__main__":
    portable_or_exit()
    if sys.argv[1:] == ["--cases", "-"]:
        json.dump([record(*c) for c in json.load(sys.stdin)], sys.stdout)
    elif sys.argv[1:]:
        sys.exit(f"usage: python {sys.argv[0]} [--cases -]")
    else:
        rows = [record(*c) for c in cases()]
        FILE.write_text(json.dumps(rows, indent=1) + "\n")
        print(f"wrote {len(rows)} reference runs to {FILE}", file=sys.stderr)
