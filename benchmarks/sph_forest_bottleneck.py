"""Widest crossing of each Table II forest: how wide a corridor joins the two ends of the strip.

    PYTHONPATH=src python benchmarks/sph_forest_bottleneck.py [--seeds 1-40]

For each forest of ``sph-forest`` (density 0.15-0.45) the widest w such that free space with
clearance >= w / 2 from every disc and both walls joins x = -1 m to x = 13 m (0.1 m grid,
4-connected; bisection to 0.05 m). Two robots pass a corridor abreast with neither inside the
ESDF band and no contact only if it is at least 2 d_thr + 2 body radii = 1.4 m wide; below that
the swarm must cross in single file, and a robot beside another in the gap is pressed into it by
the environment force (docs/methods/sph.md, *Why the densest forests fall short*; the table this prints:
docs/reproduction/sph.md, *The forests*).
"""

from __future__ import annotations

import argparse

import numpy as np
from scipy import ndimage

from swarmnav.world import load_scenario

FOREST = "random_forest:density={d},seed={s},length=12,r_min=1.0,r_max=2.0,min_passage=1.0"  # as sph-forest
LENGTH, WIDTH = 12.0, 20.0
ABREAST = 1.4  # [m]: 2 d_thr (0.5 m) + 2 body radii (0.2 m)


def widest_crossing(centers: np.ndarray, radii: np.ndarray, res: float = 0.1) -> float:
    """Largest corridor width [m] (to 0.05 m) joining both ends of the strip between the walls."""
    xs = np.arange(-1.0, LENGTH + 1.0 + 1e-9, res)
    ys = np.arange(-WIDTH / 2, WIDTH / 2 + 1e-9, res)
    gx, gy = np.meshgrid(xs, ys)
    clear = WIDTH / 2 - np.abs(gy)
    for c, r in zip(centers, radii):
        clear = np.minimum(clear, np.hypot(gx - c[0], gy - c[1]) - r)

    def joins(w: float) -> bool:
        lab, _ = ndimage.label(clear >= w / 2)
        left = set(lab[:, 0][lab[:, 0] > 0].tolist())
        return any(v in left for v in lab[:, -1][lab[:, -1] > 0].tolist())

    lo, hi = 0.0, float(2 * clear.max())
    while hi - lo > 0.05:
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if joins(mid) else (lo, mid)
    return lo


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default="1-40")
    a = ap.parse_args()
    s0, _, s1 = a.seeds.partition("-")
    seeds = range(int(s0), int(s1 or s0) + 1)
    print(f"{'d_obs':>6} {'forests':>7} {'< 1.4 m':>8} {'median (m)':>10}  widest crossing per seed (m)")
    for d in (0.15, 0.25, 0.35, 0.45):
        ws = []
        for s in seeds:
            scn = load_scenario(FOREST.format(d=d, s=s))
            discs = [o for o in scn.obstacles if type(o).__name__ == "Circle"]
            ws.append(widest_crossing(np.array([o.center for o in discs]), np.array([o.radius for o in discs])))
        w = np.array(ws)
        print(f"{d:>6g} {len(w):>7} {int((w < ABREAST).sum()):>8} {np.median(w):>10.2f}  "
              + " ".join(f"{x:.2f}" for x in w))


if __name__ == "__main__":
    main()
