"""Maps from files (MovingAI grids, scenarios and voxel maps, ROS map_server maps): what loads,
the axes and units, the exact merge into boxes, sensing on merged maps against a per-cell
oracle, and bad files (one-line ScenarioError)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from PIL import Image

from swarmnav.errors import ScenarioError
from swarmnav.sensing import Esdf, lidar_ring, points_inside, signed_distance
from swarmnav.world import load_scenario
from swarmnav.world.maps import load_grid, merge_cells, rasterize, read_movingai_scen
from swarmnav.world.obstacles import Box, Geometry

EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "maps"


def _grids(dims=(2,), side=10):
    shape = st.tuples(*[st.integers(1, side)] * 2) if dims == (2,) else st.tuples(*[st.integers(1, 5)] * 3)
    return shape.flatmap(lambda s: arrays(bool, s))


def _movingai(occ_top_down: np.ndarray, blocked: str = "@") -> str:
    h, w = occ_top_down.shape
    rows = ["".join(blocked if o else "." for o in r) for r in occ_top_down]
    return f"type octile\nheight {h}\nwidth {w}\nmap\n" + "\n".join(rows) + "\n"


def _cell_boxes(occ: np.ndarray, cell: float = 1.0) -> list[Box]:
    """The per-cell reference: one box per occupied cell (occ[iy, ix], y up)."""
    return [Box((ix * cell, iy * cell), ((ix + 1) * cell, (iy + 1) * cell)) for iy, ix in zip(*np.nonzero(occ))]


# --------------------------------------------------------------------------- the exact merge

@settings(max_examples=150, deadline=None)
@given(_grids((2,)))
def test_merge_covers_each_occupied_cell_once_and_no_free_cell_2d(occ):
    ranges = merge_cells(occ)
    assert (rasterize(ranges, occ.shape) == occ).all()
    assert (ranges[:, 2:] > ranges[:, :2]).all()


@settings(max_examples=100, deadline=None)
@given(_grids((3,)))
def test_merge_covers_each_occupied_voxel_once_and_no_free_voxel_3d(occ):
    ranges = merge_cells(occ)
    assert (rasterize(ranges, occ.shape) == occ).all()


def test_merge_joins_whole_rectangles():
    occ = np.zeros((6, 8), dtype=bool)
    occ[1:4, 2:7] = True  # one 5 x 3 block
    occ[5, :] = True  # one full row
    assert sorted(map(tuple, merge_cells(occ).tolist())) == [(0, 5, 8, 6), (2, 1, 7, 4)]
    assert merge_cells(np.ones((2, 3, 4), dtype=bool)).tolist() == [[0, 0, 0, 4, 3, 2]]
    assert merge_cells(np.zeros((3, 3), dtype=bool)).shape == (0, 4)


# --------------------------------------------------------------------------- sensing on merged maps

@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(_grids((2,), side=9), st.integers(0, 2**31 - 1))
def test_sensing_on_merged_map_matches_per_cell_oracle(tmp_path_factory, occ, seed):
    """LiDAR ring, signed distance and ESDF nodes of the merged boxes, read from the map file,
    against one box per cell and a brute-force signed distance of the occupied set: equal
    outside; inside, the depth reported (that of the deepest containing box) lies between a
    cell's and the union's."""
    f = tmp_path_factory.mktemp("m") / "g.map"
    f.write_text(_movingai(occ[::-1]))  # file rows run top-down
    grid = load_grid(f, cell=1.0)
    assert (grid.occupied == occ).all()
    merged = Geometry.from_obstacles(grid.boxes())
    cells = Geometry.from_obstacles(_cell_boxes(occ))
    h, w = occ.shape
    rng = np.random.default_rng(seed)
    pts = np.vstack([rng.uniform(-1.0, [w + 1.0, h + 1.0], (40, 2)),
                     rng.integers(-1, [w + 2, h + 2], (20, 2)).astype(float),  # grid corners
                     rng.integers(0, [w + 1, h + 1], (20, 2)) + [0.5, 0.0]])  # on grid lines
    if not occ.any():
        assert merged.is_empty
        return
    assert (points_inside(merged, pts) == points_inside(cells, pts)).all()
    centres = np.stack(np.meshgrid(np.arange(w) + 0.5, np.arange(h) + 0.5), -1).reshape(-1, 2)
    assert (points_inside(merged, centres) == occ.ravel()).all()
    ring_m, ring_c = lidar_ring(merged, pts, 72, 15.0), lidar_ring(cells, pts, 72, 15.0)
    np.testing.assert_allclose(ring_m, ring_c, rtol=0, atol=1e-12)  # the same edges, the same lines
    e_m = Esdf.build(merged, (-1.0, -1.0, w + 1.0, h + 1.0), 0.25)
    e_c = Esdf.build(cells, (-1.0, -1.0, w + 1.0, h + 1.0), 0.25)
    ny, nx = e_m.shape
    nodes = np.stack(np.meshgrid(-1.0 + 0.25 * np.arange(nx), -1.0 + 0.25 * np.arange(ny)), -1).reshape(-1, 2)
    for q, s_m, s_c in ((pts, signed_distance(merged, pts), signed_distance(cells, pts)),
                        (nodes, e_m.values.ravel(), e_c.values.ravel())):
        truth = _union_signed_distance(occ, q)
        out = truth > 0
        np.testing.assert_allclose(s_m[out], truth[out], rtol=0, atol=1e-12)
        np.testing.assert_allclose(s_c[out], truth[out], rtol=0, atol=1e-12)
        # in the union or on its boundary: the depth of the deepest containing box, which is at
        # least a cell's and at most the union's (0 on a face two boxes share)
        assert (truth[~out] - 1e-12 <= s_m[~out]).all() and (s_m[~out] <= s_c[~out] + 1e-12).all()
        assert (s_c[~out] <= 0).all()


def _union_signed_distance(occ: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """Brute force, cell by cell: the distance to the nearest occupied cell outside the union;
    inside or on it, minus the distance to the nearest free cell or the map's edge."""
    h, w = occ.shape

    def to_cells(mask):
        iy, ix = np.nonzero(mask)
        lo = np.stack([ix, iy], 1).astype(float)
        gap = np.maximum(np.maximum(lo[None] - pts[:, None], 0.0), pts[:, None] - (lo[None] + 1.0))
        return np.sqrt((gap**2).sum(-1)).min(axis=1) if len(lo) else np.full(len(pts), np.inf)

    d_occ = to_cells(occ)
    inside_map = (pts >= 0).all(1) & (pts <= [w, h]).all(1)
    edge = np.where(inside_map, np.minimum.reduce([pts[:, 0], pts[:, 1], w - pts[:, 0], h - pts[:, 1]]), 0.0)
    depth = np.minimum(to_cells(~occ), edge)
    return np.where(d_occ > 0, d_occ, -depth)


# --------------------------------------------------------------------------- MovingAI

def test_movingai_axes_units_and_terrain(tmp_path):
    f = tmp_path / "t.map"
    f.write_text("type octile\nheight 3\nwidth 4\nmap\n@.GT\n.S.O\nW...\n")
    g = load_grid(f, cell=2.0)
    # file row 0 is the top: '@' at column 0 of the top row is the world's upper-left cell
    assert g.bounds == (0.0, 0.0, 8.0, 6.0)
    expect_top_down = np.array([[1, 0, 0, 1], [0, 0, 0, 1], [1, 0, 0, 0]], dtype=bool)
    assert (g.occupied == expect_top_down[::-1]).all()
    inside = points_inside(Geometry.from_obstacles(g.boxes()), np.array([[1.0, 5.0], [7.0, 5.0], [1.0, 1.0], [3.0, 3.0]]))
    assert inside.tolist() == [True, True, True, False]


def test_scen_row_gives_spawn_and_goal():
    rows = read_movingai_scen(EXAMPLES / "warehouse.map.scen")
    scn = load_scenario(f"{EXAMPLES}/warehouse.map.scen#1")
    (sx, sy), (gx, gy) = rows[1].start, rows[1].goal
    # the centre of cell (x, y), y counted from the top of a 32-row map, at 1 m cells
    assert scn.goal == (gx + 0.5, 32 - gy - 0.5)
    x0, y0, x1, y1 = scn.swarm.spawn
    assert x0 < sx + 0.5 < x1 and y0 < 32 - sy - 0.5 < y1
    assert scn.bounds == (0.0, 0.0, 48.0, 32.0) and scn.boundary == "wall" and scn.n == 4
    big = load_scenario(f"{EXAMPLES}/warehouse.map.scen#row=1,cell=0.5,n=6")
    assert big.goal == ((gx + 0.5) * 0.5, (32 - gy - 0.5) * 0.5) and big.n == 6
    assert load_scenario(f"{EXAMPLES}/warehouse.map.scen#1", n=9).n == 9
    # the name rebuilds the scene
    again = load_scenario(f"{EXAMPLES}/{big.name}")
    assert again.goal == big.goal and again.swarm == big.swarm


@pytest.mark.parametrize("spec", ["warehouse.map.scen#3", "office.yaml#start=1:2,goal=24:14,n=5"])
def test_map_scene_round_trips_through_a_toml_scene(spec):
    from swarmnav.world import loads

    scn = load_scenario(f"{EXAMPLES}/{spec}")
    back = loads(scn.to_toml(), source="back.toml")
    assert back.obstacles == scn.obstacles and back.bounds == scn.bounds and back.boundary == scn.boundary
    assert back.goal == scn.goal and back.swarm == scn.swarm and back.contact == scn.contact
    assert back.rules.goal_radius == scn.rules.goal_radius


def test_toml_scene_takes_its_obstacles_from_a_map():
    scn = load_scenario(EXAMPLES / "warehouse_flight.toml")
    grid = load_grid(EXAMPLES / "warehouse.map")
    assert scn.obstacles == grid.boxes() and scn.bounds == grid.bounds and scn.rules.goal_radius == 3.0


# --------------------------------------------------------------------------- ROS map_server

def _ros(tmp_path, pixels, pil_mode=None, **meta):
    Image.fromarray(np.asarray(pixels, dtype=np.uint8), mode=pil_mode).save(tmp_path / "m.png")
    m = {"image": "m.png", "resolution": 0.5, "origin": [1.0, 2.0, 0.0], "negate": 0,
         "occupied_thresh": 0.65, "free_thresh": 0.196, **meta}
    text = "".join(f"{k}: {v}\n" for k, v in m.items())
    (tmp_path / "m.yaml").write_text(text)
    return tmp_path / "m.yaml"


def test_ros_map_origin_rows_and_thresholds(tmp_path):
    # grey 0 is occupied (p = 1), 254 free (p = 0.004), 205 unknown (p = 0.196: not < free_thresh)
    px = [[0, 254, 205], [254, 254, 0]]
    g = load_grid(_ros(tmp_path, px))
    assert g.bounds == (1.0, 2.0, 2.5, 3.0) and g.cell == 0.5
    # image row 0 is the top; origin is the lower-left pixel's corner; unknown is an obstacle
    assert g.occupied.tolist() == [[False, False, True], [True, False, True]]
    g_free = load_grid(_ros(tmp_path, px), unknown="free")
    assert g_free.occupied.tolist() == [[False, False, True], [True, False, False]]
    g_neg = load_grid(_ros(tmp_path, px, negate=1), unknown="free")  # white is occupied
    assert g_neg.occupied.tolist() == [[True, True, False], [False, True, True]]  # 205: p = 0.80
    inside = points_inside(Geometry.from_obstacles(g.boxes()), np.array([[1.25, 2.75], [1.25, 2.25], [2.25, 2.25]]))
    assert inside.tolist() == [True, False, True]


def test_ros_modes_scale_alpha_and_raw(tmp_path):
    rgba = np.zeros((1, 2, 4), dtype=np.uint8)
    rgba[..., :3] = 0  # black: occupied
    rgba[0, 1, 3] = 128  # translucent: unknown in scale mode
    rgba[0, 0, 3] = 255
    g = load_grid(_ros(tmp_path, rgba, "RGBA", mode="scale"), unknown="free")
    assert g.occupied.tolist() == [[True, False]]
    raw = load_grid(_ros(tmp_path, [[100, 0, 255, 50]], mode="raw"), unknown="free")  # percent; 255 unknown
    assert raw.occupied.tolist() == [[True, False, False, False]]
    raw_u = load_grid(_ros(tmp_path, [[100, 0, 255, 50]], mode="raw"))
    assert raw_u.occupied.tolist() == [[True, False, True, True]]


def test_ros_example_and_pgm():
    scn = load_scenario(f"{EXAMPLES}/office.yaml#start=1:2,goal=24:14")
    assert scn.bounds == (-2.0, -1.0, 28.0, 19.0)
    img = np.asarray(Image.open(EXAMPLES / "office.pgm"))
    occ = (255.0 - img) / 255.0
    expect = (occ > 0.65) | ~(occ < 0.196)
    assert (load_grid(EXAMPLES / "office.yaml").occupied == expect[::-1]).all()


# --------------------------------------------------------------------------- MovingAI voxel maps

def test_voxel_map_merges_exactly_and_flies_as_a_3d_scene(tmp_path):
    rng = np.random.default_rng(4)
    occ = rng.random((6, 7, 8)) < 0.2  # [z, y, x]
    occ[:, 0:2, 0:2] = False
    occ[:, 5:7, 6:8] = False
    z, y, x = np.nonzero(occ)
    f = tmp_path / "v.3dmap"
    f.write_text("voxel 8 7 6\n" + "".join(f"{a} {b} {c}\n" for a, b, c in zip(x, y, z)))
    g = load_grid(f, cell=2.0)
    assert (g.occupied == occ).all() and g.bounds == (0.0, 0.0, 0.0, 16.0, 14.0, 12.0)
    geom = Geometry.from_obstacles(g.boxes(), dim=3)
    centres = (np.argwhere(np.ones_like(occ))[:, ::-1] + 0.5) * 2.0
    assert (points_inside(geom, centres) == occ.ravel()).all()
    scn = load_scenario(f"{f}#start=2:2:6,goal=14:13:6,cell=2,n=2,spread=1.5")
    assert scn.dim == 3 and scn.goal == (14.0, 13.0, 6.0)


# --------------------------------------------------------------------------- bad files

@pytest.mark.parametrize("text, fragment", [
    ("type octile\nheight 3\nwidth 2\nmap\n..\n..\n", "height 3 but 2 map rows"),
    ("type octile\nheight 2\nwidth 3\nmap\n...\n..\n", "row 1 has 2 characters"),
    ("type octile\nheight 2\nwidth 2\nmap\n.x\n..\n", "unknown terrain 'x'"),
    ("type octile\nheight 2\nwidth 2\n", "no 'map' line"),
    ("type octile\nwidth 2\nmap\n..\n", "no 'height' line"),
    ("type octile\nheight two\nwidth 2\nmap\n..\n..\n", "height must be an integer"),
    ("", "no 'type' line"),
    ("type hex\nheight 1\nwidth 1\nmap\n.\n", "not a square grid"),
    ("type octile\nheight 1\nwidth 2\nmap\n.\u00e9\n", "unknown terrain '\u00e9'"),
])
def test_bad_movingai_map_is_one_line(tmp_path, text, fragment):
    (tmp_path / "b.map").write_text(text)
    with pytest.raises(ScenarioError) as e:
        load_scenario(f"{tmp_path}/b.map#start=0.5:0.5,goal=1.5:0.5")
    assert fragment in str(e.value) and "\n" not in str(e.value)


@pytest.mark.parametrize("spec, fragment", [
    ("warehouse.map.scen#9", "row 9 does not exist"),
    ("warehouse.map.scen#row=1,start=1:1", "start is for a map without a .scen"),
    ("warehouse.map.scen#colour=red", "unknown map option"),
    ("warehouse.map.scen#cell=-1", "cell must be > 0"),
    ("warehouse.map", "a map gives obstacles only"),
    ("warehouse.map#start=3:3,goal=100:3", "goal [100.0, 3.0] lies outside the map"),
    ("warehouse.map#start=3:3,goal=0.5:0.5", "goal.position [0.5, 0.5] lies inside an obstacle"),
    ("office.yaml#start=1:2,goal=24:14,cell=2", "a ROS map has its own resolution"),
    ("warehouse.map#start=3:3,goal=40:20,unknown=free", "unknown is for ROS maps"),
])
def test_bad_map_options_are_one_line(spec, fragment):
    with pytest.raises(ScenarioError) as e:
        load_scenario(f"{EXAMPLES}/{spec}")
    assert fragment in str(e.value) and "\n" not in str(e.value)


def test_scen_start_in_an_obstacle_or_outside_the_map(tmp_path):
    (tmp_path / "a.map").write_text("type octile\nheight 2\nwidth 3\nmap\n@..\n...\n")
    (tmp_path / "a.map.scen").write_text("version 1\n0\ta.map\t3\t2\t0\t0\t2\t1\t2.4\n"
                                         "0\ta.map\t3\t2\t1\t1\t5\t1\t4\n0\ta.map\t4\t2\t1\t1\t2\t1\t1\n")
    for row, fragment in ((0, "start cell (0, 0) is an obstacle"), (1, "goal cell (5, 1) lies outside"),
                          (2, "is for a 4 x 2 map")):
        with pytest.raises(ScenarioError) as e:
            load_scenario(f"{tmp_path}/a.map.scen#{row}")
        assert fragment in str(e.value)


@pytest.mark.parametrize("yaml_text, fragment", [
    ("image: nope.pgm\nresolution: 0.1\norigin: [0, 0, 0]\noccupied_thresh: 0.65\nfree_thresh: 0.2\n",
     "does not exist"),
    ("image: m.png\nresolution: 0.1\norigin: [0, 0, 0]\noccupied_thresh: 1.65\nfree_thresh: 0.2\n",
     "0 <= free_thresh < occupied_thresh <= 1"),
    ("image: m.png\nresolution: 0.1\norigin: [0, 0, 0]\noccupied_thresh: 0.5\nfree_thresh: 0.6\n",
     "free_thresh < occupied_thresh"),
    ("image: m.png\nresolution: -1\norigin: [0, 0, 0]\noccupied_thresh: 0.65\nfree_thresh: 0.2\n",
     "resolution must be > 0"),
    ("image: m.png\nresolution: 0.1\norigin: [0, 0]\noccupied_thresh: 0.65\nfree_thresh: 0.2\n",
     "origin must be [x, y, yaw]"),
    ("image: m.png\nresolution: 0.1\norigin: [0, 0, 0.5]\noccupied_thresh: 0.65\nfree_thresh: 0.2\n",
     "only yaw = 0"),
    ("image: m.png\nresolution: 0.1\norigin: [0, 0, 0]\nfree_thresh: 0.2\n", "'occupied_thresh' is required"),
    ("image: m.png\nresolution: .nan\norigin: [0, 0, 0]\noccupied_thresh: 0.65\nfree_thresh: 0.2\n",
     "resolution must be a finite number"),
    ("image: m.png\nresolution: 0.1\norigin: [0, 0, 0]\noccupied_thresh: 0.65\nfree_thresh: 0.2\nmode: fuzzy\n",
     "mode must be one of"),
    ("image: m.png\nresolution: 0.1\norigin: [0, 0, 0]\noccupied_thresh: 0.65\nfree_thresh: 0.2\nnegate: 2\n",
     "negate must be 0 or 1"),
    ("image: m.png\n  resolution: [", "malformed YAML"),
    ("image: notes.txt\nresolution: 0.1\norigin: [0, 0, 0]\noccupied_thresh: 0.65\nfree_thresh: 0.2\n",
     "cannot be read"),
])
def test_bad_ros_map_is_one_line(tmp_path, yaml_text, fragment):
    Image.fromarray(np.full((4, 4), 254, dtype=np.uint8)).save(tmp_path / "m.png")
    (tmp_path / "notes.txt").write_text("not an image")
    (tmp_path / "m.yaml").write_text(yaml_text)
    with pytest.raises(ScenarioError) as e:
        load_scenario(f"{tmp_path}/m.yaml#start=0.1:0.1,goal=0.3:0.3,n=1")
    assert fragment in str(e.value) and "\n" not in str(e.value)


@pytest.mark.parametrize("text, fragment", [
    ("voxel 4 4 2\n0 0 0 1\n1 1\n", "line 2: a voxel is three integers"),
    ("voxel 4 4 2\n0 0 x\n", "line 2: a voxel is three integers"),
    ("voxel 4 4 2\n0 0 0\n4 0 0\n", "line 3: voxel [4, 0, 0] lies outside"),
    ("voxel 4 4\n", "starts with 'voxel W H D'"),
])
def test_bad_voxel_map_is_one_line(tmp_path, text, fragment):
    (tmp_path / "b.3dmap").write_text(text)
    with pytest.raises(ScenarioError) as e:
        load_scenario(f"{tmp_path}/b.3dmap#start=0.5:3.5:0.5,goal=3.5:3.5:1.5,n=1,spread=0.4")
    assert fragment in str(e.value) and "\n" not in str(e.value)


def test_bad_map_table_in_a_scene(tmp_path):
    base = '[swarm]\nn = 2\nspawn = [1, 1, 5, 5]\n[goal]\nposition = [40, 20]\n'
    for table, fragment in (('[map]\nfile = "nope.map"\n', "no such map file"),
                            ('[map]\nfile = "w.map"\ncell = 0\n', "map.cell must be > 0"),
                            ('[map]\nfile = "w.map"\nres = 1\n', "unknown key 'map.res'"),
                            ('[map]\nfile = "w.txt"\n', "map.file must be a .map"),
                            ('[map]\ncell = 1\n', "map.file is required")):
        (tmp_path / "w.map").write_text((EXAMPLES / "warehouse.map").read_text())
        (tmp_path / "s.toml").write_text(table + base)
        with pytest.raises(ScenarioError) as e:
            load_scenario(tmp_path / "s.toml")
        assert fragment in str(e.value)


def _mutations():
    return st.lists(st.tuples(st.sampled_from(["delete", "insert", "truncate", "dup_line", "swap"]),
                              st.floats(0, 1), st.floats(0, 1), st.text(max_size=4)), min_size=1, max_size=3)


def _mutate(text: str, ops) -> str:
    for op, a, b, ins in ops:
        i, j = sorted((int(a * len(text)), int(b * len(text))))
        if op == "delete":
            text = text[:i] + text[j:]
        elif op == "insert":
            text = text[:i] + ins + text[i:]
        elif op == "truncate":
            text = text[:i]
        elif op == "dup_line":
            lines = text.splitlines(keepends=True)
            if lines:
                k = int(a * (len(lines) - 1))
                lines.insert(k, lines[k])
            text = "".join(lines)
        else:
            text = text[:i] + text[j:j + (j - i)] + text[i:j] + text[j + (j - i):]
    return text


def _loads_or_one_line(spec: str) -> None:
    try:
        scn = load_scenario(spec)
    except ScenarioError as e:
        assert "\n" not in str(e) and str(e)
    else:
        assert np.isfinite(scn.goal).all()


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(ops=_mutations(), which=st.sampled_from(["map", "scen", "yaml", "3dmap"]))
def test_mutated_map_files_load_or_fail_in_one_line(tmp_path, ops, which):
    d = tmp_path / "mut"
    d.mkdir(exist_ok=True)
    files = {"map": (EXAMPLES / "warehouse.map").read_text(), "scen": (EXAMPLES / "warehouse.map.scen").read_text(),
             "yaml": (EXAMPLES / "office.yaml").read_text(), "3dmap": "voxel 4 4 3\n0 0 0\n1 0 0\n3 3 2\n2 1 1\n"}
    files[which] = _mutate(files[which], ops)
    for name, key in (("warehouse.map", "map"), ("warehouse.map.scen", "scen"), ("office.yaml", "yaml"),
                      ("v.3dmap", "3dmap")):
        (d / name).write_bytes(files[key].encode("utf-8", "surrogatepass"))  # lone surrogates: invalid UTF-8
    (d / "office.pgm").write_bytes((EXAMPLES / "office.pgm").read_bytes())
    spec = {"map": "warehouse.map#start=3:3,goal=40:20", "scen": "warehouse.map.scen#2",
            "yaml": "office.yaml#start=1:2,goal=24:14", "3dmap": "v.3dmap#start=0.5:3.5:0.5,goal=3.5:0.5:2.5,n=1,spread=0.5"}
    _loads_or_one_line(f"{d}/{spec[which]}")


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(cut=st.floats(0, 1), flip=st.integers(0, 10**6), byte=st.integers(0, 255))
def test_damaged_ros_image_loads_or_fails_in_one_line(tmp_path, cut, flip, byte):
    d = tmp_path / "img"
    d.mkdir(exist_ok=True)
    data = bytearray((EXAMPLES / "office.pgm").read_bytes())
    data[flip % len(data)] = byte
    (d / "office.pgm").write_bytes(bytes(data[: max(1, int(cut * len(data)))]) if cut < 0.9 else bytes(data))
    (d / "office.yaml").write_text((EXAMPLES / "office.yaml").read_text())
    _loads_or_one_line(f"{d}/office.yaml#start=1:2,goal=24:14")


def test_cli_runs_and_shows_a_map_scene(tmp_path, capsys):
    import tomllib

    from swarmnav.cli import main

    assert main(["run", "--method", "apf", "--scenario-file", f"{EXAMPLES}/warehouse.map.scen#2", "--steps", "20",
                 "--out", str(tmp_path / "r"), "--quiet"]) == 0
    assert "apf on warehouse.map.scen#row=2,n=4" in capsys.readouterr().out
    assert main(["scenarios", "show", f"{EXAMPLES}/warehouse.map.scen#2"]) == 0
    assert tomllib.loads(capsys.readouterr().out)["goal"]["position"] == [44.5, 14.5]


def test_cli_map_scene_error_is_one_line_exit_2(tmp_path):
    import os

    import swarmnav

    src = str(Path(swarmnav.__file__).resolve().parents[1])
    env = {**os.environ, "PYTHONPATH": src + os.pathsep + os.environ.get("PYTHONPATH", "")}
    p = subprocess.run([sys.executable, "-m", "swarmnav.cli", "run", "--method", "apf", "--scenario-file",
                        f"{EXAMPLES}/warehouse.map.scen#17", "--out", str(tmp_path / "o")],
                       capture_output=True, text=True, env=env)
    lines = [ln for ln in p.stderr.splitlines() if ln.strip()]
    assert p.returncode == 2 and len(lines) == 1 and "row 17 does not exist" in lines[0], p.stderr
