"""What imperfect perception does to a flight (docs/sensing.md): HES and APF on
narrow_alternating_gates (20 agents, 90 s), seeds 1-5, under each perception setting alone.

    PYTHONPATH=src python benchmarks/perception_effect.py

Prints per method and setting: Y (mission success, mean of the seeds), R_goal (fraction of agents
at the goal, mean), crashes (agents crashed, summed over the seeds: of 100) and the crashes into
another agent (events with reason "agent"). An illustration on one scene, not the robustness
experiment of issue 37.
"""

from __future__ import annotations

import warnings

import numpy as np

import swarmnav

SETTINGS = {
    "perfect": {},
    "pos_noise 0.05 m": {"sense.pos_noise": 0.05},
    "pos_noise 0.2 m": {"sense.pos_noise": 0.2},
    "drift 0.01 m/s": {"sense.drift": 0.01},
    "range_noise 0.02 m": {"sense.range_noise": 0.02},
    "dropout 0.1": {"sense.dropout": 0.1},
    "fov 180 deg": {"sense.fov": 180.0},
    "fov 90 deg": {"sense.fov": 90.0},
}
SEEDS = range(1, 6)


def main() -> None:
    warnings.filterwarnings("ignore", message=".*portable numerics.*")
    print(f"{'method':>6} {'setting':>20} {'Y':>5} {'R_goal':>7} {'crashes':>8} {'into agents':>12}")
    for method in ("hes", "apf"):
        for name, options in SETTINGS.items():
            runs = [swarmnav.run(method, "narrow_alternating_gates", seed=s, horizon=90.0, plans=False, **options)
                    for s in SEEDS]
            agents = sum(1 for r in runs for e in r.events if e.get("action") == "crash" and e.get("reason") == "agent")
            print(f"{method:>6} {name:>20} {np.mean([r.metrics['Y'] for r in runs]):>5.2f} "
                  f"{np.mean([r.metrics['R_goal'] for r in runs]):>7.2f} {sum(r.metrics['crashes'] for r in runs):>8.0f} "
                  f"{agents:>12}", flush=True)


if __name__ == "__main__":
    main()
