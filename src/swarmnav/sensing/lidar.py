"""Simulated 2-D LiDAR ring, the range sensor of the HES method.

Ray ``r`` of ``n_rays`` points at angle ``2 pi r / n_rays`` from +x, counter-clockwise; its
value is the distance [m] to the first obstacle boundary along the ray, or ``max_range`` if
there is none within range. The range is exact for polygon edges (ray-segment) and circles
(ray-circle), fused by the minimum over all obstacles.

An agent inside an obstacle or on its boundary (a collision) reads 0.0 on every ray.
Polygons must be simple (as scene validation enforces): the kernel skips edges that face
away from the agent, which is exact only for simple polygons.
"""

from __future__ import annotations

import math
from functools import lru_cache
from typing import TYPE_CHECKING

import numpy as np

from swarmnav.sensing._kernels import as_points, geom_arrays, lidar_kernel
from swarmnav.sensing.index import lidar_indexed_kernel, polygon_index

if TYPE_CHECKING:
    from swarmnav.world.obstacles import Geometry


@lru_cache(maxsize=16)
def ray_table(n_rays: int) -> tuple[np.ndarray, np.ndarray]:
    """Unit ray directions (cos, sin) for ``n_rays`` evenly spaced angles, read-only.

    Axis-aligned rays (angles that are multiples of pi/2) get exact 0/+-1 components, so a
    ray along a box edge in a box world is tested exactly rather than through cos(pi/2) ~ 6e-17.
    """
    r = np.arange(n_rays)
    theta = 2.0 * np.pi * r / n_rays
    c = np.cos(theta)
    s = np.sin(theta)
    axis = (4 * r) % n_rays == 0
    quarter = (4 * r[axis]) // n_rays
    c[axis] = np.array([1.0, 0.0, -1.0, 0.0])[quarter]
    s[axis] = np.array([0.0, 1.0, 0.0, -1.0])[quarter]
    c.setflags(write=False)
    s.setflags(write=False)
    return c, s


def lidar_ring(geom: Geometry, positions: np.ndarray, n_rays: int = 360, max_range: float = 20.0) -> np.ndarray:
    """Range of every ray of every agent's LiDAR ring [m].

    Args:
        geom: obstacles of the world.
        positions: (N, 2) agent positions [m].
        n_rays: rays per ring; ray ``r`` points at ``2 pi r / n_rays`` rad from +x, CCW.
        max_range: sensor range [m]; rays that hit nothing closer read exactly this.

    Returns:
        (N, n_rays) float64 ranges in ``[0, max_range]``; all zeros for an agent in collision
        (strictly inside a polygon by the even-odd rule, inside a circle, or on a boundary).

    Raises:
        ValueError: bad shapes, ``n_rays < 1``, ``max_range <= 0`` or non-finite positions.
    """
    n_rays = int(n_rays)
    if n_rays < 1:
        raise ValueError(f"n_rays must be >= 1, got {n_rays}")
    max_range = float(max_range)
    if not (max_range > 0.0 and math.isfinite(max_range)):
        raise ValueError(f"max_range must be finite and > 0, got {max_range}")
    pos = as_points(positions, "positions")
    # A non-finite position would turn the ray-index arithmetic into garbage indices.
    if not np.isfinite(pos).all():
        raise ValueError("positions must be finite")
    cos_t, sin_t = ray_table(n_rays)
    out = np.empty((pos.shape[0], n_rays), dtype=np.float64)
    index = polygon_index(geom)
    if index is not None:  # a large map: the same ranges, visiting only the polygons in range
        lidar_indexed_kernel(*geom_arrays(geom), *index, pos, cos_t, sin_t, max_range, out)
    else:
        lidar_kernel(*geom_arrays(geom), pos, cos_t, sin_t, max_range, out)
    return out


def fibonacci_sphere(n: int) -> np.ndarray:
    """(n, 3) unit vectors of the Fibonacci lattice: near-uniform directions over the sphere,
    each standing for the solid angle ``4 pi / n`` (deterministic, no random seed)."""
    k = np.arange(n) + 0.5
    z = 1.0 - 2.0 * k / n
    phi = np.pi * (3.0 - np.sqrt(5.0)) * k
    rho = np.sqrt(1.0 - z * z)
    return np.ascontiguousarray(np.column_stack([rho * np.cos(phi), rho * np.sin(phi), z]))
