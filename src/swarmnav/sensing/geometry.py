"""Point and segment queries against the obstacles: signed distance, nearest boundary point,
inside test and line-of-sight blocking.

Obstacles are closed sets: a point on a boundary is in collision and a segment that only
touches a boundary is blocked. Kernels live in :mod:`swarmnav.sensing._kernels`.
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
)

if TYPE_CHECKING:
    from swarmnav.world.obstacles import Geometry

_NO_DIR = np.zeros((0, 2))


def signed_distance(geom: Geometry, points: np.ndarray) -> np.ndarray:
    """Signed Euclidean distance [m] from each point to the obstacle boundaries.

    Positive outside (distance to the nearest obstacle, i.e. exactly to their union), zero on a
    boundary, negative inside: minus the depth in the containing obstacle (the deepest one if
    obstacles overlap, which then is a lower bound of the depth in their union).

    Args:
        geom: obstacles of the world.
        points: (M, 2) query points [m].

    Returns:
        (M,) float64; ``+inf`` everywhere for an empty geometry.
    """
    pts = as_points(points)
    d = np.empty(pts.shape[0])
    nearest_kernel(*geom_arrays(geom), pts, d, _NO_DIR, False)
    return d


def nearest_obstacle(geom: Geometry, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Signed distance and unit direction toward the nearest obstacle boundary point.

    Args:
        geom: obstacles of the world.
        points: (M, 2) query points [m].

    Returns:
        ``(dist, direction)``: ``dist`` (M,) as :func:`signed_distance`; ``direction`` (M, 2)
        unit vector from the point toward its nearest boundary point (outward for a point
        inside an obstacle, toward +x at a circle's centre), zeros where the geometry is
        empty or the distance is exactly 0.
    """
    pts = as_points(points)
    d = np.empty(pts.shape[0])
    v = np.empty((pts.shape[0], 2))
    nearest_kernel(*geom_arrays(geom), pts, d, v, True)
    return d, v


def points_inside(geom: Geometry, points: np.ndarray) -> np.ndarray:
    """(M,) bool: the point is in collision, i.e. strictly inside a polygon (even-odd rule),
    inside a circle, or on any boundary."""
    pts = as_points(points)
    out = np.empty(pts.shape[0], dtype=np.bool_)
    points_inside_kernel(*geom_arrays(geom), pts, out)
    return out


def segments_blocked(geom: Geometry, p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """(M,) bool: the closed segment ``p[m] -> q[m]`` meets an obstacle (line of sight is blocked).

    True if the segment crosses or touches a polygon edge, comes within a circle's radius of
    its centre (touching included), or lies inside an obstacle. A zero-length segment is a
    point test.

    Args:
        geom: obstacles of the world.
        p: (M, 2) segment start points [m].
        q: (M, 2) segment end points [m].
    """
    a = as_points(p, "p")
    b = as_points(q, "q")
    if a.shape != b.shape:
        raise ValueError(f"p and q must have the same shape, got {a.shape} and {b.shape}")
    out = np.empty(a.shape[0], dtype=np.bool_)
    segments_blocked_kernel(*geom_arrays(geom), a, b, out)
    return out
