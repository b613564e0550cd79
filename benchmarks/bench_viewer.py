"""The replay viewer on a 1,000-agent x 1,000-step run: file size, open time, frame rate.

Run: ``python benchmarks/bench_viewer.py [--dim 3]`` (needs Debian's ``chromium``). It flies a
real run, APF with N = 1000 for K = 1000 steps (dt = 0.1 s) on a 205 m x 84 m field of discs
and boxes (``--dim 3``: a 20 m tall 3-D field of pillars, spheres and boxes)
(written by ``swarmnav run``, the simulator's own writer), writes its viewer with
``swarmnav view`` and opens it in headless Chromium (software WebGL, as CI has no GPU):

- file size of ``viewer.html`` [MB] (target <= 25 MB);
- open time [s]: from the navigation to the first drawn frame, data decoded (target <= 2 s);
- frames per second while playing (target >= 30 fps), counted with requestAnimationFrame
  over ``--seconds`` of play at 12x real time (120 steps/s: at 60 Hz or less every frame
  draws a new step; 5 s play 600 of the 1000 steps): top-down, and in perspective twice, at
  full resolution (adaptive resolution off) and with the page's default adaptive resolution
  (the mean drawing-buffer scale per axis is printed); ``draws`` says how many frames drew;
- CPU time of all the browser's processes per frame [ms]: what a frame costs, which the frame
  rate shows only on an otherwise idle machine (Linux: read from /proc).

The APF parameters are its defaults; the run is only a source of 1000 realistic paths.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

#: A field large enough to spawn 1000 agents 0.6 m apart: discs and boxes between spawn and goal.
SCENE = """
name = "bench_viewer_field"
description = "Viewer benchmark: 1000 agents across a 200 m x 80 m field of discs and boxes."
[world]
bounds = [-45.0, -42.0, 160.0, 42.0]
[swarm]
n = 1000
spawn = [-40.0, -30.0, 0.0, 30.0]
[goal]
position = [150.0, 0.0]
"""


#: The 3-D form (``--dim 3``): a 205 m x 84 m x 20 m box, pillars, spheres and boxes.
SCENE_3D = """
name = "bench_viewer_field_3d"
description = "Viewer benchmark: 1000 agents across a 3-D field of pillars, spheres and boxes."
[world]
bounds = [-45.0, -42.0, 0.0, 160.0, 42.0, 20.0]
[swarm]
n = 1000
spawn = [-40.0, -30.0, 2.0, 0.0, 30.0, 8.0]
[goal]
position = [150.0, 0.0, 5.0]
"""


def scene_text_3d() -> str:
    import numpy as np

    rng = np.random.default_rng(7)
    parts = [SCENE_3D]
    for _ in range(30):
        x, y, r = rng.uniform(15, 130), rng.uniform(-35, 35), rng.uniform(0.8, 2.5)
        parts.append(f'[[obstacles]]\ntype = "cylinder"\ncenter = [{x:.2f}, {y:.2f}]\nradius = {r:.2f}\n'
                     f'z = [0.0, {rng.uniform(6, 20):.2f}]\n')
    for _ in range(12):
        x, y, z, r = rng.uniform(15, 130), rng.uniform(-35, 35), rng.uniform(3, 15), rng.uniform(1, 3)
        parts.append(f'[[obstacles]]\ntype = "sphere"\ncenter = [{x:.2f}, {y:.2f}, {z:.2f}]\nradius = {r:.2f}\n')
    for _ in range(10):
        x, y, z = rng.uniform(15, 130), rng.uniform(-35, 35), rng.uniform(0, 10)
        w, h, t = rng.uniform(1, 6), rng.uniform(1, 6), rng.uniform(2, 8)
        parts.append(f'[[obstacles]]\ntype = "box"\nmin = [{x:.2f}, {y:.2f}, {z:.2f}]\n'
                     f'max = [{x + w:.2f}, {y + h:.2f}, {z + t:.2f}]\n')
    return "\n".join(parts)


def scene_text() -> str:
    import numpy as np

    rng = np.random.default_rng(7)
    parts = [SCENE]
    for _ in range(40):
        x, y, r = rng.uniform(15, 130), rng.uniform(-35, 35), rng.uniform(0.8, 2.5)
        parts.append(f'[[obstacles]]\ntype = "circle"\ncenter = [{x:.2f}, {y:.2f}]\nradius = {r:.2f}\n')
    for _ in range(12):
        x, y = rng.uniform(15, 130), rng.uniform(-35, 35)
        w, h = rng.uniform(1, 6), rng.uniform(1, 6)
        parts.append(f'[[obstacles]]\ntype = "box"\nmin = [{x:.2f}, {y:.2f}]\nmax = [{x + w:.2f}, {y + h:.2f}]\n')
    return "\n".join(parts)


def cpu_seconds(pid: int) -> float:
    """CPU time (user + system) of a process and all its descendants [s], from /proc."""
    total, todo = 0.0, [pid]
    while todo:
        p = todo.pop()
        try:
            for task in os.listdir(f"/proc/{p}/task"):
                with open(f"/proc/{p}/task/{task}/children") as f:
                    todo += [int(c) for c in f.read().split()]
            with open(f"/proc/{p}/stat") as f:
                fields = f.read().rsplit(")", 1)[1].split()
            total += (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")
        except OSError:  # a process that ended meanwhile
            pass
    return total


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=5.0, help="play time per view for the frame count [s]")
    ap.add_argument("--keep", metavar="DIR", help="keep the run directory here (default: a temporary one)")
    ap.add_argument("--dim", type=int, choices=(2, 3), default=2,
                    help="2 (default): a planar field, opened top-down; 3: a 3-D field, opened in perspective")
    args = ap.parse_args()

    from swarmnav.cli import main as cli
    from swarmnav.viz.headless import Browser

    with tempfile.TemporaryDirectory() as tmp:
        root = Path(args.keep or tmp)
        root.mkdir(parents=True, exist_ok=True)
        scene = root / "field.toml"
        scene.write_text(scene_text() if args.dim == 2 else scene_text_3d())
        run_dir = root / "run"
        t0 = time.perf_counter()
        assert cli(["run", "--method", "apf", "--scenario-file", str(scene), "--steps", "1000", "--seed", "1",
                    "--out", str(run_dir), "--quiet"]) == 0
        t_run = time.perf_counter() - t0
        t0 = time.perf_counter()
        assert cli(["view", str(run_dir)]) == 0
        t_write = time.perf_counter() - t0
        html = run_dir / "viewer.html"
        size = html.stat().st_size / 1e6
        print(f"run (apf, N = 1000, K = 1000, {args.dim}-D): {t_run:.1f} s;  swarmnav view: {t_write:.2f} s")
        print(f"file size: {size:.2f} MB  (target <= 25 MB)")
        with Browser(1280, 800, timeout=120) as b:
            b.open(html)
            b.eval("window.swarmnav.ready")
            opened = b.eval("window.swarmnav.stats().readyMs") / 1000
            first = "top-down" if args.dim == 2 else "perspective, three.js loaded"
            print(f"open time: {opened:.2f} s from navigation to the first frame ({first}), data decoded  "
                  f"(target <= 2 s)")
            for view, resolution, name in (("top", "full", "top-down"),
                                           ("persp", "full", "perspective, full resolution"),
                                           ("persp", "adaptive", "perspective, adaptive resolution")):
                b.eval(f"window.swarmnav.view('{view}')")
                b.eval(f"window.swarmnav.resolution('{resolution}')")
                b.eval("window.swarmnav.seek(0)")
                before = b.eval("window.swarmnav.stats()")
                cpu0 = cpu_seconds(b.proc.pid)
                b.eval("window.swarmnav.play(12)")
                t0 = time.perf_counter()
                time.sleep(args.seconds)
                after = b.eval("window.swarmnav.stats()")
                dt = time.perf_counter() - t0
                cpu = cpu_seconds(b.proc.pid) - cpu0
                b.eval("window.swarmnav.pause()")
                frames, draws = after["frames"] - before["frames"], after["draws"] - before["draws"]
                ms = (after["drawMs"] - before["drawMs"]) / max(draws, 1)
                scale = (after["scaleSum"] - before["scaleSum"]) / max(draws, 1)
                print(f"{name}: {frames / dt:.1f} fps  (target >= 30 fps)\n"
                      f"    {frames} frames in {dt:.1f} s, {draws} drew a new step; page script {ms:.1f} ms, "
                      f"browser CPU {1000 * cpu / max(frames, 1):.0f} ms per frame"
                      + (f"; mean drawing-buffer scale {scale:.2f}" if resolution == "adaptive" else ""))
            print(f"load average at the end: {os.getloadavg()[0]:.1f} ({os.cpu_count()} cores)")
            if b.errors:
                print("page errors:", *b.errors, sep="\n  ")


if __name__ == "__main__":
    main()
