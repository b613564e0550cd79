"""3-D sensing against a brute-force NumPy reference on random boxes, vertical cylinders,
spheres and (concave) prisms: signed distance, nearest point, inside test, line of sight and
range scan.

The reference is built differently from the kernels: an obstacle's boundary is enumerated as
its faces (side rectangles edge x [z0, z1], the two caps, a sphere's surface) and the nearest
boundary point is the closest of the faces' nearest points; the signed distance of the world
is the minimum over obstacles of (minus, when inside) that boundary distance.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from swarmnav.sensing import nearest_obstacle, points_inside, range_scan, segments_blocked, signed_distance
from swarmnav.world.obstacles import Box, Cylinder, Geometry, Polygon, Sphere

TOL = 1e-9  # [m] the bound on the error of signed distance and nearest point


# ------------------------------------------------------------------------------------------
# Reference (vectorised over points, a loop over obstacles and edges)
# ------------------------------------------------------------------------------------------


def _in_polygon(xy: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Even-odd rule (PNPOLY); boundary points are handled by the distance (0 there)."""
    x, y = xy[:, 0], xy[:, 1]
    inside = np.zeros(len(xy), dtype=bool)
    for a, b in zip(v, np.roll(v, -1, axis=0)):
        straddle = (a[1] > y) != (b[1] > y)
        with np.errstate(divide="ignore", invalid="ignore"):
            xc = a[0] + (y - a[1]) * (b[0] - a[0]) / (b[1] - a[1])
        inside ^= straddle & (x < xc)
    return inside


def _nearest_on_segments(xy: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Nearest point (M, 2) on the closed polygon boundary ``v``."""
    best = np.full(len(xy), np.inf)
    out = np.zeros_like(xy)
    for a, b in zip(v, np.roll(v, -1, axis=0)):
        e = b - a
        s = np.clip(((xy - a) @ e) / (e @ e), 0.0, 1.0)
        q = a + s[:, None] * e
        d = np.linalg.norm(xy - q, axis=1)
        better = d < best
        best[better] = d[better]
        out[better] = q[better]
    return out


def _candidates(o, p: np.ndarray) -> list[np.ndarray]:
    """Nearest points of ``p`` (M, 3) on each face of obstacle ``o``."""
    xy, z = p[:, :2], p[:, 2]
    if isinstance(o, Sphere):
        c = np.array(o.center)
        w = p - c
        n = np.linalg.norm(w, axis=1, keepdims=True)
        u = np.where(n > 0, w / np.where(n > 0, n, 1.0), [1.0, 0.0, 0.0])
        return [c + o.radius * u]
    z0, z1 = o.z
    if isinstance(o, Cylinder):
        c = np.array(o.center)
        w = xy - c
        n = np.linalg.norm(w, axis=1, keepdims=True)
        rim = c + o.radius * np.where(n > 0, w / np.where(n > 0, n, 1.0), [1.0, 0.0])
        in_fp = n[:, 0] <= o.radius
    else:
        v = o.vertices()
        rim = _nearest_on_segments(xy, v)
        in_fp = _in_polygon(xy, v)
    side = np.c_[rim, np.clip(z, z0, z1)]
    caps = [np.c_[np.where(in_fp[:, None], xy, rim), np.full(len(p), zc)] for zc in (z0, z1)]
    return [side, *caps]


def _inside(o, p: np.ndarray) -> np.ndarray:
    if isinstance(o, Sphere):
        return np.linalg.norm(p - np.array(o.center), axis=1) <= o.radius
    z0, z1 = o.z
    inz = (p[:, 2] >= z0) & (p[:, 2] <= z1)
    if isinstance(o, Cylinder):
        return inz & (np.linalg.norm(p[:, :2] - np.array(o.center), axis=1) <= o.radius)
    return inz & _in_polygon(p[:, :2], o.vertices())


def ref_obstacle(o, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Signed distance of ``p`` to obstacle ``o`` and its nearest boundary point."""
    cands = _candidates(o, p)
    d = np.stack([np.linalg.norm(p - q, axis=1) for q in cands])
    k = np.argmin(d, axis=0)
    q = np.stack(cands)[k, np.arange(len(p))]
    bd = d[k, np.arange(len(p))]
    return np.where(_inside(o, p), -bd, bd), q


def ref_signed_distance(obs, p: np.ndarray) -> np.ndarray:
    return np.min([ref_obstacle(o, p)[0] for o in obs], axis=0)


def ref_boundary_distance(obs, p: np.ndarray) -> np.ndarray:
    """Distance from ``p`` to the nearest point on any obstacle's boundary."""
    return np.min([np.abs(ref_obstacle(o, p)[0]) for o in obs], axis=0)


# ------------------------------------------------------------------------------------------
# Random worlds
# ------------------------------------------------------------------------------------------


def random_world(rng: np.random.Generator) -> list:
    """Boxes, cylinders, spheres and star prisms (concave, both orientations) in a 10 x 10 x 5 m
    region, overlaps allowed."""
    obs: list = []
    for _ in range(3):
        lo = rng.uniform([0, 0, 0], [9, 9, 4])
        obs.append(Box(tuple(lo), tuple(lo + rng.uniform(0.3, 3.0, 3))))
    for _ in range(3):
        z0 = rng.uniform(0, 3)
        obs.append(Cylinder(tuple(rng.uniform(0, 10, 2)), float(rng.uniform(0.2, 1.5)),
                            (z0, z0 + rng.uniform(0.5, 3))))
    for _ in range(2):
        obs.append(Sphere(tuple(rng.uniform([0, 0, 0], [10, 10, 5])), float(rng.uniform(0.3, 1.5))))
    for _ in range(2):
        k = int(rng.integers(4, 8))
        ang = 2 * np.pi * (np.arange(k) + rng.uniform(0.0, 0.8, k)) / k
        rad = rng.uniform(0.4, 2.0, k)
        pts = rng.uniform(0, 10, 2) + np.c_[rad * np.cos(ang), rad * np.sin(ang)]
        if rng.random() < 0.5:
            pts = pts[::-1]
        z0 = rng.uniform(0, 3)
        obs.append(Polygon(tuple(map(tuple, pts)), z=(z0, z0 + rng.uniform(0.5, 3))))
    return obs


def query_points(rng: np.random.Generator, obs, m: int = 1500) -> np.ndarray:
    """Uniform points plus points within a few cm of random boundaries (both sides)."""
    uni = rng.uniform([-1, -1, -1], [11, 11, 6], (m, 3))
    near = []
    for o in obs:
        p = rng.uniform([-1, -1, -1], [11, 11, 6], (60, 3))
        _, q = ref_obstacle(o, p)
        near.append(q + rng.normal(0, 0.03, q.shape))
    return np.vstack([uni, *near])


@pytest.fixture(scope="module", params=[0, 1, 2])
def world(request):
    rng = np.random.default_rng(request.param)
    obs = random_world(rng)
    return obs, Geometry.from_obstacles(obs, dim=3), rng


# ------------------------------------------------------------------------------------------
# Tests
# ------------------------------------------------------------------------------------------


def test_signed_distance_matches_reference(world):
    obs, geom, rng = world
    p = query_points(rng, obs)
    want = ref_signed_distance(obs, p)
    got = signed_distance(geom, p)
    np.testing.assert_allclose(got, want, rtol=0, atol=TOL)
    assert (want < 0).sum() > 50 and (want > 0).sum() > 50  # both sides are exercised


def test_nearest_point_lies_on_a_boundary_at_the_signed_distance(world):
    obs, geom, rng = world
    p = query_points(rng, obs)
    d, u = nearest_obstacle(geom, p)
    np.testing.assert_array_equal(d, signed_distance(geom, p))
    nz = d != 0
    np.testing.assert_allclose(np.linalg.norm(u[nz], axis=1), 1.0, atol=1e-12)
    q = p + np.abs(d)[:, None] * u
    # |q - p| = |d| (exact by construction) and q on a boundary: q is a nearest boundary point.
    assert np.max(ref_boundary_distance(obs, q)) < TOL
    # Inside an obstacle the direction is outward: stepping along it leaves (reduces depth).
    inside = d < -1e-3
    d2 = signed_distance(geom, p[inside] + 1e-4 * u[inside])
    assert np.all(d2 > d[inside])


def test_inside_matches_reference_and_boundaries_are_closed(world):
    obs, geom, rng = world
    p = query_points(rng, obs)
    want = ref_signed_distance(obs, p)
    got = points_inside(geom, p)
    clear = np.abs(want) > 1e-12
    np.testing.assert_array_equal(got[clear], want[clear] <= 0)
    # Points exactly on the caps and walls of a box are in collision, with distance 0.
    b = next(o for o in obs if isinstance(o, Box))
    mid = (np.array(b.min) + np.array(b.max)) / 2
    on = np.array([[mid[0], mid[1], b.max[2]], [mid[0], mid[1], b.min[2]], [b.min[0], mid[1], mid[2]],
                   list(b.max)])
    assert points_inside(geom, on).all()
    assert np.all(signed_distance(geom, on) <= 0.0)


def test_segments_blocked_matches_dense_sampling_of_the_reference(world):
    """Rigorous both ways: the reference distance is 1-Lipschitz, so a segment whose samples
    (spacing h) all have distance > h/2 is clear, and one with a sample at distance <= 0 is
    blocked; segments in between are ambiguous and skipped (few)."""
    obs, geom, rng = world
    m = 300
    p = rng.uniform([-1, -1, -1], [11, 11, 6], (m, 3))
    q = p + rng.normal(0, 4.0, (m, 3))
    n_s = 801
    t = np.linspace(0, 1, n_s)
    pts = (p[:, None, :] + t[None, :, None] * (q - p)[:, None, :]).reshape(-1, 3)
    sd = ref_signed_distance(obs, pts).reshape(m, n_s)
    h = np.linalg.norm(q - p, axis=1) / (n_s - 1)
    surely_blocked = sd.min(axis=1) <= 0.0
    surely_clear = sd.min(axis=1) > h / 2
    got = segments_blocked(geom, p, q)
    assert np.all(got[surely_blocked]) and not np.any(got[surely_clear])
    assert surely_blocked.sum() > 40 and surely_clear.sum() > 40
    assert (surely_blocked | surely_clear).sum() >= 0.95 * m


def test_segment_touching_a_face_or_a_sphere_is_blocked():
    geom = Geometry.from_obstacles([Box((0, 0, 0), (1, 1, 1)), Sphere((5, 0, 0), 1.0),
                                    Cylinder((0, 5), 1.0, (0, 2))], dim=3)
    p = np.array([[-1, 0.5, 1.0], [4, -1, 0.0], [-2, 6, 2.0], [-1, 0.5, 1.0 + 1e-9], [0.5, 0.5, 3]])
    q = np.array([[2, 0.5, 1.0], [6, -1, 0.0], [2, 6, 2.0], [2, 0.5, 1.0 + 1e-9], [0.5, 0.5, 1.0]])
    # along the top face; tangent to the sphere's top; along the cylinder's top cap (y=6 is
    # its rim); just above the box's top; straight down onto the top face
    np.testing.assert_array_equal(segments_blocked(geom, p, q), [True, True, True, False, True])


def _sphere_trace(obs, p, u, max_range, eps=1e-11, iters=3000):
    """First hit along each ray by sphere tracing the reference distance (a step never passes
    an obstacle); NaN where it has not converged (grazing rays)."""
    t = np.zeros(len(p))
    done = np.zeros(len(p), dtype=bool)
    for _ in range(iters):
        live = ~done
        if not live.any():
            break
        d = ref_signed_distance(obs, p[live] + t[live, None] * u[live])
        idx = np.flatnonzero(live)
        hit = d < eps
        done[idx[hit]] = True
        t[idx[~hit]] += d[~hit]
        far = t >= max_range
        t[far & ~done] = max_range
        done |= far
    t[~done] = np.nan
    return t


def test_range_scan_matches_sphere_tracing_of_the_reference(world):
    obs, geom, rng = world
    pos = rng.uniform([-1, -1, -1], [11, 11, 6], (6, 3))
    pos = pos[~points_inside(geom, pos)]
    u = rng.normal(size=(200, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    got = range_scan(geom, pos, u, 8.0)
    for i in range(len(pos)):
        want = _sphere_trace(obs, np.tile(pos[i], (len(u), 1)), u, 8.0)
        ok = np.isfinite(want)
        assert ok.mean() > 0.9
        np.testing.assert_allclose(got[i, ok], want[ok], rtol=0, atol=1e-7)
    assert np.any(got < 8.0) and np.any(got == 8.0)
    inside = np.array([[*ref_obstacle(obs[0], np.array([[5.0, 5.0, 2.0]]))[1][0]]])  # a boundary point
    assert np.all(range_scan(geom, inside, u, 8.0) == 0.0)


def test_range_scan_in_the_plane_equals_the_lidar_ring():
    from _helpers.scenes import random_scene

    from swarmnav.sensing import lidar_ring

    rng = np.random.default_rng(3)
    geom = Geometry.from_obstacles(random_scene(rng))
    x = rng.uniform(-18, 28, (12, 2))
    th = 2 * np.pi * np.arange(90) / 90
    got = range_scan(geom, x, np.c_[np.cos(th), np.sin(th)], 12.0)
    np.testing.assert_allclose(got, lidar_ring(geom, x, n_rays=90, max_range=12.0), rtol=0, atol=1e-9)


def test_wrong_point_shape_names_the_expected_shape():
    geom = Geometry.from_obstacles([Sphere((0, 0, 0), 1.0)], dim=3)
    for f in (signed_distance, points_inside, nearest_obstacle):
        with pytest.raises(ValueError, match=r"\(M, 3\)"):
            f(geom, np.zeros((4, 2)))
    with pytest.raises(ValueError, match=r"\(M, 3\)"):
        segments_blocked(geom, np.zeros((4, 2)), np.zeros((4, 2)))
    with pytest.raises(ValueError, match=r"\(M, 2\)"):
        signed_distance(Geometry.from_obstacles([]), np.zeros((4, 3)))
    with pytest.raises(ValueError, match=r"\(N, 3\)"):
        range_scan(geom, np.zeros((4, 2)), np.eye(3), 5.0)


def test_empty_3d_world_is_free():
    geom = Geometry.from_obstacles([], dim=3)
    p = np.array([[0.0, 1.0, 2.0]])
    assert signed_distance(geom, p)[0] == np.inf
    assert not points_inside(geom, p)[0] and not segments_blocked(geom, p, p + 1)[0]
    assert np.all(range_scan(geom, p, np.eye(3), 4.0) == 4.0)


@settings(max_examples=60, deadline=None)
@given(c=st.tuples(*[st.floats(-5, 5)] * 3), r=st.floats(0.1, 3), z0=st.floats(-3, 3), hz=st.floats(0.1, 4),
       p=st.tuples(*[st.floats(-10, 10)] * 3))
def test_single_cylinder_and_sphere_property(c, r, z0, hz, p):
    """One cylinder or one sphere: the kernel equals the reference at any point."""
    pt = np.array([p])
    for o in (Cylinder(c[:2], r, (z0, z0 + hz)), Sphere(c, r)):
        geom = Geometry.from_obstacles([o], dim=3)
        assert abs(signed_distance(geom, pt)[0] - ref_signed_distance([o], pt)[0]) < TOL
