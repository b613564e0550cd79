"""swarmnav from Python: load a scene, fly two methods on it, compare, draw.

    python examples/quickstart.py                 # 60 s of simulated time, figures in runs/quickstart
    python examples/quickstart.py --horizon 10    # shorter
"""

import argparse
from pathlib import Path

import swarmnav
from swarmnav.viz import plot_run

parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
parser.add_argument("--horizon", type=float, default=60.0, help="simulated time per run [s]")
parser.add_argument("--out", default="runs/quickstart", help="directory for the run directories and figures")
args = parser.parse_args()

scene = swarmnav.load_scenario(Path(__file__).with_name("my_scene.toml"))
print(f"{scene.name}: {scene.n} agents, goal {scene.goal} m, {len(scene.obstacles)} obstacles")

for method, params in (("hes", {}), ("apf", {"k_rep": 10.0})):
    result = swarmnav.run(method, scene, seed=1, horizon=args.horizon, **params)  # same seed: same arrays
    m = result.metrics
    print(f"{method:4s} Y = {m['Y']:.0f}  R_goal = {m['R_goal']:.2f}  E_mean = {m['E_mean']:.1f} m  "
          f"R_unsafe = {m['R_unsafe']:.2f}  min clearance = {m['d_clr_min']:.2f} m  "
          f"({result.positions.shape[0] - 1} steps, {result.wall_time:.2f} s wall)")
    run_dir = result.save(Path(args.out) / method)  # metrics.json, trajectory.npz, config.json
    plot_run(result, run_dir / "trajectory.png")
print(f"figures: {args.out}/*/trajectory.png")
