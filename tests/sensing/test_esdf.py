"""ESDF grid: node values are the exact signed distance, the query is the bilinear interpolant
with its analytic gradient."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from swarmnav.sensing import signed_distance
from swarmnav.sensing.esdf import Esdf
from swarmnav.world.obstacles import Box, Circle, Geometry, Polygon


@pytest.fixture(scope="module")
def scene():
    geom = Geometry.from_obstacles([
        Box((0.0, 0.0), (4.0, 2.0)),
        Circle((10.0, 5.0), 1.5),
        Polygon(((14.0, -3.0), (18.0, -3.0), (16.0, 1.0))),
    ])
    return geom, Esdf.build(geom, bounds=(-3.0, -5.0, 20.0, 9.0), resolution=0.1)


def test_grid_layout(scene):
    _, esdf = scene
    assert esdf.values.shape == (141, 231)  # (9 - -5)/0.1 + 1, (20 - -3)/0.1 + 1
    np.testing.assert_array_equal(esdf.origin, [-3.0, -5.0])
    with pytest.raises(dataclasses.FrozenInstanceError):
        esdf.resolution = 0.2


def test_query_at_nodes_equals_signed_distance(scene):
    geom, esdf = scene
    rng = np.random.default_rng(0)
    iy = rng.integers(0, esdf.values.shape[0], 500)
    ix = rng.integers(0, esdf.values.shape[1], 500)
    nodes = esdf.origin + esdf.resolution * np.c_[ix, iy]
    val, _ = esdf.query(nodes)
    np.testing.assert_allclose(val, signed_distance(geom, nodes), rtol=0, atol=1e-12)
    np.testing.assert_array_equal(esdf.values[iy, ix], signed_distance(geom, nodes))


def test_gradient_is_derivative_of_interpolant(scene):
    _, esdf = scene
    rng = np.random.default_rng(1)
    # Keep points >= 1e-3 cells from grid lines so the central difference stays in one cell.
    ny, nx = esdf.values.shape
    cell = rng.integers(0, [nx - 1, ny - 1], (400, 2)).astype(float) + rng.uniform(0.01, 0.99, (400, 2))
    pts = esdf.origin + esdf.resolution * cell
    _, grad = esdf.query(pts)
    h = 1e-6
    fd = np.stack([
        (esdf.query(pts + [h, 0])[0] - esdf.query(pts - [h, 0])[0]) / (2 * h),
        (esdf.query(pts + [0, h])[0] - esdf.query(pts - [0, h])[0]) / (2 * h),
    ], axis=1)
    # The interpolant is quadratic in each cell: central differences are exact up to rounding
    # of values ~10 m divided by 2e-6 m (~1e-9 relative).
    np.testing.assert_allclose(grad, fd, rtol=0, atol=1e-6)


def test_gradient_is_unit_and_points_away_from_obstacles(scene):
    _, esdf = scene
    # Above the box's top face the distance is linear, so bilinear interpolation is exact.
    xs = np.linspace(1.0, 3.0, 9)
    above = np.c_[xs, np.full_like(xs, 3.33)]
    val, grad = esdf.query(above)
    np.testing.assert_allclose(val, 1.33, atol=1e-9)
    np.testing.assert_allclose(grad, np.tile([0.0, 1.0], (9, 1)), atol=1e-9)
    # Around the circle the field is radial; interpolation error of the gradient is
    # O(h / distance to centre) = 0.1 / 2.5 -> a few per cent.
    ang = np.linspace(0, 2 * np.pi, 24, endpoint=False)
    ring = np.array([10.0, 5.0]) + 2.5 * np.c_[np.cos(ang), np.sin(ang)]
    val, grad = esdf.query(ring)
    np.testing.assert_allclose(val, 1.0, atol=0.01)
    np.testing.assert_allclose(np.linalg.norm(grad, axis=1), 1.0, atol=0.03)
    radial = (ring - [10.0, 5.0]) / 2.5
    assert np.all(np.einsum("ij,ij->i", grad, radial) > 0.99)
    # Inside the box the value is negative and the gradient still points outward (up here).
    val, grad = esdf.query(np.array([[2.0, 1.8]]))
    assert val[0] == pytest.approx(-0.2, abs=1e-9)
    np.testing.assert_allclose(grad[0], [0.0, 1.0], atol=1e-9)


def test_points_outside_grid_are_clamped(scene):
    _, esdf = scene
    far = np.array([[-100.0, 3.0], [50.0, -50.0]])
    border = np.array([[-3.0, 3.0], [20.0, -5.0]])
    v_far, g_far = esdf.query(far)
    v_b, g_b = esdf.query(border)
    np.testing.assert_array_equal(v_far, v_b)
    np.testing.assert_array_equal(g_far, g_b)


def test_empty_world_is_infinite_with_zero_gradient():
    esdf = Esdf.build(Geometry.from_obstacles([]), bounds=(0, 0, 1, 1), resolution=0.25)
    val, grad = esdf.query(np.array([[0.5, 0.5], [3.0, 3.0]]))
    assert np.all(val == np.inf) and np.all(grad == 0.0)


def test_build_rejects_bad_bounds():
    geom = Geometry.from_obstacles([])
    with pytest.raises(ValueError):
        Esdf.build(geom, bounds=(1, 0, 0, 1))
    with pytest.raises(ValueError):
        Esdf.build(geom, bounds=(0, 0, 1, 1), resolution=0.0)


def test_planar_build_takes_little_more_memory_than_the_field_and_counts_its_nodes(scene):
    """The planar build computes the exact distance a block of rows at a time: its peak memory is
    the field plus a bounded block (the whole-grid build took ~6x the field: query points, their
    coordinates and distances for every node at once). ``grid_nodes`` counts what it samples."""
    import tracemalloc

    from swarmnav.sensing.esdf import grid_nodes

    geom, _ = scene
    bounds = (-3.0, -5.0, 397.0, 195.0)  # 4001 x 2001 nodes, a 64 MB field
    Esdf.build(geom, bounds=(0.0, 0.0, 1.0, 1.0), resolution=0.1)  # kernels loaded before measuring
    tracemalloc.start()
    try:
        esdf = Esdf.build(geom, bounds=bounds, resolution=0.1)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert esdf.values.size == grid_nodes(bounds, 0.1) == 4001 * 2001
    assert peak < esdf.values.nbytes + 32 * 2**20  # the field + one block of ~0.5 M nodes (~48 B each)
    i = np.random.default_rng(0).integers(0, esdf.values.size, 500)
    nodes = esdf.origin + 0.1 * np.column_stack([i % 4001, i // 4001])
    np.testing.assert_array_equal(esdf.values.ravel()[i], signed_distance(geom, nodes))
    assert grid_nodes((-1e6, -1e6, 1e6, 1e6), 0.1) == 20_000_001**2 and grid_nodes((0.0, 0.0, 1e308, 1.0), 0.01) == np.inf
