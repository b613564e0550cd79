"""Convex outer polyhedra for MADER-style planning: obstacles as vertex sets, B-spline segment
hulls, other agents' trajectory hulls over a time interval, and separating-plane seeds.

MADER (Tordesillas & How, T-RO 2021) represents every obstacle, and every interval of another
agent's trajectory, by the vertices of a convex polyhedron, and every interval of the agent's
own trajectory by the convex hull of its segment's control points (B-spline, Bezier or MINVO
basis; here the B-spline control points: the conservative hull of the paper's Table II, see
docs/methods/mader.md). A plane ``n . x + d = 0`` separates the two when

    n . v + d >= 1  for every obstacle vertex v,   n . c + d <= -1  for every control point c

(the scale of (n, d) is free, so the margins are 1).

All sets are arrays: ``(P, V, D)`` vertices of P polyhedra, padded by repeating a vertex.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.spatial import ConvexHull, QhullError

from swarmnav.world.obstacles import Box, Circle, Cylinder, Polygon, Sphere

#: sides of the polygon that bounds a disc (a regular polygon circumscribing it)
DISC_SIDES = 8


def _square_offsets(dim: int) -> np.ndarray:
    """(2^dim, dim) corners of the cube [-1, 1]^dim."""
    g = np.array(np.meshgrid(*([[-1.0, 1.0]] * dim), indexing="ij")).reshape(dim, -1).T
    return g


def _ring(center, radius: float) -> np.ndarray:
    """(DISC_SIDES, 2) vertices of the regular polygon circumscribing a disc."""
    ang = 2 * math.pi * (np.arange(DISC_SIDES) + 0.5) / DISC_SIDES
    rr = radius / math.cos(math.pi / DISC_SIDES)
    return np.asarray(center, dtype=float) + rr * np.stack([np.cos(ang), np.sin(ang)], axis=1)


def obstacle_vertices(obstacle, dim: int, inflation: float, z_range=(-1e3, 1e3)) -> np.ndarray:
    """Vertices (V, dim) of a convex polyhedron containing ``obstacle`` grown by ``inflation`` [m]:
    boxes as boxes, discs / cylinders as circumscribing polygons / prisms, polygons as their
    vertices grown by a square (the convex hull is taken implicitly: a non-convex polygon is
    bounded by its hull), spheres as their bounding cubes. In 3-D a planar obstacle (no z) is a
    prism over ``z_range``."""
    e = inflation
    if isinstance(obstacle, Box):
        lo = np.asarray(obstacle.min, dtype=float) - e
        hi = np.asarray(obstacle.max, dtype=float) + e
        if dim == 3 and lo.size == 2:
            lo, hi = np.append(lo, z_range[0] - e), np.append(hi, z_range[1] + e)
        c, h = 0.5 * (lo + hi), 0.5 * (hi - lo)
        return c + h * _square_offsets(dim)
    if isinstance(obstacle, Sphere):
        return np.asarray(obstacle.center, dtype=float) + (obstacle.radius + e) * _square_offsets(3)
    if isinstance(obstacle, (Circle, Cylinder)):
        flat = _ring(obstacle.center, obstacle.radius + e)
        z = getattr(obstacle, "z", None)
    elif isinstance(obstacle, Polygon):
        pts = np.asarray(obstacle.points, dtype=float)
        flat = (pts[:, None, :] + e * _square_offsets(2)[None]).reshape(-1, 2)
        z = obstacle.z
    else:  # pragma: no cover - every obstacle type is listed above
        raise TypeError(f"unknown obstacle {type(obstacle).__name__}")
    if dim == 2:
        return flat
    z0, z1 = (z if z is not None else z_range)
    z0, z1 = z0 - e, z1 + e
    return np.vstack([np.column_stack([flat, np.full(len(flat), z0)]),
                      np.column_stack([flat, np.full(len(flat), z1)])])


def pad(sets: list[np.ndarray], dim: int, multiple: int = 1) -> np.ndarray:
    """Stack vertex sets of different sizes into (P, Vmax, dim), padding with each set's centroid
    (inside the hull, so a padded row is a constraint that is never active; a repeated vertex
    would be a duplicate, degenerate one)."""
    if not sets:
        return np.zeros((0, 1, dim))
    vmax = -(-max(len(s) for s in sets) // multiple) * multiple
    out = np.empty((len(sets), vmax, dim))
    for k, s in enumerate(sets):
        out[k, : len(s)] = s
        out[k, len(s):] = s.mean(axis=0)
    return out


def inflate_points(points: np.ndarray, half: float) -> np.ndarray:
    """Vertices of the Minkowski sum of the points' hull and the cube of half-size ``half``
    (only the corners on the hull, by SciPy's Qhull)."""
    dim = points.shape[1]
    pts = (points[:, None, :] + half * _square_offsets(dim)[None]).reshape(-1, dim)
    return hull_vertices(pts)


def hull_vertices(pts: np.ndarray) -> np.ndarray:
    """The points of ``pts`` that are vertices of its convex hull (all of them if the hull is flat)."""
    try:
        return pts[np.sort(ConvexHull(pts).vertices)]
    except QhullError:
        return pts


def segment_points(ctrl: np.ndarray) -> np.ndarray:
    """(S, 4, D) control points of each segment of a uniform cubic B-spline (its convex hull
    contains the segment)."""
    s = ctrl.shape[0] - 3
    return ctrl[np.arange(s)[:, None] + np.arange(4)[None, :]]


def interval_points(ctrl: np.ndarray, dt_knot: float, t_start: float, t0: float, t1: float) -> np.ndarray:
    """Control points whose hull contains a committed B-spline (started at ``t_start`` [s]) over the
    absolute interval [t0, t1] [s]; before its start / after its end it holds its first / last
    position, which are its control points' too (start: at rest; end: three equal points)."""
    s = ctrl.shape[0] - 3
    a = int(np.clip(math.floor((t0 - t_start) / dt_knot), 0, s - 1))
    b = int(np.clip(math.floor((t1 - t_start) / dt_knot), 0, s - 1))
    return ctrl[a: b + 4]


def _directions(dim: int) -> np.ndarray:
    if dim == 2:
        ang = 2 * math.pi * np.arange(16) / 16
        return np.stack([np.cos(ang), np.sin(ang)], axis=1)
    g = np.array([(i, j, k) for i in (-1, 0, 1) for j in (-1, 0, 1) for k in (-1, 0, 1) if (i, j, k) != (0, 0, 0)],
                 dtype=float)
    return g / np.linalg.norm(g, axis=1, keepdims=True)


def seed_planes(cps: np.ndarray, verts: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Initial planes between control-point sets ``cps`` (P, 4, D) and vertex sets ``verts``
    (P, V, D): the best of a fixed fan of directions and the centroid direction, scaled so the
    margins are +-1 where the sets are separated. Returns n (P, D), d (P,), gap (P,) [m] (the
    separation along n; <= 0: not separated along any tried direction)."""
    p_, _, dim = cps.shape
    if p_ == 0:
        return np.zeros((0, dim)), np.zeros(0), np.zeros(0)
    fan = _directions(dim)
    cen = verts.mean(axis=1) - cps.mean(axis=1)
    cen /= np.maximum(np.linalg.norm(cen, axis=1, keepdims=True), 1e-12)
    dirs = np.concatenate([np.broadcast_to(fan, (p_, *fan.shape)), cen[:, None, :]], axis=1)  # (P, K, D)
    pc = np.einsum("pkd,pcd->pkc", dirs, cps).max(axis=2)  # (P, K)
    pv = np.einsum("pkd,pvd->pkv", dirs, verts).min(axis=2)
    gap = pv - pc
    best = np.argmax(gap, axis=1)
    r = np.arange(p_)
    u, g = dirs[r, best], gap[r, best]
    mid = 0.5 * (pv[r, best] + pc[r, best])
    scale = 2.0 / np.maximum(g, 0.5)
    return u * scale[:, None], -mid * scale, g


def separated(cps: np.ndarray, verts: np.ndarray) -> np.ndarray:
    """Whether each pair of sets (P, 4, D) / (P, V, D) is separated along some fan direction
    (a sufficient test, for diagnostics)."""
    return seed_planes(cps, verts)[2] > 0
