"""Euclidean signed distance field (ESDF) on a regular grid, for fast distance/gradient lookups.

Node values are the exact signed distance of :func:`swarmnav.sensing.signed_distance` (so the
grid and the exact queries share one definition); between nodes the field is the bilinear
interpolant, whose gradient is returned analytically.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from swarmnav.sensing._kernels import as_points, esdf_query_kernel
from swarmnav.sensing.geometry import signed_distance

if TYPE_CHECKING:
    from swarmnav.world.obstacles import Geometry


@dataclass(frozen=True, slots=True, eq=False)
class Esdf:
    """Signed distance sampled at grid nodes.

    Attributes:
        origin: (2,) position [m] of node ``values[0, 0]``.
        resolution: node spacing [m].
        values: (ny, nx) signed distance [m]; node ``values[iy, ix]`` sits at
            ``origin + resolution * (ix, iy)``. ``+inf`` everywhere for an empty world.
    """

    origin: np.ndarray
    resolution: float
    values: np.ndarray

    @classmethod
    def build(cls, geom: Geometry, bounds: tuple[float, float, float, float],
              resolution: float = 0.1) -> Esdf:
        """Sample the exact signed distance on a grid covering ``bounds = (xmin, ymin, xmax, ymax)`` [m].

        The grid starts at ``(xmin, ymin)`` and has ``ceil(extent / resolution) + 1`` nodes per
        axis (at least 2), so it covers the bounds, possibly overshooting by < one cell.
        """
        xmin, ymin, xmax, ymax = (float(b) for b in bounds)
        resolution = float(resolution)
        if not (resolution > 0.0 and math.isfinite(resolution)):
            raise ValueError(f"resolution must be finite and > 0, got {resolution}")
        if not (xmax > xmin and ymax > ymin):
            raise ValueError(f"bounds must satisfy xmin < xmax and ymin < ymax, got {bounds}")
        # The 1e-9 slack keeps an extent that is a whole number of cells from gaining a node
        # through rounding (e.g. 10 / 0.1 = 100.00000000000001).
        nx = max(int(math.ceil((xmax - xmin) / resolution - 1e-9)) + 1, 2)
        ny = max(int(math.ceil((ymax - ymin) / resolution - 1e-9)) + 1, 2)
        xs = xmin + resolution * np.arange(nx)
        ys = ymin + resolution * np.arange(ny)
        gx, gy = np.meshgrid(xs, ys)  # (ny, nx), row = y
        nodes = np.stack([gx.ravel(), gy.ravel()], axis=1)
        values = signed_distance(geom, nodes).reshape(ny, nx)
        values.setflags(write=False)
        origin = np.array([xmin, ymin])
        origin.setflags(write=False)
        return cls(origin=origin, resolution=resolution, values=values)

    @property
    def shape(self) -> tuple[int, int]:
        """``(ny, nx)`` node counts."""
        return self.values.shape

    def query(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Bilinear value [m] and its analytic gradient at ``points`` (M, 2) [m].

        Points outside the grid are clamped to the border: they get the value and gradient
        of the interpolant at the clamped point (the gradient is kept, not zeroed, so it still
        points away from obstacles).

        Returns:
            ``(value (M,), grad (M, 2))``; in cells with a non-finite corner (empty world)
            the value is the smallest corner value and the gradient is zero.
        """
        pts = as_points(points)
        val = np.empty(pts.shape[0])
        grad = np.empty((pts.shape[0], 2))
        esdf_query_kernel(np.ascontiguousarray(self.values), float(self.origin[0]), float(self.origin[1]),
                          float(self.resolution), pts, val, grad)
        return val, grad
