"""3-D ESDF: node values are exactly the signed distance, the query is the trilinear
interpolant with its analytic gradient, clamped to the grid."""

from __future__ import annotations

import numpy as np
import pytest

from swarmnav.sensing import Esdf, signed_distance
from swarmnav.world.obstacles import Box, Cylinder, Geometry, Polygon, Sphere


@pytest.fixture(scope="module")
def scene():
    geom = Geometry.from_obstacles([
        Box((0.0, 0.0, 0.0), (2.0, 1.0, 1.5)),
        Cylinder((4.0, 2.0), 0.5, (0.0, 3.0)),
        Cylinder((4.3, 2.2), 0.4, (2.5, 4.0)),  # overlaps the first: the deepest one counts
        Sphere((1.0, 3.0, 2.0), 0.8),
        Polygon(((5.0, -1.0), (6.5, -1.0), (6.0, 0.5), (5.6, -0.2)), z=(0.5, 2.0)),
    ], dim=3)
    return geom, Esdf.build(geom, bounds=(-1.0, -2.0, -0.5, 7.0, 4.5, 4.5), resolution=0.1)


def test_grid_layout(scene):
    _, esdf = scene
    assert esdf.shape == esdf.values.shape == (51, 66, 81) and esdf.dim == 3
    np.testing.assert_array_equal(esdf.origin, [-1.0, -2.0, -0.5])
    assert esdf.resolution == 0.1


def test_node_values_are_the_signed_distance(scene):
    geom, esdf = scene
    nz, ny, nx = esdf.shape
    iz, iy, ix = np.meshgrid(np.arange(nz), np.arange(ny), np.arange(nx), indexing="ij")
    nodes = esdf.origin + esdf.resolution * np.c_[ix.ravel(), iy.ravel(), iz.ravel()]
    want = signed_distance(geom, nodes).reshape(esdf.shape)
    np.testing.assert_array_equal(esdf.values, want)  # same per-obstacle formula, bit for bit
    assert (want < 0).any() and (want > 0).any()
    val, _ = esdf.query(nodes[::97])
    np.testing.assert_allclose(val, want.ravel()[::97], rtol=0, atol=1e-12)


def test_gradient_is_derivative_of_interpolant(scene):
    _, esdf = scene
    rng = np.random.default_rng(1)
    nz, ny, nx = esdf.shape
    cell = rng.integers(0, [nx - 1, ny - 1, nz - 1], (400, 3)) + rng.uniform(0.01, 0.99, (400, 3))
    pts = esdf.origin + esdf.resolution * cell
    _, grad = esdf.query(pts)
    h = 1e-6
    fd = np.stack([(esdf.query(pts + h * e)[0] - esdf.query(pts - h * e)[0]) / (2 * h) for e in np.eye(3)], axis=1)
    # Trilinear is polynomial in each cell: central differences are exact up to rounding of
    # values ~5 m over 2e-6 m (~1e-9 relative).
    np.testing.assert_allclose(grad, fd, rtol=0, atol=1e-6)


def test_field_above_a_box_is_linear_and_clamped_outside(scene):
    _, esdf = scene
    above = np.c_[np.linspace(0.5, 1.5, 7), np.full(7, 0.5), np.full(7, 2.43)]
    val, grad = esdf.query(above)
    np.testing.assert_allclose(val, 0.93, atol=1e-9)
    np.testing.assert_allclose(grad, np.tile([0.0, 0.0, 1.0], (7, 1)), atol=1e-9)
    far = np.array([[-50.0, 0.0, 1.0], [3.0, 3.0, 99.0]])
    border = np.array([[-1.0, 0.0, 1.0], [3.0, 3.0, 4.5]])
    for a, b in zip(esdf.query(far), esdf.query(border)):
        np.testing.assert_array_equal(a, b)


def test_empty_world_and_bad_bounds():
    empty = Geometry.from_obstacles([], dim=3)
    esdf = Esdf.build(empty, (0, 0, 0, 1, 1, 1), 0.25)
    val, grad = esdf.query(np.array([[0.5, 0.5, 0.5]]))
    assert val[0] == np.inf and np.all(grad == 0.0)
    with pytest.raises(ValueError, match="3-D"):
        Esdf.build(empty, (0, 0, 1, 1), 0.1)
    with pytest.raises(ValueError):
        Esdf.build(empty, (0, 0, 1, 1, 1, 0), 0.1)
    with pytest.raises(ValueError, match=r"\(M, 3\)"):
        esdf.query(np.zeros((2, 2)))


def test_random_forest_nodes_equal_signed_distance():
    """Many tall trunks: the column pruning keeps only a few candidates per column."""
    rng = np.random.default_rng(7)
    obs = [Cylinder(tuple(rng.uniform(0, 12, 2)), float(rng.uniform(0.3, 0.6)), (0.0, float(rng.uniform(2, 4))))
           for _ in range(40)]
    obs += [Sphere(tuple(rng.uniform([0, 0, 0], [12, 12, 4])), 0.7), Box((3, 3, 3), (5, 4, 3.5))]
    geom = Geometry.from_obstacles(obs, dim=3)
    esdf = Esdf.build(geom, (0, 0, 0, 12, 12, 4), 0.2)
    nz, ny, nx = esdf.shape
    iz, iy, ix = np.meshgrid(np.arange(nz), np.arange(ny), np.arange(nx), indexing="ij")
    nodes = esdf.origin + esdf.resolution * np.c_[ix.ravel(), iy.ravel(), iz.ravel()]
    np.testing.assert_array_equal(esdf.values.ravel(), signed_distance(geom, nodes))
