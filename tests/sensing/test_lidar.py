"""LiDAR ring: the culled numba kernel against a brute-force per-ray reference, plus exact cases."""

from __future__ import annotations

import math

import numpy as np
import pytest
from numba import njit

from swarmnav.sensing import lidar_ring, ray_table
from _helpers.scenes import random_scene
from swarmnav.world.obstacles import Box, Circle, Geometry, Polygon

# Tolerance of the oracle comparison [m]: both sides are exact up to floating-point rounding
# of a few intersections at scene scale (~50 m), far above 1e-9.
ATOL = 1e-9


def ref_edges(geom: Geometry) -> tuple[np.ndarray, np.ndarray, list[tuple[int, int]]]:
    off = geom.poly_offsets
    return geom.seg_a, geom.seg_b, [(off[p], off[p + 1]) for p in range(len(off) - 1)]


def ref_point_seg_dist(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    e = b - a
    ee = np.einsum("ij,ij->i", e, e)
    s = np.clip(np.einsum("ij,ij->i", p - a, e) / np.where(ee > 0, ee, 1.0), 0.0, 1.0)
    return np.hypot(*(a + s[:, None] * e - p).T)


def ref_in_polygon(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> bool:
    """Winding number (sum of subtended angles) -- independent of the kernel's crossing rule."""
    va, vb = a - p, b - p
    ang = np.arctan2(va[:, 0] * vb[:, 1] - va[:, 1] * vb[:, 0], np.einsum("ij,ij->i", va, vb))
    return abs(ang.sum()) > np.pi


def ref_in_collision(geom: Geometry, p: np.ndarray) -> bool:
    A, B, polys = ref_edges(geom)
    for k0, k1 in polys:
        if ref_point_seg_dist(p, A[k0:k1], B[k0:k1]).min() == 0.0 or ref_in_polygon(p, A[k0:k1], B[k0:k1]):
            return True
    return bool(np.any(np.hypot(*(p - geom.circ_c).T) <= geom.circ_r))


def ref_lidar(geom: Geometry, positions: np.ndarray, n_rays: int, max_range: float) -> np.ndarray:
    """Per-ray loop, every ray against every edge (no culling) and every circle."""
    A, B = geom.seg_a, geom.seg_b
    E = B - A
    out = np.full((len(positions), n_rays), max_range)
    for i, p in enumerate(positions):
        if ref_in_collision(geom, p):
            out[i] = 0.0
            continue
        for r in range(n_rays):
            th = 2 * np.pi * r / n_rays
            u = np.array([np.cos(th), np.sin(th)])
            u[np.abs(u) < 1e-12] = 0.0  # exact axis directions, as a real sensor table would
            best = max_range
            if len(A):
                w = A - p
                den = u[0] * E[:, 1] - u[1] * E[:, 0]
                ok = den != 0.0
                with np.errstate(divide="ignore", invalid="ignore"):
                    t = (w[:, 0] * E[:, 1] - w[:, 1] * E[:, 0]) / den
                    s = (w[:, 0] * u[1] - w[:, 1] * u[0]) / den
                hit = ok & (t >= 0) & (s >= -1e-12) & (s <= 1 + 1e-12)
                if hit.any():
                    best = min(best, t[hit].min())
            for c, rad in zip(geom.circ_c, geom.circ_r):
                f = p - c
                b = f @ u
                disc = b * b - (f @ f - rad * rad)
                if disc >= 0 and -b - np.sqrt(disc) >= 0:
                    best = min(best, -b - np.sqrt(disc))
            out[i, r] = best
    return out


def special_agents(geom: Geometry, rng: np.random.Generator) -> np.ndarray:
    """Agents on edges' supporting lines, near vertices, at vertices, inside obstacles."""
    A, B = geom.seg_a, geom.seg_b
    pts = []
    for k in rng.choice(len(A), 8, replace=False):
        for s in (-2.5, -0.7, 1.3, 3.0):  # on the supporting line, off the segment
            pts.append(A[k] + s * (B[k] - A[k]))
    for k in rng.choice(len(A), 8, replace=False):
        d = rng.normal(size=2)
        pts.append(A[k] + 10.0 ** rng.uniform(-6, -2) * d / np.linalg.norm(d))  # near a vertex
    for c, rad in zip(geom.circ_c, geom.circ_r):
        a = rng.uniform(0, 2 * np.pi)
        pts.append(c + (rad + 10.0 ** rng.uniform(-6, -0.5)) * np.array([np.cos(a), np.sin(a)]))  # near a circle
    pts.append(A[0])  # exactly on a vertex: in collision
    pts.extend(geom.circ_c[:2])  # circle centres: inside
    return np.array(pts)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_matches_bruteforce_reference_on_random_scenes(seed):
    rng = np.random.default_rng(seed)
    geom = Geometry.from_obstacles(random_scene(rng))
    agents = np.vstack([rng.uniform(-18, 28, (12, 2)), special_agents(geom, rng)])
    n_rays = 180
    got = lidar_ring(geom, agents, n_rays=n_rays, max_range=12.0)
    want = ref_lidar(geom, agents, n_rays, 12.0)
    np.testing.assert_allclose(got, want, rtol=0, atol=ATOL)
    assert np.all((got >= 0.0) & (got <= 12.0))


def test_360_rays_and_odd_ray_counts_match_reference():
    rng = np.random.default_rng(7)
    geom = Geometry.from_obstacles(random_scene(rng))
    agents = rng.uniform(-18, 28, (4, 2))
    for n_rays in (360, 7, 1):
        got = lidar_ring(geom, agents, n_rays=n_rays, max_range=25.0)
        np.testing.assert_allclose(got, ref_lidar(geom, agents, n_rays, 25.0), rtol=0, atol=ATOL)


def test_rays_through_vertices_never_slip_between_edges():
    # Agents placed so that ray r points (up to rounding) straight at a polygon vertex whose
    # two edges lie on opposite sides of the ray: the ray must stop at or before the vertex.
    # (Rays that merely graze a silhouette vertex are left out: hit or miss is then decided
    # by the last bit and both answers are right.)
    rng = np.random.default_rng(11)
    n = 72
    checked = 0
    for _ in range(10):
        geom = Geometry.from_obstacles(random_scene(rng))
        off = geom.poly_offsets
        ks = rng.choice(len(geom.seg_a), 12, replace=False)
        rs = rng.integers(0, n, 12)
        u = np.c_[np.cos(2 * np.pi * rs / n), np.sin(2 * np.pi * rs / n)]
        dist = rng.uniform(1.0, 8.0, 12)
        agents = geom.seg_a[ks] - dist[:, None] * u
        ring = lidar_ring(geom, agents, n, 30.0)
        want = ref_lidar(geom, agents, n, 30.0)
        for m, k in enumerate(ks):
            p = np.searchsorted(off, k, side="right") - 1
            k_prev = k - 1 if k > off[p] else off[p + 1] - 1
            v, nxt, prv = geom.seg_a[k], geom.seg_b[k], geom.seg_a[k_prev]
            side_nxt = u[m, 0] * (nxt - v)[1] - u[m, 1] * (nxt - v)[0]
            side_prv = u[m, 0] * (prv - v)[1] - u[m, 1] * (prv - v)[0]
            if side_nxt * side_prv >= 0 or ref_in_collision(geom, agents[m]):
                continue
            checked += 1
            assert ring[m, rs[m]] <= dist[m] + 1e-9
            assert ring[m, rs[m]] == pytest.approx(want[m, rs[m]], abs=ATOL)
    assert checked >= 30


def test_exact_values_through_vertices_and_along_edges():
    geom = Geometry.from_obstacles([
        Box((5.0, 4.5), (25.0, 5.5)),
        Box((3.0, -1.0), (4.0, 1.0)),
        Circle((0.0, -6.0), 1.0),
        Polygon(((-5.0, -2.0), (-3.0, 0.0), (-5.0, 2.0))),
    ])
    n = 360
    # On the supporting line of the box's bottom edge: ray 0 grazes the edge and meets the
    # corner (5, 4.5) exactly.
    assert lidar_ring(geom, np.array([[0.0, 4.5]]), n)[0, 0] == 5.0
    # Ray 0 from the origin hits the face x = 3; ray 270 (down) hits the circle top at y = -5;
    # ray 180 (-x) hits the triangle exactly at its vertex (-3, 0).
    ring = lidar_ring(geom, np.array([[0.0, 0.0]]), n)[0]
    assert ring[0] == 3.0
    assert ring[270] == pytest.approx(5.0, abs=1e-12)
    assert ring[180] == pytest.approx(3.0, abs=1e-12)
    # Through the corner (3, -1) of the small box along the diagonal (the ray enters the box).
    r45 = lidar_ring(geom, np.array([[2.0, -2.0]]), 8)[0, 1]
    assert r45 == pytest.approx(np.sqrt(2.0), abs=1e-12)


def test_agents_in_collision_read_zero_on_every_ray():
    geom = Geometry.from_obstacles([Box((0, 0), (2, 1)), Circle((5, 5), 1.0),
                                    Polygon(((10, 0), (14, 0), (14, 4), (12, 1), (10, 4)))])
    agents = np.array([
        [1.0, 0.5],    # inside the box
        [2.0, 0.5],    # on the box's right edge
        [0.0, 0.0],    # on a box corner
        [5.0, 5.5],    # inside the circle
        [6.0, 5.0],    # on the circle
        [10.5, 1.0],   # inside the concave polygon's left lobe
        [12.0, 3.0],   # in the notch of the concave polygon: outside
    ])
    ring = lidar_ring(geom, agents, 64)
    assert np.all(ring[:6] == 0.0)
    assert np.all(ring[6] > 0.0)
    np.testing.assert_allclose(ring, ref_lidar(geom, agents, 64, 20.0), rtol=0, atol=ATOL)


def test_empty_geometry_and_short_range_read_max_range():
    agents = np.random.default_rng(3).uniform(-5, 5, (5, 2))
    empty = Geometry.from_obstacles([])
    np.testing.assert_array_equal(lidar_ring(empty, agents, 32, 7.5), 7.5)
    far = Geometry.from_obstacles([Box((100, 100), (110, 110)), Circle((-50, 0), 2.0)])
    np.testing.assert_array_equal(lidar_ring(far, agents, 32, 7.5), 7.5)
    assert lidar_ring(far, np.zeros((0, 2)), 32).shape == (0, 32)


def test_range_cut_is_exact_near_max_range():
    # The wall is 10 m away: rays whose hit lies beyond max_range = 12 read 12, the others the
    # exact distance 10 / sin(theta).
    geom = Geometry.from_obstacles([Box((-100.0, 10.0), (100.0, 11.0))])
    ring = lidar_ring(geom, np.array([[0.0, 0.0]]), 360, 12.0)[0]
    th = 2 * np.pi * np.arange(360) / 360
    with np.errstate(divide="ignore"):
        want = np.where(np.sin(th) > 0, 10.0 / np.sin(th), np.inf)
    np.testing.assert_allclose(ring, np.minimum(want, 12.0), rtol=0, atol=1e-12)


def test_rejects_bad_arguments():
    geom = Geometry.from_obstacles([])
    with pytest.raises(ValueError):
        lidar_ring(geom, np.zeros((3, 3)))
    with pytest.raises(ValueError):
        lidar_ring(geom, np.zeros((3, 2)), n_rays=0)
    with pytest.raises(ValueError):
        lidar_ring(geom, np.zeros((3, 2)), max_range=-1.0)
    with pytest.raises(ValueError):
        lidar_ring(geom, np.array([[0.0, np.nan]]))


@njit(cache=False)
def _scalar_rays(seg_a, seg_b, poly_offsets, circ_c, circ_r, positions, cos_t, sin_t, max_range, out):
    """The ray loop as a per-ray test with early exits (the form the kernel's branch-free,
    vectorised loop replaced), every facing edge and circle within range, no cone culling
    beyond the edge's own ray interval; agents in collision are not special-cased."""
    n_rays = cos_t.shape[0]
    for i in range(positions.shape[0]):
        px, py = positions[i, 0], positions[i, 1]
        row = out[i]
        row[:] = max_range
        for p in range(poly_offsets.shape[0] - 1):
            area2 = 0.0
            for k in range(poly_offsets[p], poly_offsets[p + 1]):
                area2 += seg_a[k, 0] * seg_b[k, 1] - seg_a[k, 1] * seg_b[k, 0]
            sgn = 1.0 if area2 > 0.0 else -1.0
            for k in range(poly_offsets[p], poly_offsets[p + 1]):
                ax, ay = seg_a[k, 0] - px, seg_a[k, 1] - py
                bx, by = seg_b[k, 0] - px, seg_b[k, 1] - py
                cr = ax * (by - ay) - ay * (bx - ax)
                if sgn * cr >= 0.0:
                    continue
                for rr in range(n_rays):
                    ux, uy = cos_t[rr], sin_t[rr]
                    sa = ux * ay - uy * ax
                    sb = ux * by - uy * bx
                    if (sa > 0.0 and sb > 0.0) or (sa < 0.0 and sb < 0.0):
                        continue
                    den = sb - sa
                    if den == 0.0:
                        continue
                    t = cr / den
                    if t >= 0.0 and t < row[rr]:
                        row[rr] = t
        for c in range(circ_r.shape[0]):
            cx, cy, rc = circ_c[c, 0] - px, circ_c[c, 1] - py, circ_r[c]
            dc = math.sqrt(cx * cx + cy * cy)
            q = (dc - rc) * (dc + rc)
            for rr in range(n_rays):
                ux, uy = cos_t[rr], sin_t[rr]
                b = ux * cx + uy * cy
                if b <= 0.0:
                    continue
                perp = ux * cy - uy * cx
                disc = rc * rc - perp * perp
                if disc < 0.0:
                    continue
                t = q / (b + math.sqrt(disc))
                if t < row[rr]:
                    row[rr] = t


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_vectorised_ray_loop_matches_the_per_ray_test_bit_for_bit(seed):
    # The kernel tests only the rays of each edge's (or circle's) interval, in a branch-free
    # loop; a per-ray test with early exits over every ray must give the same bits wherever the
    # agent is outside the obstacles (wrapping intervals, rays through vertices and grazing
    # circles included: the special agents).
    rng = np.random.default_rng(100 + seed)
    geom = Geometry.from_obstacles(random_scene(rng))
    agents = np.vstack([rng.uniform(-18, 28, (40, 2)), special_agents(geom, rng)])
    for n_rays, max_range in ((360, 20.0), (181, 12.0), (7, 30.0)):
        got = lidar_ring(geom, agents, n_rays=n_rays, max_range=max_range)
        cos_t, sin_t = ray_table(n_rays)
        want = np.empty_like(got)
        _scalar_rays(geom.seg_a, geom.seg_b, geom.poly_offsets, geom.circ_c, geom.circ_r,
                     np.ascontiguousarray(agents, dtype=np.float64), cos_t, sin_t, max_range, want)
        free = np.array([not ref_in_collision(geom, p) for p in agents])
        assert free.sum() >= 30
        np.testing.assert_array_equal(got[free], want[free])
