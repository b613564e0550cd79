"""Signed distance, nearest boundary point, inside test and segment blocking against
brute-force references written here."""

from __future__ import annotations

import numpy as np
import pytest

from swarmnav.sensing import nearest_obstacle, points_inside, segments_blocked, signed_distance, surfaces_within
from _helpers.scenes import random_scene
from swarmnav.world.obstacles import Box, Circle, Geometry, Polygon

# Distances are sums/products of a few scene-scale numbers: 1e-9 m is rounding, not modelling.
ATOL = 1e-9


def closest_on_segments(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    e = b - a
    s = np.clip(np.einsum("ij,ij->i", p - a, e) / np.einsum("ij,ij->i", e, e), 0.0, 1.0)
    return a + s[:, None] * e


def winding_inside(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> bool:
    va, vb = a - p, b - p
    ang = np.arctan2(va[:, 0] * vb[:, 1] - va[:, 1] * vb[:, 0], np.einsum("ij,ij->i", va, vb))
    return abs(ang.sum()) > np.pi


def ref_nearest(geom: Geometry, p: np.ndarray) -> tuple[float, np.ndarray | None]:
    """(signed distance, nearest boundary point) by brute force over every obstacle.

    Outside: nearest boundary over all obstacles. Inside: boundary of the deepest containing
    obstacle (the documented convention for overlaps).
    """
    cands = []  # (inside, distance, boundary point)
    off = geom.poly_offsets
    for k0, k1 in zip(off[:-1], off[1:]):
        q = closest_on_segments(p, geom.seg_a[k0:k1], geom.seg_b[k0:k1])
        d = np.hypot(*(q - p).T)
        j = int(np.argmin(d))
        cands.append((d[j] > 0 and winding_inside(p, geom.seg_a[k0:k1], geom.seg_b[k0:k1]), d[j], q[j]))
    for c, r in zip(geom.circ_c, geom.circ_r):
        v = p - c
        n = np.hypot(*v)
        u = v / n if n > 0 else np.array([1.0, 0.0])
        cands.append((n < r, abs(n - r), c + r * u))
    if not cands:
        return np.inf, None
    inside = [x for x in cands if x[0]]
    if inside:
        _, d, q = max(inside, key=lambda x: x[1])
        return -d, q
    _, d, q = min(cands, key=lambda x: x[1])
    return d, q


def ref_blocked(geom: Geometry, p: np.ndarray, q: np.ndarray) -> bool:
    """Closed segment p-q against every edge (parametric solve), endpoint-inside, and circles."""
    d = q - p
    for a, b in zip(geom.seg_a, geom.seg_b):
        e = b - a
        den = d[0] * e[1] - d[1] * e[0]
        w = a - p
        if den != 0.0:
            t = (w[0] * e[1] - w[1] * e[0]) / den
            s = (w[0] * d[1] - w[1] * d[0]) / den
            if -1e-12 <= t <= 1 + 1e-12 and -1e-12 <= s <= 1 + 1e-12:
                return True
        elif w[0] * d[1] - w[1] * d[0] == 0.0:  # collinear: overlap of projections
            L = d @ d if d @ d > 0 else 1.0
            t0, t1 = sorted(((a - p) @ d / L, (b - p) @ d / L))
            if d @ d == 0.0:
                if np.hypot(*closest_on_segments(p[None], a[None], b[None])[0] - p) == 0:
                    return True
            elif t1 >= 0 and t0 <= 1:
                return True
    off = geom.poly_offsets
    for k0, k1 in zip(off[:-1], off[1:]):
        if winding_inside(p, geom.seg_a[k0:k1], geom.seg_b[k0:k1]):
            return True
    for c, r in zip(geom.circ_c, geom.circ_r):
        if d @ d == 0:
            if np.hypot(*(p - c)) <= r:
                return True
        elif np.hypot(*(closest_on_segments(c[None], p[None], q[None])[0] - c)) <= r:
            return True
    return False


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_signed_distance_and_direction_match_bruteforce(seed):
    rng = np.random.default_rng(seed)
    geom = Geometry.from_obstacles(random_scene(rng, extent=10.0, n_boxes=3, with_l_shape=False))
    pts = rng.uniform(-13, 13, (300, 2))
    dist, direc = nearest_obstacle(geom, pts)
    np.testing.assert_array_equal(dist, signed_distance(geom, pts))
    for p, d, v in zip(pts, dist, direc):
        rd, rq = ref_nearest(geom, p)
        assert d == pytest.approx(rd, abs=ATOL)
        # direction: unit, from p toward the reference's nearest boundary point (p + |d| v).
        assert np.linalg.norm(v) == pytest.approx(1.0, abs=1e-12)
        np.testing.assert_allclose(p + abs(d) * v, rq, atol=1e-7)
    inside = points_inside(geom, pts)
    np.testing.assert_array_equal(inside, dist < 0)
    assert inside.any() and (~inside).any()  # the scene really exercises both sides


def test_signed_distance_known_values_and_boundaries():
    geom = Geometry.from_obstacles([Box((0, 0), (4, 2)), Circle((10, 0), 1.0),
                                    Polygon(((20, 0), (24, 0), (24, 4), (22, 1), (20, 4)))])
    pts = np.array([
        [2.0, 3.0],    # 1 m above the box's top face
        [2.0, 1.5],    # inside the box, 0.5 m from the top
        [4.0, 1.0],    # on the box's right edge
        [7.0, 5.0],    # nearest feature is the box corner (4, 2), not the circle
        [10.0, 0.0],   # circle centre: depth 1, direction +x by convention
        [12.0, 0.0],   # 1 m right of the circle
        [22.0, 2.0],   # in the polygon's notch, outside
    ])
    d, v = nearest_obstacle(geom, pts)
    np.testing.assert_allclose(d[:3], [1.0, -0.5, 0.0], atol=1e-15)
    assert d[3] == pytest.approx(np.hypot(3, 3))  # circle: hypot(3, 5) - 1 is farther
    assert d[4] == -1.0 and d[5] == 1.0
    assert d[6] > 0
    np.testing.assert_allclose(v[0], [0, -1], atol=1e-15)
    np.testing.assert_allclose(v[1], [0, 1], atol=1e-15)  # inside: toward the nearest boundary
    np.testing.assert_array_equal(v[2], [0, 0])  # exactly on the boundary
    np.testing.assert_allclose(v[4], [1, 0])
    np.testing.assert_allclose(v[5], [-1, 0])
    np.testing.assert_array_equal(points_inside(geom, pts), [False, True, True, False, True, False, False])


def test_overlapping_obstacles_use_the_deepest_containing_one():
    # (3.8, 2) is 0.2 m inside the box and 0.8 m inside the circle: the documented convention
    # reports the deeper penetration, with the direction toward that obstacle's boundary.
    geom = Geometry.from_obstacles([Box((0, 0), (4, 4)), Circle((4, 2), 1.0)])
    d, v = nearest_obstacle(geom, np.array([[3.8, 2.0], [6.0, 2.0]]))
    np.testing.assert_allclose(d, [-0.8, 1.0], atol=1e-12)
    np.testing.assert_allclose(v, [[-1.0, 0.0], [-1.0, 0.0]], atol=1e-12)


def test_empty_geometry():
    geom = Geometry.from_obstacles([])
    pts = np.random.default_rng(0).normal(size=(5, 2))
    d, v = nearest_obstacle(geom, pts)
    assert np.all(d == np.inf) and np.all(v == 0.0)
    assert np.all(signed_distance(geom, pts) == np.inf)
    assert not points_inside(geom, pts).any()
    assert not segments_blocked(geom, pts, -pts).any()
    assert signed_distance(geom, np.zeros((0, 2))).shape == (0,)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_segments_blocked_matches_bruteforce(seed):
    rng = np.random.default_rng(seed)
    geom = Geometry.from_obstacles(random_scene(rng, extent=10.0, n_boxes=3, with_l_shape=False))
    p = rng.uniform(-13, 13, (400, 2))
    q = p + rng.normal(scale=4.0, size=(400, 2))
    got = segments_blocked(geom, p, q)
    want = np.array([ref_blocked(geom, a, b) for a, b in zip(p, q)])
    np.testing.assert_array_equal(got, want)
    assert got.any() and (~got).any()


def test_segments_blocked_touching_counts():
    geom = Geometry.from_obstacles([Box((0, 0), (2, 2)), Circle((10, 0), 1.0)])
    p = np.array([
        [-1.0, -1.0],  # to the corner (0, 0) exactly: touches
        [-1.0, 0.0],   # along the bottom edge's line, overlapping it
        [-1.0, 0.0],   # ends exactly on the corner
        [3.0, 3.0],    # passes the corner (2, 2) at 1e-9 m: free
        [0.5, 0.5],    # wholly inside the box
        [8.0, 1.0],    # tangent to the circle's top
        [8.0, 1.0 + 1e-9],  # just above the tangent: free
        [1.0, 1.0],    # zero-length, inside
        [5.0, 5.0],    # zero-length, outside
        [-3.0, 1.0],   # through the whole box
        [1.0, -1.0],   # from outside, ends inside the bottom edge
        [1.0, 0.0],    # starts inside the bottom edge, leaves outward
    ])
    q = np.array([
        [0.0, 0.0],
        [5.0, 0.0],
        [0.0, 0.0],
        [2.0 + 1e-9, 4.0],
        [1.5, 1.5],
        [12.0, 1.0],
        [12.0, 1.0 + 1e-9],
        [1.0, 1.0],
        [5.0, 5.0],
        [5.0, 1.0],
        [1.0, 0.0],
        [1.0, -1.0],
    ])
    want = [True, True, True, False, True, True, False, True, False, True, True, True]
    np.testing.assert_array_equal(segments_blocked(geom, p, q), want)


def test_shape_checks():
    geom = Geometry.from_obstacles([Box((0, 0), (1, 1))])
    with pytest.raises(ValueError):
        segments_blocked(geom, np.zeros((3, 2)), np.zeros((2, 2)))
    with pytest.raises(ValueError):
        signed_distance(geom, np.zeros(4))


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_surfaces_within_lists_every_obstacle_in_reach(seed):
    """Oracle: one row per (point, obstacle) whose own signed distance is within reach, that
    distance and direction equal to nearest_obstacle's against a world of that obstacle alone."""
    rng = np.random.default_rng(seed)
    obstacles = random_scene(rng, extent=10.0, n_boxes=3, with_l_shape=False)
    geom = Geometry.from_obstacles(obstacles)
    pts = rng.uniform(-13, 13, (200, 2))
    reach = 2.5
    point, dist, direc = surfaces_within(geom, pts, reach)
    assert np.all(np.diff(point) >= 0)
    expected = []
    for ob in obstacles:
        d, v = nearest_obstacle(Geometry.from_obstacles([ob]), pts)
        for i in np.flatnonzero(d <= reach):
            expected.append((i, d[i], v[i]))
    assert len(expected) == len(point) > len(pts) // 4  # the scene puts many points near obstacles
    got = sorted(zip(point, dist, map(tuple, direc)), key=lambda r: (r[0], r[1]))
    expected.sort(key=lambda r: (r[0], r[1]))
    for (i, d, v), (ei, ed, ev) in zip(got, expected):
        assert i == ei
        assert d == pytest.approx(ed, abs=1e-12)
        np.testing.assert_allclose(v, ev, atol=1e-12)
    # a point between two obstacles has a row for each, where nearest_obstacle sees one
    assert np.max(np.bincount(point)) >= 2


def test_surfaces_within_refuses_3d_worlds():
    from swarmnav.world.obstacles import Sphere
    with pytest.raises(ValueError, match="planar"):
        surfaces_within(Geometry.from_obstacles([Sphere((0, 0, 0), 1.0)], dim=3), np.zeros((1, 3)), 1.0)
