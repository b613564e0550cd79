"""Sensing speed on a 512 x 512 MovingAI-style map against today's scenes (issue 40).

Run: ``python benchmarks/bench_maps.py``. Writes two 512 x 512 maps of 1 m cells as MovingAI
files and loads them as scenes: ``random512-25`` (every cell blocked with probability 0.25, seed
0: the kind of MovingAI's random512-25 maps and the worst case for merging) and ``room512-32``
(32 x 32-cell rooms with walls one cell thick and a 4-cell door on each wall, as MovingAI's
room512-32 maps). Prints the merged box count, the time to load the scene, and for each map and
for today's corridor (benchmarks/bench_sensing.py) and a random_forest scene: the LiDAR ring
(20 agents x 360 rays, 20 m) per ray, signed distance per point, and an ESDF build per node
(a 40 m x 40 m window at 0.25 m). It also checks the LiDAR ring and the signed distance on the
merged random512-25 map against one box per occupied cell (the per-cell oracle), and times the
3-D range scan on a 64 x 64 x 16 MovingAI-style voxel map and the default mockamap world
(``mockamap:type=1,seed=1``, 16 731 boxes) beside the Table II 3-D forest, with the 3-D ESDF build
on the last two. ``python benchmarks/bench_maps.py --3d`` runs the 3-D part alone.

Timings are the best of several repeats after a warm-up call (compilation excluded), pinned
to CPU 0 where ``os.sched_setaffinity`` exists. The maps of 256 boxes or more are sensed through
``swarmnav.sensing.index``. Figures: docs/maps.md (Speed).
"""

from __future__ import annotations

import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
try:
    import swarmnav  # noqa: F401
except ImportError:  # running from a checkout without installing
    sys.path.insert(0, str(HERE.parent / "src"))

from bench_sensing import best_time, corridor  # noqa: E402

from swarmnav.sensing import Esdf, lidar_ring, range_scan, signed_distance  # noqa: E402
from swarmnav.world import load_scenario  # noqa: E402
from swarmnav.world.maps import load_grid  # noqa: E402
from swarmnav.world.obstacles import Box, Geometry  # noqa: E402

SIDE = 512


def random_map(p: float, seed: int = 0) -> np.ndarray:
    """(SIDE, SIDE) bool, file rows top-down: each cell blocked with probability ``p``."""
    return np.random.default_rng(seed).random((SIDE, SIDE)) < p


def room_map(room: int = 32, door: int = 4) -> np.ndarray:
    g = np.zeros((SIDE, SIDE), dtype=bool)
    g[::room, :] = True
    g[:, ::room] = True
    g[-1, :] = g[:, -1] = True
    for k in range(0, SIDE, room):  # a door in the middle of every wall segment
        for m in range(0, SIDE, room):
            mid = m + room // 2 - door // 2
            g[k, mid : mid + door] = False
            g[mid : mid + door, k] = False
    return g


def write_map(path: Path, occ: np.ndarray) -> None:
    rows = ["".join("@" if o else "." for o in r) for r in occ]
    path.write_text(f"type octile\nheight {SIDE}\nwidth {SIDE}\nmap\n" + "\n".join(rows) + "\n")


def free_points(geom: Geometry, lo, hi, n: int, rng) -> np.ndarray:
    out = np.zeros((0, 2))
    while len(out) < n:
        p = rng.uniform(lo, hi, (4 * n, 2))
        out = np.vstack([out, p[signed_distance(geom, p) > 0.05]])
    return out[:n]


def measure(name: str, geom: Geometry, window: tuple[float, float, float, float], rng) -> dict:
    x0, y0, x1, y1 = window
    agents = free_points(geom, (x0, y0), (x1, y1), 20, rng)
    t_lidar = best_time(lambda: lidar_ring(geom, agents, 360, 20.0))
    pts = rng.uniform((x0, y0), (x1, y1), (10_000, 2))
    t_sd = best_time(lambda: signed_distance(geom, pts), repeats=3)
    cx, cy = (x0 + x1) / 2, (y0 + y1) / 2
    eb = (cx - 20.0, cy - 20.0, cx + 20.0, cy + 20.0)
    t_esdf = best_time(lambda: Esdf.build(geom, eb, 0.25), repeats=2, min_time=0.05)
    nodes = Esdf.build(geom, eb, 0.25).values.size
    return {"name": name, "ray": t_lidar / (20 * 360), "point": t_sd / 1e4, "node": t_esdf / nodes,
            "boxes": geom.n_polygons + geom.n_circles}


#: The Table II forest in 3-D (experiments spec ``sph-table2-3d``: full-height trunks, 6 m).
FOREST_3D = "random_forest:density=0.15,seed=1,length=12,r_min=1.0,r_max=2.0,min_passage=1.0,height=6"
#: The default mockamap world (docs/maps-generators.md): Perlin noise, 200 x 200 x 40 voxels of 0.1 m.
MOCKAMAP = "mockamap:type=1,seed=1"


def _free3d(geom: Geometry, lo, hi, n: int, rng) -> np.ndarray:
    out = np.zeros((0, 3))
    while len(out) < n:
        p = rng.uniform(lo, hi, (8 * n, 3))
        out = np.vstack([out, p[signed_distance(geom, p) > 0.05]])
    return out[:n]


def measure3d(rng) -> list[dict]:
    """Per 3-D world: the range scan (20 agents x 360 random directions, 20 m) per ray [s], and for
    the mockamap world and the forest the ESDF build over the scene's bounds at SPH's 0.1 m [s].
    Worlds: a 64 x 64 x 16 voxel map at 0.5 m (each voxel occupied with probability 0.1, seed 0),
    the default mockamap world and the Table II 3-D forest. Large worlds are indexed
    (swarmnav.sensing.index3d); on the mockamap world the plain scan is timed too (4 agents)."""
    import swarmnav.sensing.index3d as index3d

    occ = np.random.default_rng(0).random((16, 64, 64)) < 0.1
    z, y, x = np.nonzero(occ)
    dirs = rng.normal(size=(360, 3))
    dirs /= np.linalg.norm(dirs, axis=1)[:, None]
    rows = []
    with tempfile.TemporaryDirectory() as d:
        f = Path(d) / "v.3dmap"
        f.write_text("voxel 64 64 16\n" + "".join(f"{a} {b} {c}\n" for a, b, c in zip(x, y, z)))
        voxels = Geometry.from_obstacles(load_grid(f, cell=0.5).boxes(), dim=3)
    t0 = time.perf_counter()
    mock = load_scenario(MOCKAMAP)
    t_mock = time.perf_counter() - t0
    forest = load_scenario(FOREST_3D)
    worlds = ((f"voxel map 64x64x16 ({int(occ.sum())} voxels)", voxels, (0, 0, 0), (32, 32, 8), None),
              (MOCKAMAP, mock.geometry, (-10, -10, 0.2), (10, 10, 3.8), mock.bounds),
              (FOREST_3D.split(",min_passage")[0] + ",...,height=6", forest.geometry, forest.lower, forest.upper,
               forest.bounds))
    for name, geom, lo, hi, bounds in worlds:
        agents = _free3d(geom, lo, hi, 20, rng)
        r = {"name": name, "prims": geom.n_polygons + geom.n_circles + geom.n_spheres,
             "indexed": index3d.box_index(geom) is not None,
             "ray": best_time(lambda: range_scan(geom, agents, dirs, 20.0), repeats=3) / (20 * 360)}
        if name == MOCKAMAP:
            r["load"] = t_mock
            with_plain = agents[:4]
            try:
                index3d.INDEX3D_MIN_PRIMITIVES, keep = 10**9, index3d.INDEX3D_MIN_PRIMITIVES
                index3d._cache.clear()
                r["plain_ray"] = best_time(lambda: range_scan(geom, with_plain, dirs, 20.0), repeats=1,
                                           min_time=0.0) / (4 * 360)
                pts = _free3d(geom, lo, hi, 500, rng)
                r["plain_node"] = best_time(lambda: signed_distance(geom, pts), repeats=1, min_time=0.0) / 500
            finally:
                index3d.INDEX3D_MIN_PRIMITIVES = keep
                index3d._cache.clear()
        if bounds is not None:
            Esdf.build(geom, (0.0, 0.0, 1.0, 0.5, 0.5, 1.5), 0.1)  # compile (or load) the kernels
            t0 = time.perf_counter()
            esdf = Esdf.build(geom, bounds, 0.1)  # one build: seconds, and the same work every time
            r["esdf"] = time.perf_counter() - t0
            r["nodes"] = esdf.values.size
        rows.append(r)
    return rows


def report3d(rows: list[dict]) -> None:
    forest = rows[-1]["ray"]
    print("3-D range scan, 20 agents x 360 random directions, 20 m; ESDF over the scene's bounds at 0.1 m")
    print(f"{'scene':<64}{'prims':>7}{'index':>6}{'ns/ray':>9}{'x forest':>9}{'ESDF s':>8}{'M nodes':>8}")
    for r in rows:
        esdf = f"{r['esdf']:.2f}" if "esdf" in r else "-"
        nodes = f"{r['nodes'] / 1e6:.2f}" if "nodes" in r else "-"
        print(f"{r['name']:<64}{r['prims']:>7}{'yes' if r['indexed'] else 'no':>6}{r['ray'] * 1e9:>9.0f}"
              f"{r['ray'] / forest:>9.2f}{esdf:>8}{nodes:>8}")
        if "plain_ray" in r:
            print(f"  {r['name']} without the index: {r['plain_ray'] * 1e9:.0f} ns/ray (4 agents), exact signed "
                  f"distance {r['plain_node'] * 1e6:.0f} us/point (an ESDF of {r['nodes'] / 1e6:.2f} M nodes point "
                  f"by point ~{r['plain_node'] * r['nodes']:.0f} s); scene load {r['load']:.1f} s")


def main() -> None:
    only_3d = "--3d" in sys.argv[1:]
    pinned = False
    if hasattr(os, "sched_setaffinity"):
        try:
            os.sched_setaffinity(0, {0})
            pinned = True
        except OSError:
            pass
    rng = np.random.default_rng(1)
    if only_3d:
        print(f"3-D worlds only ({'pinned to CPU 0' if pinned else 'not pinned'}; best of repeats)")
        report3d(measure3d(rng))
        return
    rows = [measure("corridor (bench_sensing)", corridor(), (-10.0, -9.0, 40.0, 9.0), rng)]
    forest = load_scenario("random_forest:density=0.25,seed=1")
    b = forest.bounds
    rows.append(measure("random_forest:density=0.25,seed=1", forest.geometry, (b[0], b[1], b[2], b[3]), rng))
    base = rows[0]["ray"]
    with tempfile.TemporaryDirectory() as d:
        for name, occ in (("random512-25", random_map(0.25)), ("room512-32", room_map())):
            f = Path(d) / f"{name}.map"
            write_map(f, occ)
            t0 = time.perf_counter()
            scn = load_scenario(f"{f}#start=1.5:1.5,goal=500.5:500.5,n=1,spread=1") if name == "room512-32" \
                else None
            grid = load_grid(f)
            geom = Geometry.from_obstacles(grid.boxes())
            t_load = time.perf_counter() - t0
            r = measure(f"{name} ({int(occ.sum())} cells)", geom, (0.0, 0.0, float(SIDE), float(SIDE)), rng)
            r["load"] = t_load
            rows.append(r)
            if name == "random512-25":  # exact: the merged boxes against one box per cell
                cells = Geometry.from_obstacles([Box((float(ix), float(iy)), (ix + 1.0, iy + 1.0))
                                                 for iy, ix in zip(*np.nonzero(grid.occupied))])
                agents = free_points(geom, (0.0, 0.0), (SIDE, SIDE), 50, rng)
                dl = np.abs(lidar_ring(geom, agents, 360, 20.0) - lidar_ring(cells, agents, 360, 20.0)).max()
                pts = free_points(geom, (0.0, 0.0), (SIDE, SIDE), 2000, rng)
                ds = np.abs(signed_distance(geom, pts) - signed_distance(cells, pts)).max()
                t_cells = best_time(lambda: lidar_ring(cells, agents[:20], 360, 20.0), repeats=3) / (20 * 360)
                print(f"oracle on {name}: {geom.n_polygons} merged boxes vs {cells.n_polygons} cells: "
                      f"max |LiDAR difference| {dl:.3g} m over 50 agents x 360 rays, max |signed distance "
                      f"difference| {ds:.3g} m over 2000 free points; per-cell LiDAR {t_cells * 1e9:.0f} ns/ray")
            del scn
    print(f"sensing on maps ({'pinned to CPU 0' if pinned else 'not pinned'}; best of repeats)")
    print(f"{'scene':<40}{'boxes':>8}{'load s':>8}{'ns/ray':>9}{'x corr.':>8}{'us/point':>10}{'us/node':>9}")
    for r in rows:
        load = f"{r['load']:.2f}" if "load" in r else "-"
        print(f"{r['name']:<40}{r['boxes']:>8}{load:>8}{r['ray'] * 1e9:>9.1f}{r['ray'] / base:>8.1f}"
              f"{r['point'] * 1e6:>10.2f}{r['node'] * 1e6:>9.2f}")
    report3d(measure3d(rng))


if __name__ == "__main__":
    main()
