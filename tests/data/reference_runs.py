"""Stored reference runs: every registered method on a few scenes, hashed array by array.

``python tests/data/reference_runs.py`` rewrites ``reference_runs.json`` from the current code;
``tests/sim/test_reference_runs.py`` reruns every case and demands identical arrays (SHA-256 of
the raw bytes of positions, velocities, clearance and labels) and identical metrics. The file
was written before the world learnt a third dimension, so it proves that 2-D runs did not move.
"""

from __future__ import annotations

import hashlib
import json
import math
import sys
from pathlib import Path

import numpy as np

import swarmnav
from swarmnav.methods import registry

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


if __name__ == "__main__":
    rows = [record(*c) for c in cases()]
    FILE.write_text(json.dumps(rows, indent=1) + "\n")
    print(f"wrote {len(rows)} reference runs to {FILE}", file=sys.stderr)
