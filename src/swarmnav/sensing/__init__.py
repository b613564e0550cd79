"""Sensing: LiDAR ring, point/segment queries against obstacles, and neighbour search.

All functions take flat arrays (a ``Geometry`` and (N, 2) positions) and return arrays.
"""

from swarmnav.sensing.geometry import nearest_obstacle, points_inside, segments_blocked, signed_distance
from swarmnav.sensing.lidar import lidar_ring
from swarmnav.sensing.neighbors import neighbor_lists, neighbor_pairs, pairwise_min_distance
from swarmnav.sensing.prepared import PreparedGeometry

__all__ = [
    "PreparedGeometry",
    "lidar_ring",
    "nearest_obstacle",
    "neighbor_lists",
    "neighbor_pairs",
    "pairwise_min_distance",
    "points_inside",
    "segments_blocked",
    "signed_distance",
]
