"""Point and segment queries against the obstacles: signed distance, nearest boundary point,
inside test and line-of-sight blocking.

Obstacles are closed sets: a point on a boundary is in collision and a segment that only
touches a boundary is blocked. Every function takes points of shape (M, d) with ``d =
geom.dim``: planar worlds use the kernels of :mod:`swarmnav.sensing._kernels` (unchanged), 3-D
worlds (boxes, vertical prisms and cylinders, spheres) those of
:mod:`swarmnav.sensing._kernels3d`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from swarmnav.sensing._kernels import (
    as_points,
    geom_arrays,
    nearest_kernel,
    points_inside_kernel,
    segments_blocked_kernel,
    surfaces_within_kernel,
)
from swarmnav.sensing._kernels3d import (
    geom_arrays3d,
    nearest3d_kernel,
    points_inside3d_kernel,
    segments_blocked3d_kernel,
)

from swarmnav.sensing.index3d import (
    box_index,
    nearest3d_indexed_kernel,
    points_inside3d_indexed_kernel,
    segments_blocked3d_indexed_kernel,
)
from swarmnav.sensing.index import (
    nearest_indexed_kernel,
    points_inside_indexed_kernel,
    polygon_index,
    segments_blocked_indexed_kernel,
)

if TYPE_CHECKING:
    from swarmnav.world.obstacles import Geometry

_NO_DIR = np.zeros((0, 2))
_NO_DIR3 = np.zeros((0, 3))


def as_points_nd(x, dim: int, name: str = "points") -> np.ndarray:
    """``x`` as a contiguous float64 (M, dim) array, or ValueError naming ``name`` and the shape."""
    a = np.ascontiguousarray(x, dtype=np.float64)
    if a.ndim != 2 or a.shape[1] != dim:
        raise ValueError(f"{name} must have shape (M, {dim}) for a {dim}-D world, got {a.shape}")
    return a


def signed_distance(geom: Geometry, points: np.ndarray) -> np.ndarray:
    """Signed Euclidean distance [m] from each point to the obstacle boundaries.

    Positive outside (distance to the nearest obstacle, i.e. exactly to their union), zero on a
    boundary, negative inside: minus the depth in the containing obstacle (the deepest one if
    obstacles overlap, which then is a lower bound of the depth in their union).

    In 3-D each obstacle's signed distance is exact: a footprint (signed planar distance ``d2``)
    extruded over ``[z0, z1]`` has, with ``dz = max(z0 - z, z - z1)``,
    ``sqrt(max(d2, 0)^2 + max(dz, 0)^2)`` if ``d2 > 0`` or ``dz > 0``, else ``max(d2, dz)``.

    Args:
        geom: obstacles of the world.
        points: (M, d) query points [m], ``d = geom.dim``.

    Returns:
        (M,) float64; ``+inf`` everywhere for an empty geometry.
    """
    if geom.dim == 3:
        pts = as_points_nd(points, 3)
        d = np.empty(pts.shape[0])
        _nearest3d(geom, pts, d, _NO_DIR3, False)
        return d
    pts = as_points(points)
    d = np.empty(pts.shape[0])
    _nearest(geom, pts, d, _NO_DIR, False)
    return d


def _nearest(geom: Geometry, pts: np.ndarray, d: np.ndarray, v: np.ndarray, want_dir: bool) -> None:
    index = polygon_index(geom)
    if index is not None:  # a large map: the same distances, visiting only the polygons near each point
        nearest_indexed_kernel(*geom_arrays(geom), *index, pts, d, v, want_dir)
    else:
        nearest_kernel(*geom_arrays(geom), pts, d, v, want_dir)


def _nearest3d(geom: Geometry, pts: np.ndarray, d: np.ndarray, v: np.ndarray, want_dir: bool) -> None:
    index = box_index(geom)
    if index is not None:  # a large 3-D map: the same values, visiting only the primitives near each point
        nearest3d_indexed_kernel(*geom_arrays3d(geom), *index, pts, d, v, want_dir)
    else:
        nearest3d_kernel(*geom_arrays3d(geom), pts, d, v, want_dir)


def nearest_obstacle(geom: Geometry, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Signed distance and unit direction toward the nearest obstacle boundary point.

    Args:
        geom: obstacles of the world.
        points: (M, d) query points [m], ``d = geom.dim``.

    Returns:
        ``(dist, direction)``: ``dist`` (M,) as :func:`signed_distance`; ``direction`` (M, d)
        unit vector from the point toward its nearest boundary point (outward for a point
        inside an obstacle, toward +x at a circle's centre, a cylinder's axis or a sphere's
        centre), zeros where the geometry is empty or the distance is exactly 0.
    """
    if geom.dim == 3:
        pts = as_points_nd(points, 3)
        d = np.empty(pts.shape[0])
        v = np.empty((pts.shape[0], 3))
        _nearest3d(geom, pts, d, v, True)
        return d, v
    pts = as_points(points)
    d = np.empty(pts.shape[0])
    v = np.empty((pts.shape[0], 2))
    _nearest(geom, pts, d, v, True)
    return d, v


def surfaces_within(geom: Geometry, points: np.ndarray, reach: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each obstacle whose boundary lies within ``reach`` [m] of a point, one row per (point,
    obstacle) pair: not only the nearest obstacle, as :func:`nearest_obstacle` gives, but every
    one a point must keep clear of (a point between two trunks has a row for each). Planar worlds.

    Args:
        geom: obstacles of a 2-D world.
        points: (M, 2) query points [m].
        reach: [m] rows farther than this are left out; a point inside an obstacle always has its row.

    Returns:
        ``(point, dist, direction)``: the row's point index (Q,) int64, ascending; the point's
        signed distance to that obstacle alone (Q,) [m]; the unit direction (Q, 2) from the point
        toward that obstacle's nearest boundary point (as :func:`nearest_obstacle`'s).
    """
    if geom.dim != 2:
        raise ValueError("surfaces_within takes a planar world")
    pts = as_points(points)
    arrays = geom_arrays(geom)
    dummy_i, dummy_d, dummy_v = np.zeros(0, np.int64), np.zeros(0), np.zeros((0, 2))
    q = surfaces_within_kernel(*arrays, pts, float(reach), dummy_i, dummy_d, dummy_v, False)
    point, dist, direction = np.empty(q, np.int64), np.empty(q), np.empty((q, 2))
    surfaces_within_kernel(*arrays, pts, float(reach), point, dist, direction, True)
    return point, dist, direction


def points_inside(geom: Geometry, points: np.ndarray) -> np.ndarray:
    """(M,) bool: the point (M, d) [m], ``d = geom.dim``, is in collision, i.e. strictly inside a
    polygon (even-odd rule) or a circle, or on any boundary; in 3-D inside or on a prism, a
    cylinder or a sphere."""
    if geom.dim == 3:
        pts = as_points_nd(points, 3)
        out = np.empty(pts.shape[0], dtype=np.bool_)
        index = box_index(geom)
        if index is not None:
            points_inside3d_indexed_kernel(*geom_arrays3d(geom), *index, pts, out)
        else:
            points_inside3d_kernel(*geom_arrays3d(geom), pts, out)
        return out
    pts = as_points(points)
    out = np.empty(pts.shape[0], dtype=np.bool_)
    index = polygon_index(geom)
    if index is not None:
        points_inside_indexed_kernel(*geom_arrays(geom), *index, pts, out)
    else:
        points_inside_kernel(*geom_arrays(geom), pts, out)
    return out


def segments_blocked(geom: Geometry, p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """(M,) bool: the closed segment ``p[m] -> q[m]`` meets an obstacle (line of sight is blocked).

    True if the segment crosses or touches a polygon edge, comes within a circle's radius of
    its centre (touching included), or lies inside an obstacle. A zero-length segment is a
    point test. In 3-D the test is exact per primitive: the part of the segment inside a
    prism's or cylinder's z range is clipped and tested against the footprint in the plane;
    a sphere is met when the segment's nearest point to its centre is within the radius.

    Args:
        geom: obstacles of the world.
        p: (M, d) segment start points [m], ``d = geom.dim``.
        q: (M, d) segment end points [m].
    """
    if geom.dim == 3:
        a = as_points_nd(p, 3, "p")
        b = as_points_nd(q, 3, "q")
        if a.shape != b.shape:
            raise ValueError(f"p and q must have the same shape, got {a.shape} and {b.shape}")
        out = np.empty(a.shape[0], dtype=np.bool_)
        index = box_index(geom)
        if index is not None:
            segments_blocked3d_indexed_kernel(*geom_arrays3d(geom), *index, a, b, out)
        else:
            segments_blocked3d_kernel(*geom_arrays3d(geom), a, b, out)
        return out
    a = as_points(p, "p")
    b = as_points(q, "q")
    if a.shape != b.shape:
        raise ValueError(f"p and q must have the same shape, got {a.shape} and {b.shape}")
    out = np.empty(a.shape[0], dtype=np.bool_)
    index = polygon_index(geom)
    if index is not None:
        segments_blocked_indexed_kernel(*geom_arrays(geom), *index, a, b, out)
    else:
        segments_blocked_kernel(*geom_arrays(geom), a, b, out)
    return out
