"""The grid index of large planar worlds (swarmnav.sensing.index) gives the plain scan's LiDAR
ranges, signed distances, inside tests and line of sight bit for bit."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import swarmnav.sensing.index as index
from swarmnav.sensing import (
    Esdf,
    PreparedGeometry,
    lidar_ring,
    nearest_obstacle,
    points_inside,
    segments_blocked,
    signed_distance,
)
from swarmnav.sensing.lidar import ray_table
from swarmnav.world.obstacles import Box, Circle, Geometry, Polygon


def _world(seed: int, n_boxes: int, grid: bool) -> Geometry:
    rng = np.random.default_rng(seed)
    obs = []
    if grid:  # touching unit cells, as a merged map gives
        cells = np.argwhere(rng.random((40, 40)) < 0.3)
        obs += [Box((float(x), float(y)), (x + 1.0, y + 1.0)) for y, x in cells]
    lo = rng.uniform(-30.0, 30.0, (n_boxes, 2))
    obs += [Box(tuple(a), tuple(a + rng.uniform(0.1, 4.0, 2))) for a in lo]  # overlapping boxes too
    obs += [Polygon(((0.0 + k, -40.0), (3.0 + k, -40.0), (1.5 + k, -37.0))) for k in range(0, 30, 5)]
    obs += [Circle(tuple(rng.uniform(-30, 30, 2)), float(rng.uniform(0.2, 2.0))) for _ in range(5)]
    return Geometry.from_obstacles(obs)


def _points(seed: int, geom: Geometry) -> np.ndarray:
    rng = np.random.default_rng(seed + 1)
    return np.vstack([rng.uniform(-60.0, 60.0, (150, 2)),  # inside and far outside the grid
                      rng.integers(-5, 45, (60, 2)).astype(float),  # cell corners of the map
                      geom.seg_a[rng.integers(0, len(geom.seg_a), 40)]])  # polygon vertices


@settings(max_examples=12, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), n_boxes=st.integers(0, 300), grid=st.booleans())
def test_indexed_queries_equal_the_plain_scan(seed, n_boxes, grid):
    geom = _world(seed, n_boxes, grid)
    pts = _points(seed, geom)
    indexed = index.polygon_index(geom) is not None
    ends = pts + np.random.default_rng(seed).normal(0.0, 3.0, pts.shape)  # line of sight blocked or not
    got = (lidar_ring(geom, pts, 90, 12.0), signed_distance(geom, pts), points_inside(geom, pts),
           nearest_obstacle(geom, pts)[0], segments_blocked(geom, pts, ends))
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(index, "INDEX_MIN_POLYGONS", 10**9)
        assert index.polygon_index(geom) is None
        want = (lidar_ring(geom, pts, 90, 12.0), signed_distance(geom, pts), points_inside(geom, pts),
                nearest_obstacle(geom, pts)[0], segments_blocked(geom, pts, ends))
    assert indexed == (geom.n_polygons >= 256)
    for g, w in zip(got, want):
        np.testing.assert_array_equal(g, w)


def test_prepared_geometry_and_esdf_use_the_index_with_the_same_results():
    geom = _world(5, 300, True)
    assert index.polygon_index(geom) is not None
    pts = _points(5, geom)
    prep = PreparedGeometry(geom)
    c, s = ray_table(72)
    ring = prep.lidar_into(pts, c, s, 15.0, np.empty((len(pts), 72)))
    dist = prep.distance_into(pts, np.empty(len(pts)))
    ends = pts[::-1] + 0.5
    sight = prep.blocked_into(pts, ends, np.empty(len(pts), dtype=bool))
    esdf = Esdf.build(geom, (-45.0, -45.0, 45.0, 45.0), 0.5)
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(index, "INDEX_MIN_POLYGONS", 10**9)
        np.testing.assert_array_equal(ring, lidar_ring(geom, pts, 72, 15.0))
        np.testing.assert_array_equal(dist, signed_distance(geom, pts))
        np.testing.assert_array_equal(sight, segments_blocked(geom, pts, ends))
        np.testing.assert_array_equal(esdf.values, Esdf.build(geom, (-45.0, -45.0, 45.0, 45.0), 0.5).values)


@pytest.mark.parametrize("seed", [0, 1])
def test_lidar_on_scattered_cells_equals_the_plain_scan(seed):
    """A map of scattered single cells (as MovingAI's random maps): most rays stop within a few
    cells and a few escape through gaps to the range, so the ring walks its nearest cells and
    then the cells along the escaping rays only; the ranges equal the plain scan's bit for bit."""
    rng = np.random.default_rng(seed)
    cells = np.argwhere(rng.random((90, 90)) < 0.25)
    geom = Geometry.from_obstacles([Box((float(x), float(y)), (x + 1.0, y + 1.0)) for y, x in cells])
    occupied = {(int(x), int(y)) for y, x in cells}
    free = [(x + 0.5, y + 0.5) for x, y in rng.integers(0, 90, (400, 2)).tolist() if (x, y) not in occupied]
    pts = np.array(free[:120] + [(-3.0, 45.0), (95.0, -2.0)])  # and two outside the map
    assert index.polygon_index(geom) is not None
    got = lidar_ring(geom, pts, 360, 20.0)
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(index, "INDEX_MIN_POLYGONS", 10**9)
        want = lidar_ring(geom, pts, 360, 20.0)
    assert np.array_equal(got, want)
    assert (got > 5.0).mean() > 0.01 and (got < 3.0).mean() > 0.5  # a few long rays among many short
