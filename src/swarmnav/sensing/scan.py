"""Range scan along arbitrary ray directions: the range sensor of a 3-D world.

Each ray from a position reads the distance [m] to the first closed obstacle along it, or
``max_range`` when there is none within range. Exact per primitive (ray against a prism's
slab and footprint edges, a cylinder's slab and disc, a sphere), fused by the minimum. The
planar ring of evenly spaced rays stays :func:`swarmnav.sensing.lidar_ring`.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from swarmnav.sensing._kernels3d import geom_arrays3d, planar_as_3d, range_scan_kernel
from swarmnav.sensing.index3d import box_index, range_scan_indexed_kernel

if TYPE_CHECKING:
    from swarmnav.world.obstacles import Geometry


def range_scan(geom: Geometry, positions: np.ndarray, directions: np.ndarray, max_range: float) -> np.ndarray:
    """Distance [m] to the first obstacle along every ray of every position.

    Works in both dimensions with one kernel: a planar world is served as its footprints
    extruded over all z (positions and directions (·, 2) are then read at z = 0), so in 2-D
    the result equals :func:`swarmnav.sensing.lidar_ring` for the same ray directions up to
    rounding.

    Args:
        geom: obstacles of the world.
        positions: (N, d) sensor positions [m], ``d = geom.dim``.
        directions: (R, d) unit ray directions (normalised here; zero vectors are an error).
        max_range: sensor range [m]; rays that hit nothing closer read exactly this.

    Returns:
        (N, R) float64 in ``[0, max_range]``; all zeros for a position in collision (inside
        or on the boundary of an obstacle).

    Raises:
        ValueError: bad shapes, zero or non-finite directions, ``max_range <= 0`` or
            non-finite positions.
    """
    d = geom.dim
    pos = np.ascontiguousarray(positions, dtype=np.float64)
    u = np.ascontiguousarray(directions, dtype=np.float64)
    if pos.ndim != 2 or pos.shape[1] != d:
        raise ValueError(f"positions must have shape (N, {d}) for a {d}-D world, got {pos.shape}")
    if u.ndim != 2 or u.shape[1] != d:
        raise ValueError(f"directions must have shape (R, {d}) for a {d}-D world, got {u.shape}")
    max_range = float(max_range)
    if not (max_range > 0.0 and math.isfinite(max_range)):
        raise ValueError(f"max_range must be finite and > 0, got {max_range}")
    if not np.isfinite(pos).all():
        raise ValueError("positions must be finite")
    norm = np.linalg.norm(u, axis=1)
    if not (np.isfinite(norm).all() and (norm > 0.0).all()):
        raise ValueError("directions must be finite and non-zero")
    u = u / norm[:, None]
    if d == 2:
        arrays = planar_as_3d(geom)
        pos = np.ascontiguousarray(np.column_stack([pos, np.zeros(len(pos))]))
        u = np.column_stack([u, np.zeros(len(u))])
    else:
        arrays = geom_arrays3d(geom)
    u = np.ascontiguousarray(u)
    out = np.empty((pos.shape[0], u.shape[0]))
    index = box_index(geom) if d == 3 else None
    if index is not None:  # a large 3-D map: each ray walks the grid cells under it (sensing.index3d)
        range_scan_indexed_kernel(*arrays, *index, pos, u, max_range, out)
    else:
        range_scan_kernel(*arrays, pos, u, max_range, out)
    return out
