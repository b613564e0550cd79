"""Numba kernels behind the 3-D sensing functions: pure functions of flat 3-D ``Geometry`` arrays.

A 3-D world has three primitives (see :mod:`swarmnav.world.obstacles`): vertical prisms (a
footprint polygon extruded over ``[z0, z1]``; boxes are prisms), vertical cylinders (a disc
extruded over ``[z0, z1]``) and spheres. Conventions are those of :mod:`._kernels`:

* Obstacles are *closed* sets; footprint polygons use the same even-odd rule and on-edge
  test as the planar kernels, so a point's footprint is classified exactly as in 2-D.
* The signed distance of one obstacle is exact: with ``d2`` the signed planar distance to the
  footprint and ``dz = max(z0 - z, z - z1)``, an extruded solid has
  ``sd = sqrt(max(d2, 0)^2 + max(dz, 0)^2)`` if ``d2 > 0`` or ``dz > 0``, else ``max(d2, dz)``;
  a sphere has ``|p - c| - r``. The signed distance of the world is the minimum over
  obstacles: outside every obstacle that is the exact distance to their union, inside it is
  minus the depth in the deepest containing obstacle (the planar kernels' definition).
* Per obstacle ``k`` the bounding box is ``bbox_lo[k], bbox_hi[k]`` (3,), in the order prisms,
  cylinders, spheres; every loop culls on it.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from swarmnav.sensing._kernels import (
    OUTSIDE,
    _polygon_status,
    footprint_arrays,
    polygon_nearest,
    segment_meets_disc,
    segment_meets_polygon,
)


def geom_arrays3d(geom) -> tuple[np.ndarray, ...]:
    """The eleven 3-D ``Geometry`` arrays in kernel argument order, contiguous with fixed dtypes:
    ``seg_a, seg_b, poly_offsets, circ_c, circ_r, poly_z, circ_z, sph_c, sph_r, bbox_lo, bbox_hi``.
    """
    return _pack(geom, geom.poly_z, geom.circ_z, geom.sph_c, geom.sph_r, geom.bbox_lo, geom.bbox_hi)


def planar_as_3d(geom) -> tuple[np.ndarray, ...]:
    """A planar geometry's arrays in 3-D kernel form: every footprint extruded over all z
    (``[-inf, inf]``), no spheres. A planar query is then the 3-D query at ``z = 0``."""
    lo = np.asarray(geom.bbox_lo, dtype=np.float64).reshape(-1, 2)
    hi = np.asarray(geom.bbox_hi, dtype=np.float64).reshape(-1, 2)
    inf_z = lambda n: np.tile([-np.inf, np.inf], (n, 1))  # noqa: E731
    return _pack(geom, inf_z(geom.n_polygons), inf_z(geom.n_circles), np.zeros((0, 3)), np.zeros(0),
                 np.column_stack([lo, np.full(len(lo), -np.inf)]), np.column_stack([hi, np.full(len(hi), np.inf)]))


def _pack(geom, poly_z, circ_z, sph_c, sph_r, bbox_lo, bbox_hi) -> tuple[np.ndarray, ...]:
    """The footprint arrays of ``geom`` and the given 3-D ones, contiguous float64 / int64."""
    f = lambda a, d: np.ascontiguousarray(a, dtype=np.float64).reshape(-1, d)  # noqa: E731
    return (*footprint_arrays(geom), f(poly_z, 2), f(circ_z, 2), f(sph_c, 3),
            np.ascontiguousarray(sph_r, dtype=np.float64).reshape(-1), f(bbox_lo, 3), f(bbox_hi, 3))


# ---------------------------------------------------------------------------------------------
# Per-primitive signed distance
# ---------------------------------------------------------------------------------------------


@njit(cache=True)
def _poly_sd2(px, py, seg_a, seg_b, k0, k1):
    """Signed planar distance [m] from (px, py) to the polygon with edges ``k0:k1`` and the
    offset (qx, qy) to its nearest boundary point (outward when inside; zeros on an edge)."""
    dmin2, inside, qx, qy = polygon_nearest(px, py, seg_a, seg_b, k0, k1)
    d = math.sqrt(dmin2)
    return (-d if inside else d), qx, qy


@njit(cache=True)
def _extrude_sd(d2, z, z0, z1):
    """Exact signed distance [m] of a footprint (signed planar distance ``d2``) extruded over
    ``[z0, z1]``, at altitude ``z``."""
    dz = max(z0 - z, z - z1)
    if d2 > 0.0:
        if dz > 0.0:
            return math.sqrt(d2 * d2 + dz * dz)
        return d2
    if dz > 0.0:
        return dz
    return max(d2, dz)


@njit(cache=True)
def _extrude_offset(d2, qx, qy, z, z0, z1):
    """Offset (3 numbers) from the point to the nearest boundary point of the extruded solid,
    given the footprint's signed distance ``d2`` and planar offset ``(qx, qy)``."""
    lo = z0 - z
    hi = z - z1
    dz = max(lo, hi)
    zoff = lo if lo > hi else -hi  # to the nearer cap plane (below: up, above: down)
    if d2 > 0.0 or dz > 0.0:
        return (qx if d2 > 0.0 else 0.0), (qy if d2 > 0.0 else 0.0), (zoff if dz > 0.0 else 0.0)
    if d2 >= dz:  # the side wall is nearer than either cap
        return qx, qy, 0.0
    return 0.0, 0.0, zoff


@njit(cache=True)
def _bbox_gap2(px, py, pz, bbox_lo, bbox_hi, k):
    """Squared distance [m^2] from the point to bounding box ``k`` (0 inside it)."""
    dx = max(bbox_lo[k, 0] - px, 0.0, px - bbox_hi[k, 0])
    dy = max(bbox_lo[k, 1] - py, 0.0, py - bbox_hi[k, 1])
    dz = max(bbox_lo[k, 2] - pz, 0.0, pz - bbox_hi[k, 2])
    return dx * dx + dy * dy + dz * dz


@njit(cache=True)
def _cull2(bound):
    """Squared box gap [m^2] beyond which an obstacle cannot go below ``bound`` [m]. The 1e-9 m
    slack covers rounding between a box gap and the obstacle's own distance (which may come out
    an ulp below it), so culling never changes a minimum and the ESDF's node values equal the
    point kernel's bit for bit."""
    b = max(bound, 0.0) + 1e-9
    return b * b


@njit(cache=True)
def cylinder_sd(px, py, pz, cx, cy, rc, z0, z1):
    """Exact signed distance [m] of a vertical cylinder (centre (cx, cy), radius rc, over [z0, z1])
    and its footprint values for :func:`_extrude_offset`: ``(sd, d2, qx, qy)``."""
    cx = cx - px
    cy = cy - py
    dc = math.sqrt(cx * cx + cy * cy)
    d2 = dc - rc
    # offset to the nearest rim point is u * d2, u the unit vector toward the axis (on the axis
    # every rim point is nearest: pick +x)
    ux = cx / dc if dc > 0.0 else -1.0
    uy = cy / dc if dc > 0.0 else 0.0
    return _extrude_sd(d2, pz, z0, z1), d2, ux * d2, uy * d2


@njit(cache=True)
def sphere_sd(px, py, pz, sx, sy, sz, rs):
    """Exact signed distance [m] of a sphere and the offset (3 numbers) to its nearest surface point."""
    cx = sx - px
    cy = sy - py
    cz = sz - pz
    dc = math.sqrt(cx * cx + cy * cy + cz * cz)
    sd = dc - rs
    if dc > 0.0:
        return sd, cx / dc * sd, cy / dc * sd, cz / dc * sd
    return sd, -sd, 0.0, 0.0


@njit(cache=True)
def unit_direction(best, vx, vy, vz, out_dir, i):
    """``out_dir[i]`` <- the offset (vx, vy, vz) made unit (zeros at distance 0 or inf)."""
    norm = math.sqrt(vx * vx + vy * vy + vz * vz)
    if best != 0.0 and norm > 0.0 and best < np.inf:
        out_dir[i, 0] = vx / norm
        out_dir[i, 1] = vy / norm
        out_dir[i, 2] = vz / norm
    else:
        out_dir[i, 0] = 0.0
        out_dir[i, 1] = 0.0
        out_dir[i, 2] = 0.0


@njit(cache=True)
def nearest3d_kernel(seg_a, seg_b, poly_offsets, circ_c, circ_r, poly_z, circ_z, sph_c, sph_r,
                     bbox_lo, bbox_hi, points, out_d, out_dir, want_dir):
    """Signed distance [m] (minimum of the per-obstacle exact signed distances) and unit
    direction toward the nearest boundary point (outward inside, zeros at distance 0); where
    obstacles tie, the first of them (prisms, cylinders, spheres, in order) gives the direction."""
    n_poly = poly_offsets.shape[0] - 1
    n_circ = circ_r.shape[0]
    n_sph = sph_r.shape[0]
    for i in range(points.shape[0]):
        px = points[i, 0]
        py = points[i, 1]
        pz = points[i, 2]
        best = np.inf
        vx = 0.0
        vy = 0.0
        vz = 0.0
        for p in range(n_poly):
            # Outside its box an obstacle is farther than the box: skip it when that is worse
            # than the best so far (every containing obstacle lies inside its box).
            if _bbox_gap2(px, py, pz, bbox_lo, bbox_hi, p) > _cull2(best):
                continue
            d2, qx, qy = _poly_sd2(px, py, seg_a, seg_b, poly_offsets[p], poly_offsets[p + 1])
            sd = _extrude_sd(d2, pz, poly_z[p, 0], poly_z[p, 1])
            if sd < best:
                best = sd
                if want_dir:
                    vx, vy, vz = _extrude_offset(d2, qx, qy, pz, poly_z[p, 0], poly_z[p, 1])
        for c in range(n_circ):
            if _bbox_gap2(px, py, pz, bbox_lo, bbox_hi, n_poly + c) > _cull2(best):
                continue
            sd, d2, qx, qy = cylinder_sd(px, py, pz, circ_c[c, 0], circ_c[c, 1], circ_r[c], circ_z[c, 0], circ_z[c, 1])
            if sd < best:
                best = sd
                if want_dir:
                    vx, vy, vz = _extrude_offset(d2, qx, qy, pz, circ_z[c, 0], circ_z[c, 1])
        for b in range(n_sph):
            if _bbox_gap2(px, py, pz, bbox_lo, bbox_hi, n_poly + n_circ + b) > _cull2(best):
                continue
            sd, ox, oy, oz = sphere_sd(px, py, pz, sph_c[b, 0], sph_c[b, 1], sph_c[b, 2], sph_r[b])
            if sd < best:
                best = sd
                if want_dir:
                    vx = ox
                    vy = oy
                    vz = oz
        out_d[i] = best
        if want_dir:
            unit_direction(best, vx, vy, vz, out_dir, i)


# ---------------------------------------------------------------------------------------------
# Inside test
# ---------------------------------------------------------------------------------------------


@njit(cache=True)
def prism_contains(px, py, pz, seg_a, seg_b, k0, k1, z0, z1):
    """True if the point is inside or on the prism with footprint edges ``k0:k1`` over [z0, z1]
    (the caller has checked its bounding box)."""
    if pz < z0 or pz > z1:
        return False
    return _polygon_status(px, py, seg_a, seg_b, k0, k1) != OUTSIDE


@njit(cache=True)
def cylinder_contains(px, py, pz, cx, cy, rc, z0, z1):
    """True if the point is inside or on the vertical cylinder."""
    if pz < z0 or pz > z1:
        return False
    dx = px - cx
    dy = py - cy
    return dx * dx + dy * dy <= rc * rc


@njit(cache=True)
def sphere_contains(px, py, pz, sx, sy, sz, rs):
    """True if the point is inside or on the sphere."""
    dx = px - sx
    dy = py - sy
    dz = pz - sz
    return dx * dx + dy * dy + dz * dz <= rs * rs


@njit(cache=True)
def _in_collision3d(px, py, pz, seg_a, seg_b, poly_offsets, circ_c, circ_r, poly_z, circ_z, sph_c, sph_r,
                    bbox_lo, bbox_hi):
    """True if the point is inside or on the boundary of any obstacle."""
    n_poly = poly_offsets.shape[0] - 1
    for p in range(n_poly):
        if _bbox_gap2(px, py, pz, bbox_lo, bbox_hi, p) > 0.0:
            continue
        if prism_contains(px, py, pz, seg_a, seg_b, poly_offsets[p], poly_offsets[p + 1], poly_z[p, 0], poly_z[p, 1]):
            return True
    for c in range(circ_r.shape[0]):
        if cylinder_contains(px, py, pz, circ_c[c, 0], circ_c[c, 1], circ_r[c], circ_z[c, 0], circ_z[c, 1]):
            return True
    for b in range(sph_r.shape[0]):
        if sphere_contains(px, py, pz, sph_c[b, 0], sph_c[b, 1], sph_c[b, 2], sph_r[b]):
            return True
    return False


@njit(cache=True)
def points_inside3d_kernel(seg_a, seg_b, poly_offsets, circ_c, circ_r, poly_z, circ_z, sph_c, sph_r,
                           bbox_lo, bbox_hi, points, out):
    """``out[m]`` is True if ``points[m]`` is inside or on the boundary of any obstacle."""
    for i in range(points.shape[0]):
        out[i] = _in_collision3d(points[i, 0], points[i, 1], points[i, 2], seg_a, seg_b, poly_offsets, circ_c,
                                 circ_r, poly_z, circ_z, sph_c, sph_r, bbox_lo, bbox_hi)


# ---------------------------------------------------------------------------------------------
# Segment blocking
# ---------------------------------------------------------------------------------------------


@njit(cache=True)
def _slab_clip(p0z, ez, z0, z1):
    """Parameter range ``[t0, t1]`` within [0, 1] where ``p0z + t ez`` lies in ``[z0, z1]``;
    ``t0 > t1`` if empty."""
    if ez == 0.0:
        if p0z < z0 or p0z > z1:
            return 1.0, 0.0
        return 0.0, 1.0
    ta = (z0 - p0z) / ez
    tb = (z1 - p0z) / ez
    if ta > tb:
        ta, tb = tb, ta
    return max(ta, 0.0), min(tb, 1.0)


@njit(cache=True)
def _point_on(t, p0, p1, e):
    """``p0 + t e``, exactly ``p0`` / ``p1`` at t = 0 / 1 (keeps endpoint tests exact)."""
    if t == 0.0:
        return p0
    if t == 1.0:
        return p1
    return p0 + t * e


@njit(cache=True)
def extruded_meets_segment(p0x, p0y, p0z, p1x, p1y, p1z, z0, z1, seg_a, seg_b, k0, k1, cx, cy, rc):
    """True if the closed segment meets the footprint extruded over [z0, z1]: the polygon with edges
    ``k0:k1`` if ``k1 > k0``, else the disc (cx, cy, rc). The part of the segment in the slab is
    clipped and tested in the plane."""
    ex = p1x - p0x
    ey = p1y - p0y
    ez = p1z - p0z
    t0, t1 = _slab_clip(p0z, ez, z0, z1)
    if t0 > t1:
        return False
    ax = _point_on(t0, p0x, p1x, ex)
    ay = _point_on(t0, p0y, p1y, ey)
    bx = _point_on(t1, p0x, p1x, ex)
    by = _point_on(t1, p0y, p1y, ey)
    if k1 > k0:
        return segment_meets_polygon(ax, ay, bx, by, seg_a, seg_b, k0, k1)
    return segment_meets_disc(ax, ay, bx, by, cx, cy, rc)


@njit(cache=True)
def sphere_meets_segment(p0x, p0y, p0z, p1x, p1y, p1z, sx, sy, sz, rs):
    """True if the closed segment's nearest point to the sphere's centre is within its radius."""
    ex = p1x - p0x
    ey = p1y - p0y
    ez = p1z - p0z
    wx = sx - p0x
    wy = sy - p0y
    wz = sz - p0z
    ee = ex * ex + ey * ey + ez * ez
    s = 0.0
    if ee > 0.0:
        s = min(max((wx * ex + wy * ey + wz * ez) / ee, 0.0), 1.0)
    dx = wx - s * ex
    dy = wy - s * ey
    dz = wz - s * ez
    return dx * dx + dy * dy + dz * dz <= rs * rs


@njit(cache=True)
def box_misses(lox, hix, loy, hiy, loz, hiz, bbox_lo, bbox_hi, k):
    """True if the box [lo, hi] and bounding box ``k`` do not overlap."""
    return (hix < bbox_lo[k, 0] or lox > bbox_hi[k, 0] or hiy < bbox_lo[k, 1] or loy > bbox_hi[k, 1]
            or hiz < bbox_lo[k, 2] or loz > bbox_hi[k, 2])


@njit(cache=True)
def segments_blocked3d_kernel(seg_a, seg_b, poly_offsets, circ_c, circ_r, poly_z, circ_z, sph_c, sph_r,
                              bbox_lo, bbox_hi, p, q, out):
    """``out[m]`` is True if the closed segment p[m]-q[m] meets any closed obstacle.

    An extruded solid is met iff the part of the segment inside its z slab (a clipped
    parameter range) meets the footprint in the plane; a sphere iff the segment's nearest point
    to the centre is within the radius.
    """
    n_poly = poly_offsets.shape[0] - 1
    n_circ = circ_r.shape[0]
    n_obs = n_poly + n_circ + sph_r.shape[0]
    for m in range(p.shape[0]):
        p0x = p[m, 0]
        p0y = p[m, 1]
        p0z = p[m, 2]
        p1x = q[m, 0]
        p1y = q[m, 1]
        p1z = q[m, 2]
        lox = min(p0x, p1x)
        hix = max(p0x, p1x)
        loy = min(p0y, p1y)
        hiy = max(p0y, p1y)
        loz = min(p0z, p1z)
        hiz = max(p0z, p1z)
        blocked = False
        for k in range(n_obs):
            if box_misses(lox, hix, loy, hiy, loz, hiz, bbox_lo, bbox_hi, k):
                continue
            if k < n_poly:
                blocked = extruded_meets_segment(p0x, p0y, p0z, p1x, p1y, p1z, poly_z[k, 0], poly_z[k, 1], seg_a, seg_b,
                                                 poly_offsets[k], poly_offsets[k + 1], 0.0, 0.0, 0.0)
            elif k < n_poly + n_circ:
                c = k - n_poly
                blocked = extruded_meets_segment(p0x, p0y, p0z, p1x, p1y, p1z, circ_z[c, 0], circ_z[c, 1], seg_a, seg_b,
                                                 0, 0, circ_c[c, 0], circ_c[c, 1], circ_r[c])
            else:
                b = k - n_poly - n_circ
                blocked = sphere_meets_segment(p0x, p0y, p0z, p1x, p1y, p1z, sph_c[b, 0], sph_c[b, 1], sph_c[b, 2],
                                               sph_r[b])
            if blocked:
                break
        out[m] = blocked


# ---------------------------------------------------------------------------------------------
# Range scan (rays in any direction)
# ---------------------------------------------------------------------------------------------


@njit(cache=True)
def _quad_roots(a, b, cc):
    """``{t : a t^2 + 2 b t + cc <= 0}`` for ``a > 0`` as ``(ok, t_lo, t_hi)``, in the
    cancellation-free form (the near root as ``cc / q``)."""
    disc = b * b - a * cc
    if disc < 0.0:
        return False, 0.0, 0.0
    sq = math.sqrt(disc)
    if b <= 0.0:
        qv = -b + sq
        if qv == 0.0:
            return True, 0.0, 0.0
        return True, cc / qv, qv / a
    qv = -b - sq
    return True, qv / a, cc / qv


@njit(cache=True)
def _ray_box(px, py, pz, ux, uy, uz, lo, hi, k, t_max):
    """Entry parameter of the ray into bounding box ``k`` within [0, t_max], or inf."""
    t0 = 0.0
    t1 = t_max
    for ax in range(3):
        pa = px if ax == 0 else (py if ax == 1 else pz)
        ua = ux if ax == 0 else (uy if ax == 1 else uz)
        if ua == 0.0:
            if pa < lo[k, ax] or pa > hi[k, ax]:
                return np.inf
            continue
        ta = (lo[k, ax] - pa) / ua
        tb = (hi[k, ax] - pa) / ua
        if ta > tb:
            ta, tb = tb, ta
        t0 = max(t0, ta)
        t1 = min(t1, tb)
        if t0 > t1:
            return np.inf
    return t0


@njit(cache=True)
def _ray_slab(pz, uz, z0, z1, t_max):
    """Parameter range of the ray inside the slab ``[z0, z1]`` within [0, t_max]; empty if lo > hi."""
    if uz == 0.0:
        if pz < z0 or pz > z1:
            return 1.0, 0.0
        return 0.0, t_max
    ta = (z0 - pz) / uz
    tb = (z1 - pz) / uz
    if ta > tb:
        ta, tb = tb, ta
    return max(ta, 0.0), min(tb, t_max)


@njit(cache=True)
def prism_ray(px, py, pz, ux, uy, uz, t_max, seg_a, seg_b, k0, k1, z0, z1):
    """The smaller of ``t_max`` [m] and the distance along the ray (unit u) to the prism with
    footprint edges ``k0:k1`` over [z0, z1]. The footprint is met first either where the ray
    enters the slab (if the projection is in the closed polygon there) or at an edge crossing."""
    t_lo, t_hi = _ray_slab(pz, uz, z0, z1, t_max)
    if t_lo > t_hi:
        return t_max
    if _polygon_status(px + t_lo * ux, py + t_lo * uy, seg_a, seg_b, k0, k1) != OUTSIDE:
        return t_lo
    t_hit = np.inf
    for j in range(k0, k1):
        ax = seg_a[j, 0] - px
        ay = seg_a[j, 1] - py
        bx = seg_b[j, 0] - px
        by = seg_b[j, 1] - py
        sa = ux * ay - uy * ax
        sb = ux * by - uy * bx
        if (sa > 0.0 and sb > 0.0) or (sa < 0.0 and sb < 0.0):
            continue
        den = sb - sa
        if den == 0.0:
            continue  # parallel: a neighbouring edge reports the vertex
        t = (ax * by - ay * bx) / den
        if t >= t_lo and t <= t_hi and t < t_hit:
            t_hit = t
    return t_hit if t_hit < t_max else t_max


@njit(cache=True)
def cylinder_ray(px, py, pz, ux, uy, uz, t_max, cx, cy, rc, z0, z1):
    """The smaller of ``t_max`` [m] and the distance along the ray to the vertical cylinder."""
    t_lo, t_hi = _ray_slab(pz, uz, z0, z1, t_max)
    if t_lo > t_hi:
        return t_max
    wx = px - cx
    wy = py - cy
    a = ux * ux + uy * uy
    cc = wx * wx + wy * wy - rc * rc
    if a == 0.0:
        if cc <= 0.0:
            return min(t_max, t_lo)
        return t_max
    ok, r0, r1 = _quad_roots(a, ux * wx + uy * wy, cc)
    if not ok:
        return t_max
    t = max(t_lo, r0)
    if t <= min(t_hi, r1) and t < t_max:
        return t
    return t_max


@njit(cache=True)
def sphere_ray(px, py, pz, ux, uy, uz, t_max, sx, sy, sz, rs):
    """The smaller of ``t_max`` [m] and the distance along the ray to the sphere."""
    wx = px - sx
    wy = py - sy
    wz = pz - sz
    a = ux * ux + uy * uy + uz * uz
    cc = wx * wx + wy * wy + wz * wz - rs * rs
    ok, r0, r1 = _quad_roots(a, ux * wx + uy * wy + uz * wz, cc)
    if not ok:
        return t_max
    t = max(0.0, r0)
    if t <= r1 and t < t_max:
        return t
    return t_max


@njit(cache=True)
def range_scan_kernel(seg_a, seg_b, poly_offsets, circ_c, circ_r, poly_z, circ_z, sph_c, sph_r,
                      bbox_lo, bbox_hi, positions, dirs, max_range, out):
    """Fill ``out[i, r]`` with the distance [m] along ray ``dirs[r]`` (unit) from ``positions[i]``
    to the first closed obstacle, ``max_range`` if none within it; 0 for a position in collision.

    Per position, obstacles whose box is out of range are dropped; per ray, a ray-box test
    that cannot beat the best hit so far skips the exact test. The per-primitive tests are
    :func:`prism_ray`, :func:`cylinder_ray` and :func:`sphere_ray` written out in the loop (the
    calls cost a quarter more on the forests; ``tests/sensing/test_index3d.py`` holds the
    two equal through the indexed scan, which calls them).
    """
    n_poly = poly_offsets.shape[0] - 1
    n_circ = circ_r.shape[0]
    n_obs = n_poly + n_circ + sph_r.shape[0]
    n_rays = dirs.shape[0]
    r2max = max_range * max_range
    for i in range(positions.shape[0]):
        px = positions[i, 0]
        py = positions[i, 1]
        pz = positions[i, 2]
        row = out[i]
        if _in_collision3d(px, py, pz, seg_a, seg_b, poly_offsets, circ_c, circ_r, poly_z, circ_z, sph_c, sph_r,
                           bbox_lo, bbox_hi):
            for r in range(n_rays):
                row[r] = 0.0
            continue
        for r in range(n_rays):
            row[r] = max_range
        for k in range(n_obs):
            if _bbox_gap2(px, py, pz, bbox_lo, bbox_hi, k) >= r2max:
                continue
            for r in range(n_rays):
                ux = dirs[r, 0]
                uy = dirs[r, 1]
                uz = dirs[r, 2]
                if _ray_box(px, py, pz, ux, uy, uz, bbox_lo, bbox_hi, k, row[r]) == np.inf:
                    continue
                if k < n_poly + n_circ:
                    if k < n_poly:
                        t_lo, t_hi = _ray_slab(pz, uz, poly_z[k, 0], poly_z[k, 1], row[r])
                    else:
                        t_lo, t_hi = _ray_slab(pz, uz, circ_z[k - n_poly, 0], circ_z[k - n_poly, 1], row[r])
                    if t_lo > t_hi:
                        continue
                    if k < n_poly:
                        k0 = poly_offsets[k]
                        k1 = poly_offsets[k + 1]
                        # The footprint is met first either where the ray enters the slab (if
                        # the projection is in the closed polygon there) or at an edge crossing.
                        if _polygon_status(px + t_lo * ux, py + t_lo * uy, seg_a, seg_b, k0, k1) != OUTSIDE:
                            row[r] = t_lo
                            continue
                        t_hit = np.inf
                        for j in range(k0, k1):
                            ax = seg_a[j, 0] - px
                            ay = seg_a[j, 1] - py
                            bx = seg_b[j, 0] - px
                            by = seg_b[j, 1] - py
                            sa = ux * ay - uy * ax
                            sb = ux * by - uy * bx
                            if (sa > 0.0 and sb > 0.0) or (sa < 0.0 and sb < 0.0):
                                continue
                            den = sb - sa
                            if den == 0.0:
                                continue  # parallel: a neighbouring edge reports the vertex
                            t = (ax * by - ay * bx) / den
                            if t >= t_lo and t <= t_hi and t < t_hit:
                                t_hit = t
                        if t_hit < row[r]:
                            row[r] = t_hit
                    else:
                        c = k - n_poly
                        wx = px - circ_c[c, 0]
                        wy = py - circ_c[c, 1]
                        a = ux * ux + uy * uy
                        cc = wx * wx + wy * wy - circ_r[c] * circ_r[c]
                        if a == 0.0:
                            if cc <= 0.0:
                                row[r] = min(row[r], t_lo)
                            continue
                        ok, r0, r1 = _quad_roots(a, ux * wx + uy * wy, cc)
                        if not ok:
                            continue
                        t = max(t_lo, r0)
                        if t <= min(t_hi, r1) and t < row[r]:
                            row[r] = t
                else:
                    b = k - n_poly - n_circ
                    wx = px - sph_c[b, 0]
                    wy = py - sph_c[b, 1]
                    wz = pz - sph_c[b, 2]
                    a = ux * ux + uy * uy + uz * uz
                    cc = wx * wx + wy * wy + wz * wz - sph_r[b] * sph_r[b]
                    ok, r0, r1 = _quad_roots(a, ux * wx + uy * wy + uz * wz, cc)
                    if not ok:
                        continue
                    t = max(0.0, r0)
                    if t <= r1 and t < row[r]:
                        row[r] = t


# ---------------------------------------------------------------------------------------------
# ESDF: exact node values, trilinear query
# ---------------------------------------------------------------------------------------------


@njit(cache=True)
def esdf3d_build_kernel(seg_a, seg_b, poly_offsets, circ_c, circ_r, poly_z, circ_z, sph_c, sph_r,
                        bbox_lo, bbox_hi, ox, oy, oz, res, out):
    """``out[iz, iy, ix]`` <- the exact signed distance [m] at node ``o + res * (ix, iy, iz)``,
    bit for bit the value of :func:`nearest3d_kernel` there.

    Column by column: every obstacle's planar part (footprint distance; a sphere's horizontal
    offset) is computed once per (x, y) column. An obstacle's value along the column is
    bounded below by ``lb`` (its footprint distance, or ``|dxy| - r`` for a sphere) and, being
    quasi-convex in z, bounded above by ``ub`` = its larger value at the two end nodes. No
    obstacle with ``lb > min ub`` can be the minimum at any node of the column, so each node
    only visits the few remaining candidates, in increasing ``lb`` and stopping once ``lb``
    reaches the best value.
    """
    nz, ny, nx = out.shape
    n_poly = poly_offsets.shape[0] - 1
    n_circ = circ_r.shape[0]
    n_sph = sph_r.shape[0]
    n_obs = n_poly + n_circ + n_sph
    za = oz
    zb = oz + res * (nz - 1)
    cand = np.empty(n_obs, dtype=np.int64)
    cand_lb = np.empty(n_obs)
    col = np.empty(n_obs)  # per obstacle: footprint distance, or a sphere's squared xy offset
    if n_obs == 0:
        out[:] = np.inf
        return
    for iy in range(ny):
        py = oy + res * iy
        for ix in range(nx):
            px = ox + res * ix
            u_best = np.inf
            n_c = 0
            for k in range(n_obs):
                gx = max(bbox_lo[k, 0] - px, 0.0, px - bbox_hi[k, 0])
                gy = max(bbox_lo[k, 1] - py, 0.0, py - bbox_hi[k, 1])
                if gx * gx + gy * gy > _cull2(u_best):
                    continue  # its footprint alone is farther than the column's upper bound
                if k < n_poly:
                    d2, qx, qy = _poly_sd2(px, py, seg_a, seg_b, poly_offsets[k], poly_offsets[k + 1])
                    z0 = poly_z[k, 0]
                    z1 = poly_z[k, 1]
                    lb = d2
                    ub = max(_extrude_sd(d2, za, z0, z1), _extrude_sd(d2, zb, z0, z1))
                    col[k] = d2
                elif k < n_poly + n_circ:
                    c = k - n_poly
                    cx = circ_c[c, 0] - px
                    cy = circ_c[c, 1] - py
                    d2 = math.sqrt(cx * cx + cy * cy) - circ_r[c]
                    z0 = circ_z[c, 0]
                    z1 = circ_z[c, 1]
                    lb = d2
                    ub = max(_extrude_sd(d2, za, z0, z1), _extrude_sd(d2, zb, z0, z1))
                    col[k] = d2
                else:
                    b = k - n_poly - n_circ
                    cx = sph_c[b, 0] - px
                    cy = sph_c[b, 1] - py
                    s2 = cx * cx + cy * cy
                    lb = math.sqrt(s2) - sph_r[b]
                    dza = sph_c[b, 2] - za
                    dzb = sph_c[b, 2] - zb
                    ub = max(math.sqrt(s2 + dza * dza), math.sqrt(s2 + dzb * dzb)) - sph_r[b]
                    col[k] = s2
                if ub < u_best:
                    u_best = ub
                if lb <= u_best:
                    # insertion by lb (the lists are short)
                    j = n_c
                    while j > 0 and cand_lb[j - 1] > lb:
                        cand[j] = cand[j - 1]
                        cand_lb[j] = cand_lb[j - 1]
                        j -= 1
                    cand[j] = k
                    cand_lb[j] = lb
                    n_c += 1
            while n_c > 0 and cand_lb[n_c - 1] > u_best:
                n_c -= 1
            for iz in range(nz):
                pz = oz + res * iz
                best = np.inf
                for j in range(n_c):
                    if cand_lb[j] >= best:
                        break
                    k = cand[j]
                    if k < n_poly:
                        sd = _extrude_sd(col[k], pz, poly_z[k, 0], poly_z[k, 1])
                    elif k < n_poly + n_circ:
                        sd = _extrude_sd(col[k], pz, circ_z[k - n_poly, 0], circ_z[k - n_poly, 1])
                    else:
                        b = k - n_poly - n_circ
                        cz = sph_c[b, 2] - pz
                        sd = math.sqrt(col[k] + cz * cz) - sph_r[b]
                    if sd < best:
                        best = sd
                out[iz, iy, ix] = best


@njit(cache=True)
def esdf3d_query_kernel(values, ox, oy, oz, res, points, out_v, out_g):
    """Trilinear interpolation of node values ``values[iz, iy, ix]`` and its analytic gradient;
    points are clamped to the grid. Cells with a non-finite corner give the minimum corner
    value and a zero gradient."""
    nz, ny, nx = values.shape
    inv = 1.0 / res
    for m in range(points.shape[0]):
        fx = min(max((points[m, 0] - ox) * inv, 0.0), nx - 1.0)
        fy = min(max((points[m, 1] - oy) * inv, 0.0), ny - 1.0)
        fz = min(max((points[m, 2] - oz) * inv, 0.0), nz - 1.0)
        ix = min(int(math.floor(fx)), nx - 2)
        iy = min(int(math.floor(fy)), ny - 2)
        iz = min(int(math.floor(fz)), nz - 2)
        u = fx - ix
        v = fy - iy
        w = fz - iz
        c000 = values[iz, iy, ix]
        c100 = values[iz, iy, ix + 1]
        c010 = values[iz, iy + 1, ix]
        c110 = values[iz, iy + 1, ix + 1]
        c001 = values[iz + 1, iy, ix]
        c101 = values[iz + 1, iy, ix + 1]
        c011 = values[iz + 1, iy + 1, ix]
        c111 = values[iz + 1, iy + 1, ix + 1]
        lo = min(min(min(c000, c100), min(c010, c110)), min(min(c001, c101), min(c011, c111)))
        hi = max(max(max(c000, c100), max(c010, c110)), max(max(c001, c101), max(c011, c111)))
        if not (math.isfinite(lo) and math.isfinite(hi)):
            out_v[m] = lo
            out_g[m, 0] = 0.0
            out_g[m, 1] = 0.0
            out_g[m, 2] = 0.0
            continue
        # bilinear in (x, y) on the two z planes, then linear in z
        a0 = (1.0 - u) * c000 + u * c100
        b0 = (1.0 - u) * c010 + u * c110
        a1 = (1.0 - u) * c001 + u * c101
        b1 = (1.0 - u) * c011 + u * c111
        f0 = (1.0 - v) * a0 + v * b0
        f1 = (1.0 - v) * a1 + v * b1
        out_v[m] = (1.0 - w) * f0 + w * f1
        gx0 = (1.0 - v) * (c100 - c000) + v * (c110 - c010)
        gx1 = (1.0 - v) * (c101 - c001) + v * (c111 - c011)
        out_g[m, 0] = ((1.0 - w) * gx0 + w * gx1) * inv
        out_g[m, 1] = ((1.0 - w) * (b0 - a0) + w * (b1 - a1)) * inv
        out_g[m, 2] = (f1 - f0) * inv
