"""Maps from scans (``sense.map = scans``): each robot's map is what its own range scans hit."""

import numpy as np
import pytest

import swarmnav
from _helpers.cli import run_cli
from swarmnav.errors import ConfigError
from swarmnav.methods import registry
from swarmnav.methods.base import Observation
from swarmnav.planning.maps import OccupancyMaps
from swarmnav.planning.scanned import Scanner
from swarmnav.sensing import signed_distance
from swarmnav.sensing.perception import Perception, sense_params
from swarmnav.world.catalog import load_scenario
from swarmnav.world.obstacles import Box, Circle, Geometry

BOUNDS = (-6.0, -6.0, 6.0, 6.0)
RES, INFLATION, MARGIN, WIDE = 0.1, 0.3, 0.5, 0.9  # [m]: the classes SPH's defaults give (d_thr, plan_clearance)


def _maps(obstacles, n=1):
    return OccupancyMaps(tuple(obstacles), BOUNDS, n, RES, INFLATION, 20.0, margin=MARGIN, wide=WIDE)


def _scan(obstacles, positions, **sense):
    """One scan of every robot at ``positions`` into fresh maps from scans; returns the maps."""
    x = np.asarray(positions, dtype=float)
    geom = Geometry.from_obstacles(list(obstacles), dim=2)
    maps = _maps(obstacles, len(x))
    p = sense_params({"sense.map": "scans", **sense})
    perception = Perception(p, x, seed=1)
    est, vel = perception.observe(0.0, x, np.zeros_like(x))
    scanner = Scanner(p, geom, maps, 20.0, 0.01)
    scanner.sweep(Observation(0, 0.0, est, vel, sensing=perception), est)
    return maps


def _centres(maps):
    iy, ix = np.indices(maps.shape)
    return maps.center(iy.ravel(), ix.ravel())


def test_a_scanned_wall_is_in_the_map_and_what_it_hides_is_not():
    wall = Box((1.0, -2.0), (1.2, 2.0))
    hidden = Circle((3.0, 0.0), 0.5)  # behind the wall, seen from the origin
    beside = Circle((0.0, 3.0), 0.5)  # in plain view
    maps = _scan([wall, hidden, beside], [[0.0, 0.0]])
    top = len(maps.levels) + 1
    grid = maps.grids[0].ravel()
    pts = _centres(maps)
    face = (np.abs(pts[:, 0] - 1.0) < 0.05) & (np.abs(pts[:, 1]) < 1.5)  # the wall's face toward the robot
    assert face.sum() > 20 and np.all(grid[face] == top)
    near_hidden = signed_distance(Geometry.from_obstacles([hidden]), pts) < MARGIN
    assert np.all(grid[near_hidden & (pts[:, 0] > 1.2 + WIDE)] == 0)  # occluded: not in the map
    near_beside = np.abs(signed_distance(Geometry.from_obstacles([beside]), pts)) < 0.05
    seen_side = pts[:, 1] < 3.0
    assert np.all(grid[near_beside & seen_side] == top)
    # the known map holds all three within range: the hidden disc is the difference
    known = _maps([wall, hidden, beside])
    known.observe(0, np.zeros(2))
    assert np.all(known.grids[0].ravel()[near_hidden] > 0)


def test_with_no_noise_and_dense_rays_the_scanned_map_equals_the_known_map_on_the_cells_scanned():
    disc = Circle((0.0, 0.0), 1.0)
    robot = np.array([4.0, 0.0])
    rays = 7200
    maps = _scan([disc], [robot], **{"sense.scan_rays": rays})
    known = _maps([disc])
    known.observe(0, robot)
    pts = _centres(maps)
    rel = pts - disc.center
    dist = np.linalg.norm(rel, axis=1) - disc.radius  # exact clearance of each cell centre [m]
    normal = rel / np.linalg.norm(rel, axis=1)[:, None]
    to_robot = (robot - disc.center) / np.linalg.norm(robot - disc.center)
    # scanned: outside the disc, within the widest clearance, nearest surface point well in view
    scanned = (dist > 0) & (dist < WIDE + 0.2) & (normal @ to_robot > 0.5)
    # classes are read from cell-centre distances: a cell may differ only within half a cell
    # diagonal plus the returns' spacing (3 m x 2 pi / 7200 rad) of a class threshold
    slack = RES * np.sqrt(2) / 2 + 3.0 * 2 * np.pi / rays
    clear = np.all(np.abs(dist[:, None] - np.array([INFLATION, MARGIN, WIDE])) > slack, axis=1)
    a, b = maps.grids[0].ravel(), known.grids[0].ravel()
    assert (scanned & clear).sum() > 100
    assert np.array_equal(a[scanned & clear], b[scanned & clear])
    assert np.all(np.abs(a[scanned].astype(int) - b[scanned]) <= 1)
    # the distance field from the scans is the exact clearance to within a cell diagonal
    d, _ = maps.query(pts[scanned & clear][:1])
    assert d[0] == pytest.approx(dist[scanned & clear][0], abs=RES * np.sqrt(2))


def test_returns_are_placed_from_the_estimated_pose():
    wall = Box((1.0, -2.0), (1.2, 2.0))
    exact = _scan([wall], [[0.0, 0.0]])
    drifted = _scan([wall], [[0.0, 0.0]], **{"sense.pos_noise": 0.5})
    assert not np.array_equal(exact.grids[0], drifted.grids[0])  # the wall moved with the estimate


def test_maps_accumulate_over_scans():
    walls = [Box((2.0, -1.0), (2.2, 1.0)), Box((-2.2, -1.0), (-2.0, 1.0))]
    one = _scan(walls, [[0.0, 0.0]], **{"sense.fov": 90})  # sees the wall ahead only (+x at rest)
    assert one.grids[0].max() > 0
    geom = Geometry.from_obstacles(walls, dim=2)
    maps = _maps(walls)
    p = sense_params({"sense.map": "scans", "sense.fov": 90})
    x = np.zeros((1, 2))
    perception = Perception(p, x, seed=1)
    scanner = Scanner(p, geom, maps, 20.0, 0.1)
    cells = []
    for k, v in enumerate([[1.0, 0.0], [-1.0, 0.0]]):  # turn around: the first wall stays in the map
        est, vel = perception.observe(0.1 * k, x, np.array([v]))
        scanner.sweep(Observation(k, 0.1 * k, est, vel, sensing=perception), est)
        cells.append(int((maps.grids[0] > 0).sum()))
    assert cells[1] > cells[0] > 0
    pts = _centres(maps)
    assert maps.grids[0].ravel()[np.argmin(np.linalg.norm(pts - [2.0, 0.0], axis=1))] > 0


@pytest.mark.parametrize("method", ["sph", "ego-swarm", "lsc"])
def test_known_maps_are_the_default_bit_for_bit_and_scans_change_the_flight(method):
    kw = dict(seed=2, steps=60)
    scene = load_scenario("default_corridor", n=4)
    base = swarmnav.run(method, scene, **kw)
    known = swarmnav.run(method, scene, **kw, **{"sense.map": "known"})
    assert np.array_equal(base.positions, known.positions) and base.metrics == known.metrics
    scans = swarmnav.run(method, scene, **kw, **{"sense.map": "scans", "sense.scan_rate": 5})
    every = max(1, round(1.0 / (5 * registry.make(method).dt)))  # control steps between scans at 5 Hz
    assert scans.metrics["scan_count"] == -(-60 // every)
    if method == "sph":  # its obstacle force reads each robot's field from its scans from the first step
        assert not np.array_equal(scans.positions, known.positions)
    assert scans.metrics["scan_hit_cells_fraction"] > 0
    assert scans.config["sense"]["map"] == "scans"


@pytest.mark.parametrize("setting, words", [
    ("sense.map=lidar", "map"), ("sense.scan_rays=3", "scan_rays"), ("sense.scan_range=-1", "scan_range"),
    ("sense.scan_rate=0", "scan_rate"), ("sense.scan_rays=720", "sense.map=known"),
    ("sense.scan_fill=-1", "scan_fill"), ("sense.scan_fill=1", "sense.map=known"),
])
def test_bad_scan_settings_are_one_line(setting, words):
    key, value = setting.split("=")
    with pytest.raises(ConfigError) as e:
        swarmnav.run("sph", "default_corridor", seed=1, steps=2, **{key: value})
    assert words in str(e.value) and "\n" not in str(e.value)


def test_a_method_that_cannot_map_from_scans_is_refused_in_one_line(tmp_path):
    r = run_cli("run", "--method", "mader", "--scenario", "default_corridor", "--steps", "2",
                "--out", str(tmp_path / "r"), "--set", "sense.map=scans")
    assert r.returncode == 2 and "Traceback" not in r.stderr and len(r.stderr.strip().splitlines()) == 1
    assert "mader cannot build its map from scans" in r.stderr
    assert all(m in r.stderr for m in ("ego-swarm", "lsc", "sph"))


def test_the_incremental_field_is_the_distance_transform_of_the_hit_cells():
    from scipy import ndimage

    from swarmnav.sensing import lidar_ring, ray_table

    obstacles = [Box((1.0, -2.0), (1.2, 2.0)), Circle((-2.0, 1.0), 0.7), Circle((0.5, -3.5), 0.4)]
    at = np.array([[0.0, 0.0], [-0.5, -1.5]])
    maps = _scan(obstacles, at)
    geom = Geometry.from_obstacles(obstacles, dim=2)
    u = np.column_stack(ray_table(360))
    for r in range(len(at)):  # oracle: the hit cells of the same rays, then scipy's exact transform
        ranges = lidar_ring(geom, at[r:r + 1], 360, 20.0)[0]
        pts = at[r] + ranges[ranges < 20.0, None] * u[ranges < 20.0]
        idx = np.rint((pts - maps.origin) / RES).astype(int)
        hits = np.zeros(maps.shape, dtype=bool)
        hits[idx[:, 1], idx[:, 0]] = True
        want = np.minimum(ndimage.distance_transform_edt(~hits, sampling=RES), maps.reach)
        assert np.allclose(maps.esdf(r).values, want, rtol=0, atol=1e-12)


def test_maps_from_scans_past_the_memory_limit_are_refused_in_one_line():
    with pytest.raises(ConfigError) as e:  # 15 robots on a Table II forest: ~10 MB of scan maps
        swarmnav.run("sph", "random_forest:density=0.35,seed=1,length=12,r_min=1.0,r_max=2.0,min_passage=1.0",
                     seed=1, steps=2, max_map_bytes=12_000_000, **{"sense.map": "scans"})
    assert "max_map_bytes" in str(e.value) and "sense.map=known" in str(e.value) and "\n" not in str(e.value)
    assert swarmnav.run("sph", "random_forest:density=0.35,seed=1,length=12,r_min=1.0,r_max=2.0,min_passage=1.0",
                        seed=1, steps=2, max_map_bytes=12_000_000).positions.shape[0] == 3


def test_filling_behind_the_returns_makes_a_seen_disc_solid_and_adds_nothing_outside_it():
    disc = Circle((0.0, 0.0), 1.0)
    robot = [[4.0, 0.0]]
    hollow = _scan([disc], robot)
    solid = _scan([disc], robot, **{"sense.scan_fill": 2.0})  # the disc's diameter
    pts = _centres(solid)
    dist = np.linalg.norm(pts - disc.center, axis=1) - disc.radius  # exact clearance of each centre [m]
    top = len(solid.levels) + 1
    inside = dist < -0.15
    # without filling the seen face is a shell and the inside beyond the inflation is free
    assert np.any(hollow.grids[0].ravel()[inside] == 0)
    # filled along the normals to the depth of the diameter: no cell of the disc is free, the unseen
    # back half included, and nearly all are within the inflation of a marked cell (the lines from the
    # seen arc, about 150 deg of it from 4 m, spread apart towards the back)
    inner = solid.grids[0].ravel()[inside]
    assert np.all(inner > 0) and np.mean(inner == top) > 0.98
    # nothing outside the disc is marked: each cell's field is at least its true clearance less half
    # a cell diagonal (a marked cell's centre lies within that of a point on or in the disc)
    field = solid.esdf(0).values.ravel()
    out = dist > 0
    assert np.all(field[out] >= np.minimum(dist[out], solid.reach) - 0.5 * np.sqrt(2.0) * RES - 1e-9)


def test_filling_behind_a_flat_face_goes_as_deep_as_asked_and_no_deeper():
    wall = Box((1.0, -3.0), (4.0, 3.0))  # 3 m thick, its face 1 m ahead of the robot
    maps = _scan([wall], [[0.0, 0.0]], **{"sense.scan_fill": 1.0})
    field = maps.esdf(0).values.ravel()
    pts = _centres(maps)
    row = np.abs(pts[:, 1]) < 0.5  # in front of the robot: the face seen head-on
    filled = row & (pts[:, 0] > 1.05) & (pts[:, 0] < 1.95)
    assert filled.sum() > 50 and np.all(field[filled] < 0.5 * np.sqrt(2.0) * RES + 1e-9)
    # 1 m of fill behind the face at x = 1 m: the field 0.5 m beyond x = 2 m is at least ~0.5 m
    deep = row & (pts[:, 0] > 2.45) & (pts[:, 0] < 2.55)
    assert np.all(field[deep] >= 0.5 - 0.5 * np.sqrt(2.0) * RES - 1e-9)
