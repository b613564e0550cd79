"""Write the small example maps of ``examples/maps/`` (made by us; same licence as swarmnav).

Run: ``python scripts/make_map_examples.py``. ``warehouse.map`` is a 48 x 32 MovingAI grid
(shelves ``@``, a few trees ``T``, a swamp patch ``S``); ``warehouse.map.scen`` holds start/goal
rows whose optimal lengths this script computes (octile, diagonal sqrt 2, no corner cutting, as
MovingAI's); ``office.yaml`` + ``office.pgm`` is a ROS map_server map of 0.25 m pixels;
``hall.ply`` and ``hall.pcd`` are one point cloud (a scanned hall) in both formats.
"""

from __future__ import annotations

import heapq
import math
from pathlib import Path

import numpy as np
from PIL import Image

OUT = Path(__file__).resolve().parents[1] / "examples" / "maps"


def warehouse() -> list[str]:
    w, h = 48, 32
    g = [["."] * w for _ in range(h)]
    for x in range(w):  # outer wall
        g[0][x] = g[h - 1][x] = "@"
    for y in range(h):
        g[y][0] = g[y][w - 1] = "@"
    for row in (6, 13, 20):  # three rows of shelves, 2 cells deep, aisles 5 cells wide
        for x0 in (8, 20, 32):
            for y in range(row, row + 2):
                for x in range(x0, x0 + 9):
                    g[y][x] = "@"
    for x, y in ((4, 26), (5, 27), (43, 4), (42, 27)):
        g[y][x] = "T"
    for y in range(25, 28):
        for x in range(20, 26):
            g[y][x] = "S"
    return ["".join(r) for r in g]


def octile(grid: list[str], s: tuple[int, int], t: tuple[int, int]) -> float:
    """Shortest 8-connected path length [cells], diagonal sqrt 2, no corner cutting."""
    h, w = len(grid), len(grid[0])
    free = lambda x, y: 0 <= x < w and 0 <= y < h and grid[y][x] in ".GS"  # noqa: E731
    dist = {s: 0.0}
    q = [(0.0, s)]
    while q:
        d, (x, y) = heapq.heappop(q)
        if (x, y) == t:
            return d
        if d > dist[(x, y)]:
            continue
        for dx in (-1, 0, 1):
            for dy in (-1, 0, 1):
                if (dx, dy) == (0, 0) or not free(x + dx, y + dy):
                    continue
                if dx and dy and not (free(x + dx, y) and free(x, y + dy)):
                    continue
                nd = d + (math.sqrt(2.0) if dx and dy else 1.0)
                if nd < dist.get((x + dx, y + dy), math.inf):
                    dist[(x + dx, y + dy)] = nd
                    heapq.heappush(q, (nd, (x + dx, y + dy)))
    raise ValueError("no path")


def office() -> np.ndarray:
    """Grey image, row 0 at the top: 254 free, 0 wall, 205 unknown (ROS's colours)."""
    h, w = 80, 120  # 30 m x 20 m at 0.25 m
    img = np.full((h, w), 254, dtype=np.uint8)
    img[:, :4] = img[:, -4:] = 205  # unknown margin outside the walls
    img[:4, :] = img[-4:, :] = 205
    img[4:6, 4:-4] = img[-6:-4, 4:-4] = 0
    img[4:-4, 4:6] = img[4:-4, -6:-4] = 0
    img[6:50, 58:60] = 0  # a partition with a 6 m door at the bottom
    for cx, cy in ((28, 30), (28, 55), (90, 25), (90, 55)):  # desks
        img[cy - 4 : cy + 4, cx - 8 : cx + 8] = 0
    return img


def hall() -> np.ndarray:
    """Points [m] a laser scan of an 8 m x 6 m x 2.5 m hall might give, one per 0.1 m of surface
    (a little noise, every point inside its 0.1 m voxel): a wall across x = 4 m with a 1.6 m
    doorway at y = 2.2-3.8 m, two 0.6 m wide square pillars and a 0.1 m post in each corner
    (the scene is walled at the cloud's extent, so floor, ceiling and outer walls need no points)."""
    rng = np.random.default_rng(40)
    c = (np.arange(80) + 0.5) * 0.1  # voxel centres along x [m]
    pts = [np.array([[x, y, z] for x in (0.05, 7.95) for y in (0.05, 5.95) for z in c[:25]])]  # corner posts
    wall = [[4.05, y, z] for y in c[:60] for z in c[:25] if not 2.2 < y < 3.8]
    pts.append(np.array(wall))
    for px, py in ((2.0, 1.5), (6.0, 4.5)):  # pillars: the four faces of [p - 0.3, p + 0.3]^2
        side = (np.arange(6) + 0.5) * 0.1 - 0.3
        for z in c[:25]:
            for s in side:
                pts.append(np.array([[px + s, py - 0.25, z], [px + s, py + 0.25, z],
                                     [px - 0.25, py + s, z], [px + 0.25, py + s, z]]))
    p = np.vstack(pts)
    return (p + rng.uniform(-0.02, 0.02, p.shape)).astype(np.float32)


def write_hall(points: np.ndarray) -> None:
    from plyfile import PlyData, PlyElement
    from pypcd4 import Encoding, PointCloud

    vertex = np.empty(len(points), dtype=[("x", "f4"), ("y", "f4"), ("z", "f4")])
    vertex["x"], vertex["y"], vertex["z"] = points.T
    PlyData([PlyElement.describe(vertex, "vertex")]).write(str(OUT / "hall.ply"))  # binary little endian
    PointCloud.from_xyz_points(points).save(OUT / "hall.pcd", encoding=Encoding.BINARY_COMPRESSED)


def main() -> None:
    OUT.mkdir(parents=True, exist_ok=True)
    g = warehouse()
    (OUT / "warehouse.map").write_text(f"type octile\nheight {len(g)}\nwidth {len(g[0])}\nmap\n" + "\n".join(g) + "\n")
    pairs = [((3, 3), (44, 28)), ((3, 28), (44, 3)), ((4, 17), (44, 17)), ((24, 3), (24, 29))]
    rows = ["version 1"]
    for (s, t) in pairs:
        rows.append(f"0\twarehouse.map\t{len(g[0])}\t{len(g)}\t{s[0]}\t{s[1]}\t{t[0]}\t{t[1]}\t{octile(g, s, t):.8f}")
    (OUT / "warehouse.map.scen").write_text("\n".join(rows) + "\n")
    Image.fromarray(office()).save(OUT / "office.pgm")
    (OUT / "office.yaml").write_text(
        "image: office.pgm\nresolution: 0.25\norigin: [-2.0, -1.0, 0.0]\nnegate: 0\n"
        "occupied_thresh: 0.65\nfree_thresh: 0.196\nmode: trinary\n")
    write_hall(hall())


if __name__ == "__main__":
    main()
