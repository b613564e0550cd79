"""Point clouds (.ply, .pcd) as 3-D occupancy: the voxel rule, the exact merge, both formats and
their encodings alike, and damaged files (NaN points, truncation, a header that disagrees with
the data, random byte damage) as one-line ScenarioErrors."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from plyfile import PlyData, PlyElement
from pypcd4 import Encoding, PointCloud

from swarmnav.errors import ScenarioError
from swarmnav.sensing import points_inside
from swarmnav.world import load_scenario
from swarmnav.world.maps import load_grid
from swarmnav.world.obstacles import Geometry

EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "maps"


def _write_ply(path: Path, pts: np.ndarray, text: bool = False) -> Path:
    v = np.empty(len(pts), dtype=[("x", "f8"), ("y", "f8"), ("z", "f8")])
    v["x"], v["y"], v["z"] = np.asarray(pts, dtype=float).T
    PlyData([PlyElement.describe(v, "vertex")], text=text).write(str(path))
    return path


def _write_pcd(path: Path, pts: np.ndarray, encoding=Encoding.BINARY) -> Path:
    PointCloud.from_xyz_points(np.asarray(pts, dtype=np.float32)).save(path, encoding=encoding)
    return path


def _cloud_of(occ: np.ndarray, cell: float, origin: np.ndarray, rng) -> np.ndarray:
    """One to three points anywhere inside each occupied voxel of ``occ`` ([z, y, x])."""
    idx = np.repeat(np.argwhere(occ)[:, ::-1], rng.integers(1, 4, int(occ.sum())), axis=0)
    return origin + (idx + rng.uniform(0.02, 0.98, idx.shape)) * cell


WRITERS = {
    "ply-binary": lambda p, x: _write_ply(p / "c.ply", x),
    "ply-ascii": lambda p, x: _write_ply(p / "c.ply", x, text=True),
    "pcd-ascii": lambda p, x: _write_pcd(p / "c.pcd", x, Encoding.ASCII),
    "pcd-binary": lambda p, x: _write_pcd(p / "c.pcd", x, Encoding.BINARY),
    "pcd-compressed": lambda p, x: _write_pcd(p / "c.pcd", x, Encoding.BINARY_COMPRESSED),
}


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(occ=st.tuples(*[st.integers(1, 6)] * 3).flatmap(lambda s: arrays(bool, s)),
       fmt=st.sampled_from(sorted(WRITERS)), seed=st.integers(0, 2**16))
def test_cloud_voxels_are_the_voxels_holding_a_point_and_merge_exactly(tmp_path, occ, fmt, seed):
    if not occ.any():
        occ = occ.copy()
        occ[0, 0, 0] = True
    rng = np.random.default_rng(seed)
    cell = 0.5
    shift = rng.integers(-4, 4, 3)  # the cloud's lowest voxel, in cells from the origin
    pts = _cloud_of(occ, cell, shift * cell, rng)
    g = load_grid(WRITERS[fmt](tmp_path, pts), cell=cell)
    # the grid spans the lowest to the highest occupied voxel, on the lattice of multiples of cell
    z, y, x = np.nonzero(occ)
    lo = np.array([x.min(), y.min(), z.min()])
    hi = np.array([x.max(), y.max(), z.max()]) + 1
    assert np.allclose(g.origin, (shift + lo) * cell)
    assert np.array_equal(g.occupied, occ[lo[2]:hi[2], lo[1]:hi[1], lo[0]:hi[0]])
    centres = np.asarray(g.origin) + (np.argwhere(np.ones_like(g.occupied))[:, ::-1] + 0.5) * cell
    inside = points_inside(Geometry.from_obstacles(g.boxes(), dim=3), centres)
    assert np.array_equal(inside, g.occupied.ravel())


def test_ply_and_pcd_examples_are_one_hall():
    a, b = load_grid(EXAMPLES / "hall.ply"), load_grid(EXAMPLES / "hall.pcd")
    assert np.array_equal(a.occupied, b.occupied) and a.origin == b.origin
    assert a.cell == 0.1 and a.bounds == pytest.approx((0.0, 0.0, 0.0, 8.0, 6.0, 2.5))
    coarse = load_grid(EXAMPLES / "hall.ply", cell=0.5)
    assert coarse.occupied.shape == (5, 12, 16)
    scn = load_scenario(f"{EXAMPLES}/hall.pcd#start=1:3:1.2,goal=7:3:1.2,cell=0.2")
    assert scn.dim == 3 and scn.bounds == pytest.approx((0.0, 0.0, 0.0, 8.0, 6.0, 2.6))


def test_a_point_on_a_voxel_face_lies_in_the_upper_voxel(tmp_path):
    g = load_grid(_write_ply(tmp_path / "f.ply", [[0.0, 0.0, 0.0], [1.0, -0.5, 0.25]]), cell=0.5)
    assert g.origin == (0.0, -0.5, 0.0) and g.occupied.shape == (1, 2, 3)
    assert g.occupied[0, 1, 0] and g.occupied[0, 0, 2] and g.occupied.sum() == 2


def test_toml_scene_takes_its_obstacles_from_a_cloud(tmp_path):
    (tmp_path / "hall.ply").write_bytes((EXAMPLES / "hall.ply").read_bytes())
    (tmp_path / "s.toml").write_text('[map]\nfile = "hall.ply"\ncell = 0.2\n[swarm]\nn = 3\n'
                                     'spawn = [0.5, 2, 1, 1.5, 4, 1.5]\n[goal]\nposition = [7, 3, 1.2]\n')
    scn = load_scenario(tmp_path / "s.toml")
    assert scn.obstacles == load_grid(EXAMPLES / "hall.ply", cell=0.2).boxes()


# --------------------------------------------------------------------------- bad clouds

def _one_line(spec) -> str:
    with pytest.raises(ScenarioError) as e:
        load_scenario(spec)
    msg = str(e.value)
    assert msg and "\n" not in msg
    return msg


def test_nan_points_truncation_and_bad_headers_are_one_line(tmp_path):
    pts = np.array([[0.1, 0.1, 0.1], [1.0, 2.0, 1.0], [2.0, 1.0, 0.5]])
    opts = "#start=0.5:1.5:0.5,goal=1.5:0.5:0.5,n=1,spread=0.2"
    nan = pts.copy()
    nan[1, 2] = np.nan
    for w in ("ply-binary", "pcd-binary"):
        d = tmp_path / w
        d.mkdir()
        f = WRITERS[w](d, nan)
        assert "point 1 is not finite" in _one_line(f"{f}{opts}")
    f = _write_ply(tmp_path / "t.ply", pts)
    f.write_bytes(f.read_bytes()[:-10])
    assert "not a readable PLY file" in _one_line(f"{f}{opts}")
    f = _write_pcd(tmp_path / "t.pcd", pts)
    f.write_bytes(f.read_bytes()[:-12])  # one point short: the header says 3
    assert "the header says POINTS 3 but the data holds 2" in _one_line(f"{f}{opts}")
    text = _write_pcd(tmp_path / "a.pcd", pts, Encoding.ASCII).read_text()
    (tmp_path / "a.pcd").write_text(text.replace("WIDTH 3", "WIDTH 4"))
    assert "POINTS 3 but WIDTH x HEIGHT = 4 x 1" in _one_line(f"{tmp_path / 'a.pcd'}{opts}")
    (tmp_path / "n.pcd").write_text(text.replace("FIELDS x y z", "FIELDS x y w"))
    assert "no z field" in _one_line(f"{tmp_path / 'n.pcd'}{opts}")
    (tmp_path / "e.ply").write_text("ply\nformat ascii 1.0\nelement face 0\nproperty list uchar int v\nend_header\n")
    assert "no 'vertex' element" in _one_line(f"{tmp_path / 'e.ply'}{opts}")
    assert "no such point cloud file" in _one_line(f"{tmp_path / 'missing.pcd'}{opts}")
    f = _write_ply(tmp_path / "far.ply", [[0, 0, 0], [1e6, 1e6, 10.0]])
    assert "more than" in _one_line(f"{f}{opts}")
    assert "map option cell must be > 0" in _one_line(f"{EXAMPLES}/hall.pcd#start=0:0:0,goal=1:1:1,cell=-1")
    assert "voxels of 1e-07 m is more than" in _one_line(f"{EXAMPLES}/hall.pcd#start=0:0:0,goal=1:1:1,cell=1e-7")
    assert "unknown is for ROS maps" in _one_line(f"{EXAMPLES}/hall.ply#start=1:3:1.2,goal=7:3:1.2,unknown=free")


def test_start_inside_a_cloud_obstacle_is_one_line():
    # the wall across x = 4 m (voxels 4.0-4.1 m) outside the doorway
    msg = _one_line(f"{EXAMPLES}/hall.ply#start=1:3:1.2,goal=4.05:1:1.2")
    assert "goal" in msg


def _damage(data: bytes, ops) -> bytes:
    for op, a, b, byte in ops:
        i, j = sorted((int(a * len(data)), int(b * len(data))))
        if op == "truncate":
            data = data[:i]
        elif op == "delete":
            data = data[:i] + data[j:]
        elif op == "insert":
            data = data[:i] + bytes([byte]) * (1 + j - i) + data[i:]
        else:  # flip one byte
            if data:
                k = min(i, len(data) - 1)
                data = data[:k] + bytes([byte]) + data[k + 1:]
    return data


@settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(ops=st.lists(st.tuples(st.sampled_from(["truncate", "delete", "insert", "flip", "flip", "flip"]),
                              st.floats(0, 1), st.floats(0, 1), st.integers(0, 255)), min_size=1, max_size=3),
       which=st.sampled_from(["hall.ply", "hall.pcd", "ascii.ply", "ascii.pcd"]))
def test_damaged_clouds_load_or_fail_in_one_line(tmp_path, ops, which):
    d = tmp_path / "mut"
    d.mkdir(exist_ok=True)
    if which.startswith("ascii"):
        pts = np.array([[0.05, 0.05, 0.05], [1.95, 1.95, 1.95], [1.05, 0.25, 0.65], [0.35, 1.45, 1.05]])
        src = (_write_ply(d / "s.ply", pts, text=True) if which.endswith("ply") else
               _write_pcd(d / "s.pcd", pts, Encoding.ASCII)).read_bytes()
        opts = "#start=0.5:0.5:1.5,goal=1.5:1.5:0.5,n=1,spread=0.2,cell=0.5"
    else:
        src = (EXAMPLES / which).read_bytes()
        opts = "#start=1:3:1.2,goal=7:3:1.2,cell=0.2"
    f = d / ("m" + Path(which).suffix)
    f.write_bytes(_damage(src, ops))
    try:
        scn = load_scenario(f"{f}{opts}")
    except ScenarioError as e:
        assert str(e) and "\n" not in str(e)
    else:
        assert scn.dim == 3 and np.isfinite(scn.bounds).all()
