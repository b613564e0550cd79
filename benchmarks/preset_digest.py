"""Digests of every preset of every registered method: one short run per (method, preset, scene),
a SHA-256 of its positions and velocities. Run it on two commits and ``compare`` the files to check
that a refactor (a module moved, a preset renamed) keeps every build's runs bit-identical.

    PYTHONPATH=src python benchmarks/preset_digest.py run --out new.jsonl
    PYTHONPATH=/path/to/old/src python benchmarks/preset_digest.py run --out old.jsonl
    python benchmarks/preset_digest.py compare old.jsonl new.jsonl

Each run is ``--time`` simulated seconds (default 5 s: 50 HES steps, 500 SPH steps; at least ``--min-steps`` 30) on the scenes
of the method's kind: the navigation methods on default_corridor, narrow_alternating_gates and
the 2-D Table II forest at d_obs = 0.35 (seed 1), the Vicsek models on a periodic box. ``--alias
OLD=NEW`` in ``compare`` matches a renamed preset (``faithful=paper``). One core, one process.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import math
import sys
from pathlib import Path

NAV = ("default_corridor", "narrow_alternating_gates",
       "random_forest:density=0.35,seed=1,length=12,r_min=1.0,r_max=2.0,min_passage=1.0")
BOX = ("periodic_box:n=40,rho=1.0,seed=2",)


def run(a) -> int:
    import swarmnav  # before NumPy: swarmnav pins its numerics as it loads
    import numpy as np
    from swarmnav.methods import registry
    from swarmnav.params import presets

    methods = a.methods or registry.names()
    n = 0
    with open(a.out, "w") as f:
        for m in methods:
            spec = registry.spec(m)
            names = ["(default)", *presets(spec.params)]
            scenes = NAV if spec.navigation else BOX
            dt = registry.make(m).dt
            steps = max(a.min_steps, math.ceil(a.time / dt))
            for preset in names:
                sets = {} if preset == "(default)" else {"preset": preset}
                for scene in scenes:
                    r = swarmnav.run(m, scene, seed=a.seed, steps=steps, **sets)
                    h = hashlib.sha256(np.ascontiguousarray(r.positions).tobytes())
                    h.update(np.ascontiguousarray(r.velocities).tobytes())
                    f.write(json.dumps({"method": m, "preset": preset, "scene": scene, "steps": steps,
                                        "sha": h.hexdigest()}) + "\n")
                    f.flush()
                    n += 1
                print(f"{m:10s} {preset:12s} {len(scenes)} scene(s), {steps} steps", file=sys.stderr)
    print(f"{n} runs -> {a.out}")
    return 0


def load(path: str, alias: dict[str, str]) -> dict[tuple, str]:
    rows = map(json.loads, Path(path).read_text().splitlines())
    return {(r["method"], alias.get(r["preset"], r["preset"]), r["scene"], r["steps"]): r["sha"] for r in rows}


def compare(a) -> int:
    alias = dict(s.split("=", 1) for s in a.alias)
    old, new = load(a.old, alias), load(a.new, {})
    common = sorted(set(old) & set(new))
    differ = [k for k in common if old[k] != new[k]]
    for k in differ:
        print(f"DIFFERS: {k[0]} preset={k[1]} on {k[2]}")
    for k in sorted(set(old) ^ set(new)):
        print(f"only in {'old' if k in old else 'new'}: {k[0]} preset={k[1]} on {k[2]}")
    print(f"{len(common)} runs in both; bit-identical: {len(common) - len(differ)} / {len(common)}")
    return 0 if common and not differ else 1


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("run")
    r.add_argument("--out", required=True)
    r.add_argument("--methods", nargs="*")
    r.add_argument("--time", type=float, default=5.0, help="simulated seconds per run [s]")
    r.add_argument("--min-steps", type=int, default=30, help="at least this many steps per run")
    r.add_argument("--seed", type=int, default=1)
    c = sub.add_parser("compare")
    c.add_argument("old")
    c.add_argument("new")
    c.add_argument("--alias", action="append", default=[], metavar="OLD=NEW")
    a = ap.parse_args(argv)
    return run(a) if a.cmd == "run" else compare(a)


if __name__ == "__main__":
    sys.exit(main())
