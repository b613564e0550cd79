"""Obstacle shapes and their flattened array form used by the sensing kernels.

Planar worlds have three shapes: axis-aligned boxes, circles and simple polygons. Boxes and
polygons are both stored as closed polygons (a box is the polygon of its four corners,
counter-clockwise), so every planar kernel handles exactly two primitives: polygon edges and
circles.

Three-dimensional worlds have four shapes: axis-aligned boxes, vertical cylinders, spheres
and vertical prisms (a polygon extruded over ``z = [z0, z1]``). A box is the prism of its
footprint and a cylinder a disc extruded over its ``z`` range, so the 3-D kernels handle three
primitives: prisms (polygon edges + a z range), vertical cylinders (circle + a z range) and
spheres. The footprint arrays are the planar ones, so a kernel written for the plane reads
the footprint of a 3-D world unchanged.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True, slots=True)
class Box:
    """Axis-aligned rectangle ``[min_x, max_x] x [min_y, max_y]`` [m], or in a 3-D world the
    box ``[min_x, max_x] x [min_y, max_y] x [min_z, max_z]`` (``min``/``max`` of three numbers)."""

    min: tuple[float, ...]
    max: tuple[float, ...]

    @property
    def dim(self) -> int:
        return len(self.min)

    @property
    def z(self) -> tuple[float, float] | None:
        """Vertical extent ``(z0, z1)`` [m] of a 3-D box; None in the plane."""
        return (self.min[2], self.max[2]) if len(self.min) == 3 else None

    def vertices(self) -> np.ndarray:
        """Footprint corners (4, 2), counter-clockwise [m]."""
        (x0, y0), (x1, y1) = self.min[:2], self.max[:2]
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
    """Simple polygon, vertices in order (either orientation) [m]; in a 3-D world the vertical
    prism of that footprint over ``z = (z0, z1)`` [m]."""

    points: tuple[tuple[float, float], ...]
    z: tuple[float, float] | None = None

    @property
    def dim(self) -> int:
        return 2 if self.z is None else 3

    def vertices(self) -> np.ndarray:
        return np.asarray(self.points, dtype=np.float64)

    def to_dict(self) -> dict:
        d = {"type": "polygon", "points": [list(p) for p in self.points]}
        if self.z is not None:
            d["z"] = list(self.z)
        return d


@dataclass(frozen=True, slots=True)
class Cylinder:
    """Vertical solid cylinder (3-D only): disc of ``radius`` [m] around ``center = (x, y)`` [m]
    extruded over ``z = (z0, z1)`` [m] (a tree trunk, a pillar)."""

    center: tuple[float, float]
    radius: float
    z: tuple[float, float]

    dim = 3

    def to_dict(self) -> dict:
        return {"type": "cylinder", "center": list(self.center), "radius": self.radius, "z": list(self.z)}


@dataclass(frozen=True, slots=True)
class Sphere:
    """Solid ball (3-D only) of ``radius`` [m] around ``center = (x, y, z)`` [m]."""

    center: tuple[float, float, float]
    radius: float

    dim = 3

    def to_dict(self) -> dict:
        return {"type": "sphere", "center": list(self.center), "radius": self.radius}


Obstacle = Box | Circle | Polygon | Cylinder | Sphere


def slice_at(obstacles, z: float) -> tuple:
    """The planar obstacles a horizontal plane at altitude ``z`` [m] cuts from 3-D obstacles.

    A box or prism whose closed z range holds ``z`` gives its footprint (a 2-D box or polygon),
    a cylinder its disc, a sphere the disc of radius ``sqrt(r^2 - (z - z_c)^2)`` (dropped when
    the plane only touches it); everything else is above or below the plane.
    """
    out: list = []
    for o in obstacles:
        if isinstance(o, Sphere):
            dz = z - o.center[2]
            if abs(dz) < o.radius:
                out.append(Circle((o.center[0], o.center[1]), float(np.sqrt(o.radius**2 - dz * dz))))
            continue
        zr = o.z if isinstance(o, (Box, Polygon, Cylinder)) else None
        if zr is None:
            out.append(o)  # already planar
        elif zr[0] <= z <= zr[1]:
            if isinstance(o, Box):
                out.append(Box(tuple(o.min[:2]), tuple(o.max[:2])))
            elif isinstance(o, Cylinder):
                out.append(Circle(tuple(o.center), o.radius))
            else:
                out.append(Polygon(o.points))
    return tuple(out)


@dataclass(frozen=True, slots=True, eq=False)
class Geometry:
    """All obstacles of a world as flat arrays, the single input of every geometric kernel.

    Attributes:
        seg_a: (S, 2) edge start points [m]; edges of polygon ``p`` are
            ``seg_a[poly_offsets[p]:poly_offsets[p + 1]]`` in vertex order, closed. In 3-D,
            the footprints of boxes and prisms.
        seg_b: (S, 2) edge end points [m].
        poly_offsets: (P + 1,) int64 offsets of each polygon's edges.
        circ_c: (C, 2) circle centres [m] (3-D: cylinder axes).
        circ_r: (C,) circle radii [m].
        bbox_lo: (P + C [+ B], dim) bounding boxes [m]: polygons, then circles, then (3-D) spheres.
        bbox_hi: upper corners of the same boxes [m].
        dim: 2 for a planar world, 3 for a 3-D one.
        poly_z: (P, 2) vertical extent ``[z0, z1]`` of each prism [m] (3-D only; (0, 2) in 2-D).
        circ_z: (C, 2) vertical extent of each cylinder [m] (3-D only; (0, 2) in 2-D).
        sph_c: (B, 3) sphere centres [m] (3-D only).
        sph_r: (B,) sphere radii [m].
    """

    seg_a: np.ndarray
    seg_b: np.ndarray
    poly_offsets: np.ndarray
    circ_c: np.ndarray
    circ_r: np.ndarray
    bbox_lo: np.ndarray = field(repr=False)  # (P + C, 2) bounding boxes, polygons then circles
    bbox_hi: np.ndarray = field(repr=False)
    dim: int = 2
    poly_z: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)), repr=False)
    circ_z: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)), repr=False)
    sph_c: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)), repr=False)
    sph_r: np.ndarray = field(default_factory=lambda: np.zeros(0), repr=False)

    @property
    def n_polygons(self) -> int:
        return len(self.poly_offsets) - 1

    @property
    def n_circles(self) -> int:
        return len(self.circ_r)

    @property
    def n_spheres(self) -> int:
        return len(self.sph_r)

    @property
    def is_empty(self) -> bool:
        return self.n_polygons == 0 and self.n_circles == 0 and self.n_spheres == 0

    @classmethod
    def from_obstacles(cls, obstacles: tuple[Obstacle, ...] | list[Obstacle], dim: int = 2) -> Geometry:
        """Flatten ``obstacles`` of a ``dim``-dimensional world (2 or 3) into kernel arrays."""
        if dim == 3:
            return cls._from_obstacles_3d(obstacles)
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

    @classmethod
    def _from_obstacles_3d(cls, obstacles) -> Geometry:
        prisms = [o for o in obstacles if isinstance(o, (Box, Polygon))]
        cyls = [o for o in obstacles if isinstance(o, Cylinder)]
        balls = [o for o in obstacles if isinstance(o, Sphere)]
        others = [o for o in obstacles if not isinstance(o, (Box, Polygon, Cylinder, Sphere))]
        if others or any(o.z is None for o in prisms):
            raise ValueError("a 3-D geometry takes 3-D boxes, prisms (polygons with z), cylinders and spheres only")
        flat = cls.from_obstacles(
            [Polygon(tuple(map(tuple, o.vertices()))) for o in prisms] + [Circle(o.center, o.radius) for o in cyls]
        )
        zr = lambda xs: np.array([o.z for o in xs], dtype=np.float64).reshape(-1, 2)  # noqa: E731
        poly_z, circ_z = zr(prisms), zr(cyls)
        sph_c = np.array([o.center for o in balls], dtype=np.float64).reshape(-1, 3)
        sph_r = np.array([o.radius for o in balls], dtype=np.float64)
        lo = np.vstack([np.column_stack([flat.bbox_lo, np.concatenate([poly_z[:, 0], circ_z[:, 0]])]),
                        sph_c - sph_r[:, None]])
        hi = np.vstack([np.column_stack([flat.bbox_hi, np.concatenate([poly_z[:, 1], circ_z[:, 1]])]),
                        sph_c + sph_r[:, None]])
        return cls(
            seg_a=flat.seg_a, seg_b=flat.seg_b, poly_offsets=flat.poly_offsets, circ_c=flat.circ_c,
            circ_r=flat.circ_r, bbox_lo=np.ascontiguousarray(lo), bbox_hi=np.ascontiguousarray(hi), dim=3,
            poly_z=np.ascontiguousarray(poly_z), circ_z=np.ascontiguousarray(circ_z),
            sph_c=np.ascontiguousarray(sph_c), sph_r=np.ascontiguousarray(sph_r),
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
