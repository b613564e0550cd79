"""Grid work of the LSC planner on a robot's occupancy map: safe flight corridor boxes grown
from the previous plan's segments, and the line-of-sight test of the goal planning.

The map is the robot's :class:`~swarmnav.planning.maps.OccupancyMaps` grid, whose cells of class
``blocked`` or more lie within the inflated obstacles (body radius + margin). A 2-D grid (ny, nx)
is handled as (1, ny, nx). Indices here are (x, y, z) order; the arrays are (z, y, x).
"""

from __future__ import annotations

import numpy as np
from numba import njit


def as3(grid: np.ndarray) -> np.ndarray:
    """A (ny, nx) grid as (1, ny, nx); a voxel grid unchanged."""
    return grid[None] if grid.ndim == 2 else grid


def to_index(p: np.ndarray, origin: np.ndarray, res: float, shape_xyz: np.ndarray) -> np.ndarray:
    """(..., 3) int64 (x, y, z) cell indices of points ``p`` (..., D), clamped to the grid."""
    p = np.asarray(p, dtype=float)
    D = p.shape[-1]
    idx = np.zeros(p.shape[:-1] + (3,), dtype=np.int64)
    idx[..., :D] = np.clip(np.rint((p - origin) / res), 0, shape_xyz[:D] - 1).astype(np.int64)
    return idx


@njit(cache=True)
def _slab_free(occ, lo, hi, axis, at, blocked):
    """Whether every cell of the box [lo, hi] with index ``at`` on ``axis`` is free."""
    a0, a1 = lo.copy(), hi.copy()
    a0[axis] = at
    a1[axis] = at
    for z in range(a0[2], a1[2] + 1):
        for y in range(a0[1], a1[1] + 1):
            for x in range(a0[0], a1[0] + 1):
                if occ[z, y, x] >= blocked:
                    return False
    return True


@njit(cache=True)
def grow_box(occ, lo, hi, lim_lo, lim_hi, dims, blocked):
    """Grow the cell box [lo, hi] (x, y, z indices, inclusive) one cell per face in turn (x-, x+,
    y-, y+, ...), a face stopping at the first slab holding a blocked cell or at its limit
    [lim_lo, lim_hi]; returns the grown (lo, hi)."""
    lo = lo.copy()
    hi = hi.copy()
    active = np.ones(2 * dims, dtype=np.bool_)
    while active.any():
        for f in range(2 * dims):
            if not active[f]:
                continue
            axis = f // 2
            if f % 2 == 0:
                at = lo[axis] - 1
                if at < lim_lo[axis] or not _slab_free(occ, lo, hi, axis, at, blocked):
                    active[f] = False
                else:
                    lo[axis] = at
            else:
                at = hi[axis] + 1
                if at > lim_hi[axis] or not _slab_free(occ, lo, hi, axis, at, blocked):
                    active[f] = False
                else:
                    hi[axis] = at
    return lo, hi


@njit(cache=True)
def _segment_free(occ, origin, res, a, b, blocked, dims):
    """Whether the straight segment a -> b [m] crosses only free cells (sampled every res / 2)."""
    length = 0.0
    for d in range(dims):
        length += (b[d] - a[d]) ** 2
    length = np.sqrt(length)
    steps = int(length / (0.5 * res)) + 1
    nz, ny, nx = occ.shape
    lim = np.array([nx - 1, ny - 1, nz - 1])
    for s in range(steps + 1):
        w = s / steps
        idx = np.zeros(3, dtype=np.int64)
        for d in range(dims):
            v = int(np.rint((a[d] + w * (b[d] - a[d]) - origin[d]) / res))
            idx[d] = min(max(v, 0), lim[d])
        if occ[idx[2], idx[1], idx[0]] >= blocked:
            return False
    return True


@njit(cache=True)
def last_visible(occ, origin, res, start, path, blocked):
    """Index of the last point of ``path`` (P, D) [m] in line of sight from ``start`` [m] (the
    segment between them crosses only free cells), or -1 if none is."""
    dims = path.shape[1]
    for i in range(path.shape[0] - 1, -1, -1):
        if _segment_free(occ, origin, res, start, path[i], blocked, dims):
            return i
    return -1
