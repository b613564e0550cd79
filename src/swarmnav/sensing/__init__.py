"""Sensing: LiDAR ring, point/segment queries against obstacles, and neighbour search.

All functions take flat arrays (a ``Geometry`` and (N, d) positions, ``d = geom.dim``) and
return arrays; the ESDF is a grid of the same signed distance with an interpolating query.
"""

from swarmnav.sensing._kernels import segments_blocked_kernel
from swarmnav.sensing.esdf import Esdf, esdf3d_query_kernel, esdf_query_kernel
from swarmnav.sensing.geometry import (
    nearest_obstacle,
    points_inside,
    segments_blocked,
    signed_distance,
    surfaces_within,
)
from swarmnav.sensing.lidar import fibonacci_sphere, lidar_ring, ray_table
from swarmnav.sensing.neighbors import neighbor_lists, neighbor_pairs, pairwise_min_distance
from swarmnav.sensing.prepared import PreparedGeometry
from swarmnav.sensing.scan import range_scan

__all__ = [
    "Esdf",
    "PreparedGeometry",
    "esdf3d_query_kernel",
    "esdf_query_kernel",
    "fibonacci_sphere",
    "lidar_ring",
    "nearest_obstacle",
    "neighbor_lists",
    "neighbor_pairs",
    "pairwise_min_distance",
    "points_inside",
    "range_scan",
    "ray_table",
    "segments_blocked",
    "segments_blocked_kernel",
    "signed_distance",
    "surfaces_within",
]
