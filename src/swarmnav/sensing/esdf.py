"""Euclidean signed distance field (ESDF) on a regular grid, for fast distance/gradient lookups.

Node values are the exact signed distance of :func:`swarmnav.sensing.signed_distance` (so the
grid and the exact queries share one definition); between nodes the field is the bilinear
(2-D) or trilinear (3-D) interpolant, whose gradient is returned analytically.

For compiled (numba) callers that query a field inside their own kernels, the query kernels
are public here: :func:`esdf_query_kernel` (2-D, bilinear) and :func:`esdf3d_query_kernel`
(3-D, trilinear), on ``Esdf.values``, ``origin`` and ``resolution``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from swarmnav.sensing._kernels import as_points, esdf_query_kernel
from swarmnav.sensing._kernels3d import esdf3d_build_kernel, esdf3d_query_kernel, geom_arrays3d
from swarmnav.sensing.geometry import as_points_nd, signed_distance
from swarmnav.sensing.index3d import box_index, esdf3d_indexed_build_kernel

if TYPE_CHECKING:
    from swarmnav.world.obstacles import Geometry


#: Nodes whose exact distance a planar build computes at once: their coordinates, query points
#: and distances take ~48 B a node, so a build's working memory stays near 25 MB beside the field
_BUILD_CHUNK = 1 << 19


def _nodes(lo: float, hi: float, resolution: float) -> int:
    # The 1e-9 slack keeps an extent that is a whole number of cells from gaining a node
    # through rounding (e.g. 10 / 0.1 = 100.00000000000001).
    return max(int(math.ceil((hi - lo) / resolution - 1e-9)) + 1, 2)


def grid_nodes(bounds: tuple[float, ...], resolution: float) -> float:
    """The number of nodes :meth:`Esdf.build` samples over ``bounds`` at ``resolution`` [m], as a
    float (``inf`` for a grid too large to count): the field holds 8 B a node."""
    d = len(bounds) // 2
    total = 1.0
    for a in range(d):
        cells = (bounds[d + a] - bounds[a]) / resolution
        total *= _nodes(bounds[a], bounds[d + a], resolution) if math.isfinite(cells) else math.inf
    return total


@dataclass(frozen=True, slots=True, eq=False)
class Esdf:
    """Signed distance sampled at grid nodes.

    Attributes:
        origin: (d,) position [m] of the first node ``values[0, 0]`` (2-D) or
            ``values[0, 0, 0]`` (3-D).
        resolution: node spacing [m], the same on every axis.
        values: signed distance [m] at the nodes, (ny, nx) in 2-D with node ``values[iy, ix]``
            at ``origin + resolution * (ix, iy)``, (nz, ny, nx) in 3-D with node
            ``values[iz, iy, ix]`` at ``origin + resolution * (ix, iy, iz)``. ``+inf``
            everywhere for an empty world.
    """

    origin: np.ndarray
    resolution: float
    values: np.ndarray

    @classmethod
    def build(cls, geom: Geometry, bounds: tuple[float, ...], resolution: float = 0.1) -> Esdf:
        """Sample the exact signed distance on a grid covering ``bounds`` [m].

        ``bounds`` is ``(xmin, ymin, xmax, ymax)`` for a planar world or
        ``(xmin, ymin, zmin, xmax, ymax, zmax)`` for a 3-D one (the scene's ``world.bounds``).
        The grid starts at the lower corner and has ``ceil(extent / resolution) + 1`` nodes per
        axis (at least 2), so it covers the bounds, possibly overshooting by < one cell.

        In 3-D every node value is exact (bit for bit :func:`signed_distance` at the node),
        computed column by column: each obstacle's planar part once per (x, y) column, then
        per node only the few obstacles that can be nearest in that column (see
        :func:`swarmnav.sensing._kernels3d.esdf3d_build_kernel`); a world indexed by
        :mod:`swarmnav.sensing.index3d` searches each node's nearest primitives through its grid.

        Raises:
            ValueError: bounds of the wrong length or inverted, bad resolution, or bounds whose
                dimension differs from the geometry's.
        """
        b = tuple(float(v) for v in bounds)
        resolution = float(resolution)
        if not (resolution > 0.0 and math.isfinite(resolution)):
            raise ValueError(f"resolution must be finite and > 0, got {resolution}")
        if len(b) not in (4, 6):
            raise ValueError(f"bounds must have 4 numbers (2-D) or 6 (3-D), got {len(b)}")
        d = len(b) // 2
        if d != geom.dim:
            raise ValueError(f"bounds are {d}-D but the geometry is {geom.dim}-D")
        lo, hi = np.array(b[:d]), np.array(b[d:])
        if not (np.all(np.isfinite(b)) and np.all(hi > lo)):
            raise ValueError(f"bounds must be finite with every min < max, got {bounds}")
        if d == 2:
            xmin, ymin, xmax, ymax = b
            nx = _nodes(xmin, xmax, resolution)
            ny = _nodes(ymin, ymax, resolution)
            xs = xmin + resolution * np.arange(nx)
            ys = ymin + resolution * np.arange(ny)
            values = np.empty((ny, nx))
            rows = max(1, _BUILD_CHUNK // nx)  # a block of rows at a time: the field is the memory it takes
            for r in range(0, ny, rows):
                gx, gy = np.meshgrid(xs, ys[r : r + rows])  # (rows, nx), row = y
                nodes = np.stack([gx.ravel(), gy.ravel()], axis=1)
                values[r : r + rows] = signed_distance(geom, nodes).reshape(-1, nx)
        else:
            n = [_nodes(lo[a], hi[a], resolution) for a in range(3)]
            values = np.empty((n[2], n[1], n[0]))
            index = box_index(geom)
            if index is not None:  # a large 3-D map: each node searches the grid cells round it
                esdf3d_indexed_build_kernel(*geom_arrays3d(geom), *index, lo[0], lo[1], lo[2], resolution, values)
            else:
                esdf3d_build_kernel(*geom_arrays3d(geom), lo[0], lo[1], lo[2], resolution, values)
        values.setflags(write=False)
        origin = lo.copy()
        origin.setflags(write=False)
        return cls(origin=origin, resolution=resolution, values=values)

    @property
    def dim(self) -> int:
        """2 or 3."""
        return self.values.ndim

    @property
    def shape(self) -> tuple[int, ...]:
        """Node counts, ``(ny, nx)`` or ``(nz, ny, nx)``."""
        return self.values.shape

    def query(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Interpolated value [m] and its analytic gradient at ``points`` (M, d) [m].

        Bilinear in 2-D, trilinear in 3-D. Points outside the grid are clamped to the border:
        they get the value and gradient of the interpolant at the clamped point (the gradient
        is kept, not zeroed, so it still points away from obstacles).

        Returns:
            ``(value (M,), grad (M, d))``; in cells with a non-finite corner (empty world)
            the value is the smallest corner value and the gradient is zero.
        """
        if self.values.ndim == 3:
            pts = as_points_nd(points, 3)
            val = np.empty(pts.shape[0])
            grad = np.empty((pts.shape[0], 3))
            o = self.origin
            esdf3d_query_kernel(self.values, float(o[0]), float(o[1]), float(o[2]), float(self.resolution),
                                pts, val, grad)
            return val, grad
        pts = as_points(points)
        val = np.empty(pts.shape[0])
        grad = np.empty((pts.shape[0], 2))
        esdf_query_kernel(np.ascontiguousarray(self.values), float(self.origin[0]), float(self.origin[1]),
                          float(self.resolution), pts, val, grad)
        return val, grad
