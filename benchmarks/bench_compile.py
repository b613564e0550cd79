"""How long Numba's first compile of swarmnav's kernels takes, per method, and what it costs later.

Run: ``python benchmarks/bench_compile.py [--steps 20]``. For each method on its scene it runs
``swarmnav run`` in a fresh process against an empty Numba cache (``NUMBA_CACHE_DIR`` in a
temporary directory: the same as deleting the ``__pycache__/*.nbi``/``*.nbc`` files), then once
more against the cache that run wrote, and prints both wall times (the whole command: start-up,
imports and a short run included) and whether the compile notice was shown. The last rows run
every case in sequence into one cache, as a new machine meets them (shared kernels are compiled
once), and a cold ``experiment cross-method`` (every method and scene kind in one process). One
row is the README's main job (``hes``, 1000 steps), whose first and warm runs the README quotes.

The notice's estimate (``swarmnav.cli.COMPILE_NOTICE``) quotes these figures.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

CASES = [("apf", "default_corridor"), ("hes", "default_corridor"), ("sph", "default_corridor"),
         ("vem", "hwvem_mission"), ("hwvem", "hwvem_mission"), ("sph", "sph_cluttered_3d"),
         ("apf", "sph_cluttered_3d"), ("hes", "sph_cluttered_3d")]
SRC = str(Path(__file__).resolve().parents[1] / "src")


def swarmnav(cache: Path, out: Path, *args: str) -> tuple[float, str]:
    env = {**os.environ, "NUMBA_CACHE_DIR": str(cache),
           "PYTHONPATH": SRC + os.pathsep + os.environ.get("PYTHONPATH", "")}
    t0 = time.perf_counter()
    p = subprocess.run([sys.executable, "-m", "swarmnav.cli", *args, "--out", str(out)], env=env,
                       capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if p.returncode not in (0, 1):
        raise SystemExit(f"swarmnav {' '.join(args)} failed:\n{p.stderr}")
    return wall, p.stderr


def noticed(stderr: str) -> str:
    return "yes" if "compiling numerical kernels" in stderr else "no"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", default="20")
    ap.add_argument("--skip-cross", action="store_true", help="skip the cold cross-method sweep (~1-2 min)")
    args = ap.parse_args()
    print(f"{'case':34s} {'cold [s]':>9s} {'warm [s]':>9s}  notice cold/warm")
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        for k, (method, scene) in enumerate(CASES):
            cache = tmp / f"cache{k}"
            run = ["run", "--method", method, "--scenario", scene, "--steps", args.steps, "--quiet", "--force"]
            cold, e1 = swarmnav(cache, tmp / "out", *run)
            warm, e2 = swarmnav(cache, tmp / "out", *run)
            print(f"{method + ' on ' + scene:34s} {cold:9.1f} {warm:9.1f}  {noticed(e1)}/{noticed(e2)}")
        main_job = ["run", "--method", "hes", "--scenario", "default_corridor", "--seed", "1", "--steps", "1000",
                    "--quiet", "--force"]  # the README's main job
        cold, e1 = swarmnav(tmp / "main", tmp / "out", *main_job)
        warm, e2 = swarmnav(tmp / "main", tmp / "out", *main_job)
        print(f"{'hes, 1000 steps (README main job)':34s} {cold:9.1f} {warm:9.1f}  {noticed(e1)}/{noticed(e2)}")
        shared = tmp / "shared"
        total = 0.0
        for method, scene in CASES:
            wall, _ = swarmnav(shared, tmp / "out", "run", "--method", method, "--scenario", scene,
                               "--steps", args.steps, "--quiet", "--force")
            total += wall
        print(f"{'all cases in sequence, one cache':34s} {total:9.1f}")
        if not args.skip_cross:
            wall, err = swarmnav(tmp / "cross", tmp / "cross-out", "experiment", "cross-method", "--seeds", "1",
                                 "--set", "horizon=1", "--workers", "1", "--quiet")
            print(f"{'experiment cross-method, 1 seed':34s} {wall:9.1f}            notice: {noticed(err)}")


if __name__ == "__main__":
    main()
