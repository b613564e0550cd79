"""The grid index of large 3-D worlds (swarmnav.sensing.index3d) gives the plain kernels' signed
distances, directions, inside tests, line of sight, range scans and ESDF bit for bit."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import swarmnav.sensing.index3d as index3d
from swarmnav.sensing import (
    Esdf,
    PreparedGeometry,
    fibonacci_sphere,
    nearest_obstacle,
    points_inside,
    range_scan,
    segments_blocked,
    signed_distance,
)
from swarmnav.world.obstacles import Box, Cylinder, Geometry, Sphere


def _world(seed: int, n_boxes: int, voxels: bool) -> Geometry:
    rng = np.random.default_rng(seed)
    obs: list = []
    if voxels:  # touching 0.5 m voxels, as a merged voxel map gives
        cells = np.argwhere(rng.random((6, 16, 16)) < 0.2)
        obs += [Box((x * 0.5, y * 0.5, z * 0.5), (x * 0.5 + 0.5, y * 0.5 + 0.5, z * 0.5 + 0.5)) for z, y, x in cells]
    lo = rng.uniform((-10.0, -10.0, 0.0), (10.0, 10.0, 4.0), (n_boxes, 3))
    obs += [Box(tuple(a), tuple(a + rng.uniform(0.05, 2.0, 3))) for a in lo]  # overlapping boxes too
    obs += [Cylinder(tuple(rng.uniform(-10, 10, 2)), float(rng.uniform(0.2, 1.0)),
                     tuple(sorted(rng.uniform(0.0, 5.0, 2)))) for _ in range(4)]
    obs += [Sphere(tuple(rng.uniform((-10, -10, 0), (10, 10, 5))), float(rng.uniform(0.2, 1.5))) for _ in range(4)]
    return Geometry.from_obstacles(obs, dim=3)


def _points(seed: int, geom: Geometry) -> np.ndarray:
    rng = np.random.default_rng(seed + 1)
    lo, hi = geom.bbox_lo, geom.bbox_hi
    k = rng.integers(0, len(lo), 60)
    t = rng.random((60, 3))
    face = lo[k] + t * (hi[k] - lo[k])
    axis = rng.integers(0, 3, 60)
    side = np.where(rng.random(60) < 0.5, lo[k, axis], hi[k, axis])
    face[np.arange(60), axis] = side  # on a face of the box (a cylinder's or sphere's box: near it)
    return np.vstack([rng.uniform((-14.0, -14.0, -2.0), (14.0, 14.0, 7.0), (150, 3)),  # free and inside
                      rng.uniform((-60.0, -60.0, -30.0), (60.0, 60.0, 30.0), (30, 3)),  # far outside the grid
                      lo[k] + t * (hi[k] - lo[k]),  # inside boxes
                      face,  # on box faces (and some just off)
                      lo[rng.integers(0, len(lo), 30)],  # box corners
                      rng.integers(-2, 10, (30, 3)) * 0.5])  # voxel corners


def _queries(geom, pts, ends, dirs):
    d, v = nearest_obstacle(geom, pts)
    prep = PreparedGeometry(geom)
    return (signed_distance(geom, pts), d, v, points_inside(geom, pts), segments_blocked(geom, pts, ends),
            range_scan(geom, pts[::4], dirs, 8.0), prep.range_into(pts[::4].copy(), dirs, 8.0,
                                                                 np.empty((len(pts[::4]), len(dirs)))),
            prep.distance_into(pts, np.empty(len(pts))), prep.blocked_into(pts, ends, np.empty(len(pts), bool)))


@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), n_boxes=st.integers(0, 400), voxels=st.booleans())
def test_indexed_queries_equal_the_plain_kernels(seed, n_boxes, voxels):
    geom = _world(seed, n_boxes, voxels)
    pts = _points(seed, geom)
    rng = np.random.default_rng(seed + 2)
    ends = np.vstack([pts[:-40] + rng.normal(0.0, 3.0, (len(pts) - 40, 3)),  # line of sight blocked or not
                      pts[-40:] + rng.integers(-2, 3, (40, 3)) * 0.5])  # along voxel faces
    dirs = np.vstack([fibonacci_sphere(60), np.eye(3), -np.eye(3)])  # and the axes, along faces
    indexed = index3d.box_index(geom) is not None
    got = _queries(geom, pts, ends, dirs)
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(index3d, "INDEX3D_MIN_PRIMITIVES", 10**9)
        index3d._cache.clear()
        assert index3d.box_index(geom) is None
        want = _queries(geom, pts, ends, dirs)
    index3d._cache.clear()
    assert indexed == (geom.n_polygons + geom.n_circles + geom.n_spheres >= 256)
    for g, w in zip(got, want):
        np.testing.assert_array_equal(g, w)


def test_the_indexed_esdf_equals_the_plain_build():
    geom = _world(3, 400, True)
    assert index3d.box_index(geom) is not None
    bounds = (-12.0, -12.0, -1.0, 12.0, 12.0, 6.0)
    got = Esdf.build(geom, bounds, 0.25).values
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(index3d, "INDEX3D_MIN_PRIMITIVES", 10**9)
        index3d._cache.clear()
        want = Esdf.build(geom, bounds, 0.25).values
    index3d._cache.clear()
    np.testing.assert_array_equal(got, want)
    assert (got < 0).any() and (got > 1.0).any()  # inside and well clear of the boxes both sampled


def test_a_ray_stops_at_the_first_voxel_face():
    """Known answers on a row of touching voxels: the range along +x from x = 0.25 to the first
    voxel at x = 2 is 1.75 m, down onto the row from 0.5 m above it 0.5 m; a point on a voxel face
    is in collision (range 0)."""
    voxels = [Box((2.0 + 0.5 * i, 0.0, 0.0), (2.5 + 0.5 * i, 0.5, 0.5)) for i in range(300)]
    geom = Geometry.from_obstacles(voxels, dim=3)
    assert index3d.box_index(geom) is not None
    at = np.array([[0.25, 0.25, 0.25], [2.0, 0.25, 0.25], [2.25, 0.25, 1.0]])
    r = range_scan(geom, at, np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0]]), 20.0)
    np.testing.assert_array_equal(r, [[1.75, 20.0], [0.0, 0.0], [20.0, 0.5]])
    np.testing.assert_array_equal(points_inside(geom, at), [False, True, False])
