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

from swarmnav.sensing._kernels import geom_arrays, lidar_kernel, segments_blocked_kernel

if TYPE_CHECKING:
    from swarmnav.world.obstacles import Geometry


class PreparedGeometry:
    """A ``Geometry`` converted once to the sensing kernels' flat arrays.

    Inputs are not validated: positions and segment ends must be C-contiguous float64
    (M, 2) arrays and ``out`` a buffer of the documented shape and dtype.
    """

    __slots__ = ("geom", "_arrays")

    def __init__(self, geom: Geometry):
        self.geom = geom
        self._arrays = geom_arrays(geom)

    @property
    def is_empty(self) -> bool:
        return self.geom.is_empty

    def lidar_into(self, positions: np.ndarray, cos_t: np.ndarray, sin_t: np.ndarray, max_range: float,
                   out: np.ndarray) -> np.ndarray:
        """``out`` (N, R) float64 <- the LiDAR ranges [m] of rays (cos_t, sin_t) from every agent,
        as :func:`swarmnav.sensing.lidar_ring` (``max_range`` where nothing is hit)."""
        lidar_kernel(*self._arrays, positions, cos_t, sin_t, float(max_range), out)
        return out

    def blocked_into(self, p: np.ndarray, q: np.ndarray, out: np.ndarray) -> np.ndarray:
        """``out`` (M,) bool <- whether segment p[m] -> q[m] meets an obstacle, as
        :func:`swarmnav.sensing.segments_blocked`."""
        segments_blocked_kernel(*self._arrays, p, q, out)
        return out
