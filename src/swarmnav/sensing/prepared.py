"""Obstacle queries against one fixed geometry, prepared once for a method's hot loop.

:func:`swarmnav.sensing.lidar_ring` and :func:`swarmnav.sensing.segments_blocked` validate and
convert their inputs on every call, which is right for a user's one-off query. A method that
asks thousands of times per run against the same obstacles (HES: a LiDAR ring and up to
4N line-of-sight tests every step) prepares the geometry once here and has the results
written into buffers it owns; the answers are the same kernels', bit for bit.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from swarmnav.sensing._kernels import geom_arrays, lidar_kernel, nearest_kernel, segments_blocked_kernel
from swarmnav.sensing._kernels3d import geom_arrays3d, nearest3d_kernel, range_scan_kernel, segments_blocked3d_kernel
from swarmnav.sensing.index3d import (
    box_index,
    nearest3d_indexed_kernel,
    range_scan_indexed_kernel,
    segments_blocked3d_indexed_kernel,
)
from swarmnav.sensing.index import (
    lidar_indexed_kernel,
    nearest_indexed_kernel,
    polygon_index,
    segments_blocked_indexed_kernel,
)

if TYPE_CHECKING:
    from swarmnav.world.obstacles import Geometry


_NO_DIR = np.zeros((0, 2))
_NO_DIR3 = np.zeros((0, 3))


class PreparedGeometry:
    """A ``Geometry`` converted once to the sensing kernels' flat arrays.

    Inputs are not validated: positions and segment ends must be C-contiguous float64
    (M, d) arrays, ``d = geom.dim``, and ``out`` a buffer of the documented shape and dtype.
    """

    __slots__ = ("geom", "_arrays", "_arrays3d", "_index", "_index3d")

    def __init__(self, geom: Geometry):
        self.geom = geom
        self._arrays = geom_arrays(geom) if geom.dim == 2 else None
        self._arrays3d = geom_arrays3d(geom) if geom.dim == 3 else None
        self._index = polygon_index(geom)  # None but for a large planar map (sensing.index)
        self._index3d = box_index(geom)  # None but for a large 3-D map (sensing.index3d)

    @property
    def is_empty(self) -> bool:
        return self.geom.is_empty

    @property
    def planar_arrays(self) -> tuple[np.ndarray, ...]:
        """The seven arrays a planar geometry is passed to the compiled queries as (the leading
        arguments of :func:`swarmnav.sensing.segments_blocked_kernel`), for a caller's own
        compiled pass; read only."""
        if self._arrays is None:
            raise ValueError("planar_arrays: this is a 3-D geometry")
        return self._arrays

    def lidar_into(self, positions: np.ndarray, cos_t: np.ndarray, sin_t: np.ndarray, max_range: float,
                   out: np.ndarray) -> np.ndarray:
        """``out`` (N, R) float64 <- the LiDAR ranges [m] of rays (cos_t, sin_t) from every agent,
        as :func:`swarmnav.sensing.lidar_ring` (``max_range`` where nothing is hit). Planar only."""
        if self._arrays is None:
            raise ValueError("lidar_into is the planar ring; use range_into in a 3-D world")
        if self._index is not None:
            lidar_indexed_kernel(*self._arrays, *self._index, positions, cos_t, sin_t, float(max_range), out)
        else:
            lidar_kernel(*self._arrays, positions, cos_t, sin_t, float(max_range), out)
        return out

    def blocked_into(self, p: np.ndarray, q: np.ndarray, out: np.ndarray) -> np.ndarray:
        """``out`` (M,) bool <- whether segment p[m] -> q[m] meets an obstacle, as
        :func:`swarmnav.sensing.segments_blocked` (either dimension)."""
        if self._index3d is not None:
            segments_blocked3d_indexed_kernel(*self._arrays3d, *self._index3d, p, q, out)
            return out
        if self._arrays3d is not None:
            segments_blocked3d_kernel(*self._arrays3d, p, q, out)
            return out
        if self._index is not None:
            segments_blocked_indexed_kernel(*self._arrays, *self._index, p, q, out)
            return out
        segments_blocked_kernel(*self._arrays, p, q, out)
        return out

    def distance_into(self, points: np.ndarray, out: np.ndarray) -> np.ndarray:
        """``out`` (M,) float64 <- the signed distance [m] of every point (M, d) to the obstacles, as
        :func:`swarmnav.sensing.signed_distance` (either dimension; the geometry must not be empty)."""
        if self._index3d is not None:
            nearest3d_indexed_kernel(*self._arrays3d, *self._index3d, points, out, _NO_DIR3, False)
        elif self._arrays3d is not None:
            nearest3d_kernel(*self._arrays3d, points, out, _NO_DIR3, False)
        elif self._index is not None:
            nearest_indexed_kernel(*self._arrays, *self._index, points, out, _NO_DIR, False)
        else:
            nearest_kernel(*self._arrays, points, out, _NO_DIR, False)
        return out

    def range_into(self, positions: np.ndarray, directions: np.ndarray, max_range: float,
                   out: np.ndarray) -> np.ndarray:
        """``out`` (N, R) float64 <- the range [m] along unit ``directions`` (R, 3) from every
        position (N, 3), as :func:`swarmnav.sensing.range_scan` in a 3-D world."""
        if self._arrays3d is None:
            raise ValueError("range_into needs a 3-D world; use lidar_into in the plane")
        if self._index3d is not None:
            range_scan_indexed_kernel(*self._arrays3d, *self._index3d, positions, directions, float(max_range), out)
        else:
            range_scan_kernel(*self._arrays3d, positions, directions, float(max_range), out)
        return out
