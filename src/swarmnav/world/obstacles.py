"""Obstacle shapes and their flattened array form used by the sensing kernels.

Three shapes exist: axis-aligned boxes, circles and simple polygons. Boxes and polygons are
both stored as closed polygons (a box is the polygon of its four corners, counter-clockwise),
so every kernel handles exactly two primitives: polygon edges and circles.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True, slots=True)
class Box:
    """Axis-aligned rectangle ``[min_x, max_x] x [min_y, max_y]`` [m]."""

    min: tuple[float, float]
    max: tuple[float, float]

    def vertices(self) -> np.ndarray:
        (x0, y0), (x1, y1) = self.min, self.max
        return np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]], dtype=np.float64)

    def to_dict(self) -> dict:
        return {"type": "box", "min": list(self.min), "max": list(self.max)}


@dataclass(frozen=True, slots=True)
class Circle:
    """Disc of ``radius`` [m] around ``center`` [m]."""

    center: tuple[float, float]
    radius: float

    def to_dict(self) -> dict:
        return {"type": "circle", "center": list(self.center), "radius": self.radius}


@dataclass(frozen=True, slots=True)
class Polygon:
    """Simple polygon, vertices in order (either orientation) [m]."""

    points: tuple[tuple[float, float], ...]

    def vertices(self) -> np.ndarray:
        return np.asarray(self.points, dtype=np.float64)

    def to_dict(self) -> dict:
        return {"type": "polygon", "points": [list(p) for p in self.points]}


Obstacle = Box | Circle | Polygon


@dataclass(frozen=True, slots=True, eq=False)
class Geometry:
    """All obstacles of a world as flat arrays, the single input of every geometric kernel.

    Attributes:
        seg_a: (S, 2) edge start points [m]; edges of polygon ``p`` are
            ``seg_a[poly_offsets[p]:poly_offsets[p + 1]]`` in vertex order, closed.
        seg_b: (S, 2) edge end points [m].
        poly_offsets: (P + 1,) int64 offsets of each polygon's edges.
        circ_c: (C, 2) circle centres [m].
        circ_r: (C,) circle radii [m].
    """

    seg_a: np.ndarray
    seg_b: np.ndarray
    poly_offsets: np.ndarray
    circ_c: np.ndarray
    circ_r: np.ndarray
    bbox_lo: np.ndarray = field(repr=False)  # (P + C, 2) bounding boxes, polygons then circles
    bbox_hi: np.ndarray = field(repr=False)

    @property
    def n_polygons(self) -> int:
        return len(self.poly_offsets) - 1

    @property
    def n_circles(self) -> int:
        return len(self.circ_r)

    @property
    def is_empty(self) -> bool:
        return self.n_polygons == 0 and self.n_circles == 0

    @classmethod
    def from_obstacles(cls, obstacles: tuple[Obstacle, ...] | list[Obstacle]) -> Geometry:
        polys = [o.vertices() for o in obstacles if not isinstance(o, Circle)]
        circles = [o for o in obstacles if isinstance(o, Circle)]
        offsets = np.zeros(len(polys) + 1, dtype=np.int64)
        seg_a, seg_b, lo, hi = [], [], [], []
        for p, v in enumerate(polys):
            seg_a.append(v)
            seg_b.append(np.roll(v, -1, axis=0))
            offsets[p + 1] = offsets[p] + len(v)
            lo.append(v.min(axis=0))
            hi.append(v.max(axis=0))
        cc = np.array([c.center for c in circles], dtype=np.float64).reshape(-1, 2)
        cr = np.array([c.radius for c in circles], dtype=np.float64)
        for c, r in zip(cc, cr):
            lo.append(c - r)
            hi.append(c + r)
        cat = lambda xs: np.ascontiguousarray(np.concatenate(xs) if xs else np.zeros((0, 2)))  # noqa: E731
        return cls(
            seg_a=cat(seg_a),
            seg_b=cat(seg_b),
            poly_offsets=offsets,
            circ_c=np.ascontiguousarray(cc),
            circ_r=np.ascontiguousarray(cr),
            bbox_lo=np.array(lo, dtype=np.float64).reshape(-1, 2),
            bbox_hi=np.array(hi, dtype=np.float64).reshape(-1, 2),
        )


def polygon_is_simple(v: np.ndarray) -> bool:
    """True if the closed polygon ``v`` (M, 2) has >= 3 vertices, non-zero area and no
    self-intersections (non-adjacent edges do not touch)."""
    m = len(v)
    if m < 3:
        return False
    area2 = np.sum(v[:, 0] * np.roll(v[:, 1], -1) - np.roll(v[:, 0], -1) * v[:, 1])
    if abs(area2) < 1e-12:
        return False
    a, b = v, np.roll(v, -1, axis=0)
    for i in range(m):
        for j in range(i + 1, m):
            if j == i + 1 or (i == 0 and j == m - 1):
                continue
            if _segments_touch(a[i], b[i], a[j], b[j]):
                return False
    return True


def _segments_touch(p1, p2, q1, q2) -> bool:
    def orient(a, b, c):
        return (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])

    d1, d2 = orient(q1, q2, p1), orient(q1, q2, p2)
    d3, d4 = orient(p1, p2, q1), orient(p1, p2, q2)
    if ((d1 > 0) != (d2 > 0)) and ((d3 > 0) != (d4 > 0)) and d1 * d2 < 0 and d3 * d4 < 0:
        return True

    def on_seg(a, b, c):
        return (
            min(a[0], b[0]) - 1e-12 <= c[0] <= max(a[0], b[0]) + 1e-12
            and min(a[1], b[1]) - 1e-12 <= c[1] <= max(a[1], b[1]) + 1e-12
        )

    return (
        (abs(d1) < 1e-12 and on_seg(q1, q2, p1))
        or (abs(d2) < 1e-12 and on_seg(q1, q2, p2))
        or (abs(d3) < 1e-12 and on_seg(p1, p2, q1))
        or (abs(d4) < 1e-12 and on_seg(p1, p2, q2))
    )
