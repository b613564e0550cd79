"""Numba kernels behind the sensing functions: pure functions of flat ``Geometry`` arrays.

Conventions shared by every kernel:

* An obstacle is a *closed* set: a point on a polygon edge or on a circle is in collision.
  "Strictly inside" a polygon is decided by the even-odd (crossing) rule; the on-edge test
  is ``cross(a - p, b - p) == 0 and dot(a - p, b - p) <= 0`` in floating point, which is
  exact for axis-aligned edges (the common box world) and within rounding otherwise.
* The crossing rule and the on-edge test use the same cross product, so a point is
  classified consistently by the LiDAR, ``points_inside`` and ``signed_distance``.
* Empty geometries have zero-length arrays and ``poly_offsets == [0]``; every loop is
  simply empty then.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

OUTSIDE = 0
INSIDE = 1
ON_BOUNDARY = 2


def geom_arrays(geom) -> tuple[np.ndarray, ...]:
    """The seven ``Geometry`` arrays in kernel argument order, contiguous with fixed dtypes.

    A no-op for geometries built by ``Geometry.from_obstacles``; keeps every kernel compiled
    for a single type signature.
    """
    f = lambda a: np.ascontiguousarray(a, dtype=np.float64)  # noqa: E731
    return (*footprint_arrays(geom), f(geom.bbox_lo).reshape(-1, 2), f(geom.bbox_hi).reshape(-1, 2))


def footprint_arrays(geom) -> tuple[np.ndarray, ...]:
    """``seg_a, seg_b, poly_offsets, circ_c, circ_r``: the planar footprints (polygons and
    circles) of a 2-D or 3-D geometry, contiguous with fixed dtypes."""
    f = lambda a: np.ascontiguousarray(a, dtype=np.float64)  # noqa: E731
    return (
        f(geom.seg_a).reshape(-1, 2),
        f(geom.seg_b).reshape(-1, 2),
        np.ascontiguousarray(geom.poly_offsets, dtype=np.int64).reshape(-1) if len(geom.poly_offsets)
        else np.zeros(1, dtype=np.int64),
        f(geom.circ_c).reshape(-1, 2),
        f(geom.circ_r).reshape(-1),
    )


def as_points(x, name: str = "points") -> np.ndarray:
    """``x`` as a contiguous float64 (M, 2) array, or ValueError naming ``name``."""
    a = np.ascontiguousarray(x, dtype=np.float64)
    if a.ndim != 2 or a.shape[1] != 2:
        raise ValueError(f"{name} must have shape (M, 2), got {a.shape}")
    return a


@njit(cache=True)
def _polygon_status(px, py, seg_a, seg_b, k0, k1):
    """Classify ``(px, py)`` against the polygon with edges ``k0:k1``.

    Returns OUTSIDE, INSIDE (even-odd rule) or ON_BOUNDARY.
    """
    inside = False
    for k in range(k0, k1):
        ax = seg_a[k, 0] - px
        ay = seg_a[k, 1] - py
        bx = seg_b[k, 0] - px
        by = seg_b[k, 1] - py
        cr = ax * by - ay * bx
        if cr == 0.0 and ax * bx + ay * by <= 0.0:
            return ON_BOUNDARY
        # Crossing of the horizontal ray to +x: the edge straddles y = py and meets it at
        # x = px + cr / (by - ay); that is right of p iff cr and (by - ay) share a sign.
        # cr != 0 here (a straddling edge with cr == 0 passes through p, caught above).
        if (ay > 0.0) != (by > 0.0):
            if (cr > 0.0) == (by > ay):
                inside = not inside
    return INSIDE if inside else OUTSIDE


@njit(cache=True)
def _in_collision(px, py, seg_a, seg_b, poly_offsets, circ_c, circ_r, bbox_lo, bbox_hi):
    """True if the point is inside or on the boundary of any obstacle."""
    n_poly = poly_offsets.shape[0] - 1
    for p in range(n_poly):
        if px < bbox_lo[p, 0] or px > bbox_hi[p, 0] or py < bbox_lo[p, 1] or py > bbox_hi[p, 1]:
            continue
        if _polygon_status(px, py, seg_a, seg_b, poly_offsets[p], poly_offsets[p + 1]) != OUTSIDE:
            return True
    for c in range(circ_r.shape[0]):
        dx = px - circ_c[c, 0]
        dy = py - circ_c[c, 1]
        if dx * dx + dy * dy <= circ_r[c] * circ_r[c]:
            return True
    return False


@njit(cache=True)
def points_inside_kernel(seg_a, seg_b, poly_offsets, circ_c, circ_r, bbox_lo, bbox_hi, points, out):
    """``out[m]`` is True if ``points[m]`` is inside or on the boundary of any obstacle."""
    for i in range(points.shape[0]):
        out[i] = _in_collision(points[i, 0], points[i, 1], seg_a, seg_b, poly_offsets, circ_c, circ_r,
                               bbox_lo, bbox_hi)


# ---------------------------------------------------------------------------------------------
# LiDAR ring
# ---------------------------------------------------------------------------------------------


@njit(cache=True)
def _ray_index_span(t_start, span, inv_dth):
    """First and last ray index (unwrapped, may exceed n) covering [t_start, t_start + span].

    ``floor``/``ceil`` always include every ray whose angle lies in the interval as long as the
    angle rounding error (~1e-16 rad) is below the ray spacing; the exact hit test decides.
    """
    if t_start < 0.0:
        t_start += 2.0 * math.pi
    r_lo = int(math.floor(t_start * inv_dth))
    r_hi = int(math.ceil((t_start + span) * inv_dth))
    return r_lo, r_hi


#: Largest error [rad] of :func:`_bearing` (4.4.49 of Abramowitz & Stegun: 1e-5 rad), and the
#: margin by which the LiDAR kernel widens an edge's ray interval to cover it.
BEARING_ERR = 1e-5
BEARING_PAD = 1e-4


@njit(cache=True, inline="always")
def _bearing(y, x):
    """``atan2(y, x)`` within BEARING_ERR rad, in [-pi - BEARING_ERR, pi + BEARING_ERR]: a
    polynomial on the octant (about 4x cheaper than libm's). Used only to choose which rays to
    test; the hit test itself is exact, so an interval widened by BEARING_PAD gives the same ranges."""
    ax = abs(x)
    ay = abs(y)
    if ax >= ay:
        if ax == 0.0:
            return 0.0
        z = y / x
        z2 = z * z
        a = z * (0.9998660 + z2 * (-0.3302995 + z2 * (0.1801410 + z2 * (-0.0851330 + z2 * 0.0208351))))
        if x < 0.0:
            a += math.pi if y >= 0.0 else -math.pi
        return a
    z = x / y
    z2 = z * z
    a = z * (0.9998660 + z2 * (-0.3302995 + z2 * (0.1801410 + z2 * (-0.0851330 + z2 * 0.0208351))))
    return (0.5 * math.pi if y > 0.0 else -0.5 * math.pi) - a


@njit(cache=True, error_model="numpy")
def _edge_rays(row, lo, hi, cos_t, sin_t, ax, ay, bx, by, cr):
    """Rays ``lo <= r < hi`` against one edge a -> b (relative to the agent; ``cr`` = cross(a, b)):
    ``row[r]`` <- the hit distance where the ray crosses the edge nearer than ``row[r]``.

    Branch-free, on slices indexed from 0, so that LLVM vectorises it; every ray computes the same
    operations as a per-ray test with early exits would (the same bits). Sign of each endpoint
    relative to the ray's line; a hit needs a sign change. A shared vertex gives the same value
    for both of its edges, so a ray exactly through a vertex cannot slip between them by
    rounding. A collinear ray (``den == 0``) is left to the neighbouring edge, which reports the
    vertex (its t, inf or NaN here, is masked out)."""
    rw = row[lo:hi]
    cs = cos_t[lo:hi]
    sn = sin_t[lo:hi]
    for j in range(hi - lo):
        ux = cs[j]
        uy = sn[j]
        sa = ux * ay - uy * ax
        sb = ux * by - uy * bx
        den = sb - sa  # cross(u, e)
        t = cr / den
        cur = rw[j]
        miss = ((sa > 0.0) & (sb > 0.0)) | ((sa < 0.0) & (sb < 0.0))
        rw[j] = t if (~miss) & (den != 0.0) & (t >= 0.0) & (t < cur) else cur


@njit(cache=True, error_model="numpy")
def _disc_rays(row, lo, hi, cos_t, sin_t, cx, cy, rc, q):
    """Rays ``lo <= r < hi`` against the circle of centre (cx, cy) (relative to the agent) and
    radius ``rc``, ``q = |c|^2 - rc^2``: the near root of ``t^2 - 2 b t + q = 0`` in the
    cancellation-free form ``q / (b + sqrt(disc))`` where it is nearer than ``row[r]``.
    Branch-free like :func:`_edge_rays` (rays pointing away, ``b <= 0``, or missing, ``disc < 0``,
    are masked out)."""
    rw = row[lo:hi]
    cs = cos_t[lo:hi]
    sn = sin_t[lo:hi]
    for j in range(hi - lo):
        ux = cs[j]
        uy = sn[j]
        b = ux * cx + uy * cy
        perp = ux * cy - uy * cx
        disc = rc * rc - perp * perp
        t = q / (b + math.sqrt(disc))
        cur = rw[j]
        rw[j] = t if (b > 0.0) & (disc >= 0.0) & (t < cur) else cur


@njit(cache=True)
def lidar_kernel(seg_a, seg_b, poly_offsets, circ_c, circ_r, bbox_lo, bbox_hi, positions,
                 cos_t, sin_t, max_range, out):
    """Fill ``out[i, r]`` with the range [m] along ray ``r`` from agent ``i``.

    Per agent and per primitive: cull by distance, keep only polygon edges facing the agent
    (the first boundary crossing of a ray starting outside a polygon always enters it, through
    an edge whose outward side holds the agent), clip the edge to the range disc, convert the
    clipped edge (or the circle's tangent cone) to an interval of ray indices and intersect
    only those rays. Agents in collision get 0 on every ray.
    """
    n_agents = positions.shape[0]
    n_rays = cos_t.shape[0]
    n_poly = poly_offsets.shape[0] - 1
    inv_dth = n_rays / (2.0 * math.pi)
    r2max = max_range * max_range

    orient = polygon_orientations(seg_a, seg_b, poly_offsets)

    for i in range(n_agents):
        px = positions[i, 0]
        py = positions[i, 1]
        row = out[i]
        if _in_collision(px, py, seg_a, seg_b, poly_offsets, circ_c, circ_r, bbox_lo, bbox_hi):
            for r in range(n_rays):
                row[r] = 0.0
            continue
        for r in range(n_rays):
            row[r] = max_range

        for p in range(n_poly):
            polygon_rays(row, p, px, py, orient[p], seg_a, seg_b, poly_offsets, bbox_lo, bbox_hi, cos_t, sin_t,
                         r2max, inv_dth)
        circles_rays(row, px, py, circ_c, circ_r, cos_t, sin_t, max_range, inv_dth)


@njit(cache=True)
def polygon_orientations(seg_a, seg_b, poly_offsets):
    """+1 for each counter-clockwise polygon, -1 for a clockwise one (sign of the shoelace area)."""
    n_poly = poly_offsets.shape[0] - 1
    orient = np.empty(n_poly)
    for p in range(n_poly):
        area2 = 0.0
        for k in range(poly_offsets[p], poly_offsets[p + 1]):
            area2 += seg_a[k, 0] * seg_b[k, 1] - seg_a[k, 1] * seg_b[k, 0]
        orient[p] = 1.0 if area2 > 0.0 else -1.0
    return orient


@njit(cache=True)
def polygon_rays(row, p, px, py, sgn, seg_a, seg_b, poly_offsets, bbox_lo, bbox_hi, cos_t, sin_t, r2max, inv_dth):
    """The LiDAR ring ``row`` of an agent at (px, py), outside every obstacle, against polygon ``p``
    (orientation ``sgn``): each facing edge within range lowers the rays it crosses."""
    n_rays = cos_t.shape[0]
    # Whole-polygon cull on the distance to its bounding box.
    dx = max(bbox_lo[p, 0] - px, 0.0, px - bbox_hi[p, 0])
    dy = max(bbox_lo[p, 1] - py, 0.0, py - bbox_hi[p, 1])
    if dx * dx + dy * dy >= r2max:
        return
    for k in range(poly_offsets[p], poly_offsets[p + 1]):
        ax = seg_a[k, 0] - px
        ay = seg_a[k, 1] - py
        bx = seg_b[k, 0] - px
        by = seg_b[k, 1] - py
        ex = bx - ax
        ey = by - ay
        cr = ax * ey - ay * ex  # cross(a - p, b - a) = cross(a - p, b - p)
        # Back-facing or edge-on (agent on the supporting line): never a first hit;
        # an edge-on edge's near vertex is hit through the neighbouring edge.
        if sgn * cr >= 0.0:
            continue
        ee = ex * ex + ey * ey
        ae = ax * ex + ay * ey
        aa = ax * ax + ay * ay
        s_near = min(max(-ae / ee, 0.0), 1.0)
        nx = ax + s_near * ex
        ny = ay + s_near * ey
        if nx * nx + ny * ny >= r2max:
            continue
        # Clip the edge to the range disc |a + s e - p| <= max_range, so long walls
        # only cost the rays that can see them within range.
        disc = ae * ae - ee * (aa - r2max)
        sq = math.sqrt(max(disc, 0.0))
        s0 = max((-ae - sq) / ee, 0.0)
        s1 = min((-ae + sq) / ee, 1.0)
        c0x = ax + s0 * ex
        c0y = ay + s0 * ey
        c1x = ax + s1 * ex
        c1y = ay + s1 * ey
        th0 = _bearing(c0y, c0x)
        th1 = _bearing(c1y, c1x)
        # cr > 0: b is counter-clockwise of a seen from p, so sweep a -> b.
        if cr > 0.0:
            t_start = th0
            span = th1 - th0
        else:
            t_start = th1
            span = th0 - th1
        if span < 0.0:
            span += 2.0 * math.pi
        # the bearings' error covered by a margin on both ends (a full turn at most)
        r_lo, r_hi = _ray_index_span(t_start - BEARING_PAD, min(span + 2.0 * BEARING_PAD, 2.0 * math.pi),
                                     inv_dth)
        while r_lo <= r_hi:  # the unwrapped interval, one piece within [0, n_rays) at a time
            base = (r_lo // n_rays) * n_rays
            hi = min(r_hi - base + 1, n_rays)
            _edge_rays(row, r_lo - base, hi, cos_t, sin_t, ax, ay, bx, by, cr)
            r_lo = base + hi


@njit(cache=True)
def circles_rays(row, px, py, circ_c, circ_r, cos_t, sin_t, max_range, inv_dth):
    """The LiDAR ring ``row`` of an agent at (px, py), outside every obstacle, against every circle."""
    n_rays = cos_t.shape[0]
    for c in range(circ_r.shape[0]):
        cx = circ_c[c, 0] - px
        cy = circ_c[c, 1] - py
        rc = circ_r[c]
        d2 = cx * cx + cy * cy
        dc = math.sqrt(d2)
        if dc - rc >= max_range:
            continue
        half = math.asin(min(rc / dc, 1.0))  # half-angle of the tangent cone
        phi = math.atan2(cy, cx)
        q = (dc - rc) * (dc + rc)  # |c - p|^2 - r^2 > 0 outside
        r_lo, r_hi = _ray_index_span(phi - half, 2.0 * half, inv_dth)
        while r_lo <= r_hi:
            base = (r_lo // n_rays) * n_rays
            hi = min(r_hi - base + 1, n_rays)
            _disc_rays(row, r_lo - base, hi, cos_t, sin_t, cx, cy, rc, q)
            r_lo = base + hi


# ---------------------------------------------------------------------------------------------
# Signed distance and nearest boundary point
# ---------------------------------------------------------------------------------------------


@njit(cache=True)
def polygon_nearest(px, py, seg_a, seg_b, k0, k1):
    """Nearest boundary point of the polygon with edges ``k0:k1`` to ``(px, py)``.

    Returns ``(dmin2, inside, qx, qy)``: the squared distance [m^2] to the boundary, whether the
    point is strictly inside (even-odd rule), and the offset (qx, qy) [m] from the point to the
    nearest boundary point. A point exactly on an edge gives ``(0, False, 0, 0)`` (distance 0,
    direction undefined).
    """
    dmin2 = np.inf
    qx = 0.0
    qy = 0.0
    inside = False
    for k in range(k0, k1):
        ax = seg_a[k, 0] - px
        ay = seg_a[k, 1] - py
        bx = seg_b[k, 0] - px
        by = seg_b[k, 1] - py
        cr = ax * by - ay * bx
        if cr == 0.0 and ax * bx + ay * by <= 0.0:
            return 0.0, False, 0.0, 0.0
        if (ay > 0.0) != (by > 0.0):
            if (cr > 0.0) == (by > ay):
                inside = not inside
        ex = bx - ax
        ey = by - ay
        ee = ex * ex + ey * ey
        s = 0.0
        if ee > 0.0:
            s = min(max(-(ax * ex + ay * ey) / ee, 0.0), 1.0)
        nx = ax + s * ex
        ny = ay + s * ey
        d2 = nx * nx + ny * ny
        if d2 < dmin2:
            dmin2 = d2
            qx = nx
            qy = ny
    return dmin2, inside, qx, qy


@njit(cache=True)
def _beyond(px, py, x0, y0, cell, nx, ny, cx, cy, ring):
    """Distance from (px, py) to the nearest side of the block of cells within ``ring`` of
    (cx, cy) beyond which the grid goes on (inf when the block covers the grid)."""
    bound = np.inf
    if cx - ring > 0:
        bound = min(bound, px - (x0 + (cx - ring) * cell))
    if cx + ring < nx - 1:
        bound = min(bound, x0 + (cx + ring + 1) * cell - px)
    if cy - ring > 0:
        bound = min(bound, py - (y0 + (cy - ring) * cell))
    if cy + ring < ny - 1:
        bound = min(bound, y0 + (cy + ring + 1) * cell - py)
    return bound


@njit(cache=True)
def nearest_cells_kernel(seg_a, seg_b, poly_offsets, circ_c, circ_r, bbox_lo, bbox_hi,
                         x0, y0, cell, nx, ny, start, items, points, out_d, out_dir, want_dir):
    """Signed distance [m] to the obstacles and unit direction toward the nearest boundary point
    (:func:`nearest_kernel`), visiting the polygons a grid of cells lists.

    The grid is ``nx x ny`` cells of side ``cell`` from (x0, y0); cell ``c`` lists the polygons
    ``items[start[c]:start[c + 1]]`` (``swarmnav.sensing.index``). Cells are visited in square
    rings of growing size around the point's, until the best boundary distance found is no
    farther than any polygon not yet visited; each polygon is handled once, as the plain scan
    handles it. The plain scan is this kernel on a grid of one cell listing every polygon.
    """
    n_poly = poly_offsets.shape[0] - 1
    n_circ = circ_r.shape[0]
    inv = 1.0 / cell
    dedupe = nx * ny > 1  # a polygon listed in several cells is handled once
    seen = np.full(n_poly if dedupe else 0, -1, dtype=np.int64)
    for i in range(points.shape[0]):
        px = points[i, 0]
        py = points[i, 1]
        slack = 1e-9 * (abs(px) + abs(py) + abs(x0) + abs(y0) + (nx + ny) * cell)
        best_out2 = np.inf
        bo_x = 0.0
        bo_y = 0.0
        best_in = -1.0
        bi_x = 0.0
        bi_y = 0.0
        cx = min(max(int(math.floor((px - x0) * inv)), 0), nx - 1)
        cy = min(max(int(math.floor((py - y0) * inv)), 0), ny - 1)
        ring = 0
        while True:
            # the cells at Chebyshev distance `ring` from (cx, cy), inside the grid
            for iy in range(max(cy - ring, 0), min(cy + ring, ny - 1) + 1):
                step = 1 if (iy == cy - ring or iy == cy + ring or ring == 0) else 2 * ring
                for ix in range(cx - ring, cx + ring + 1, step):
                    if 0 <= ix < nx:
                        for k in range(start[iy * nx + ix], start[iy * nx + ix + 1]):
                            p = items[k]
                            if dedupe:
                                if seen[p] == i:
                                    continue
                                seen[p] = i
                            in_box = not (px < bbox_lo[p, 0] or px > bbox_hi[p, 0]
                                          or py < bbox_lo[p, 1] or py > bbox_hi[p, 1])
                            if not in_box and best_in < 0.0:
                                dx = max(bbox_lo[p, 0] - px, 0.0, px - bbox_hi[p, 0])
                                dy = max(bbox_lo[p, 1] - py, 0.0, py - bbox_hi[p, 1])
                                if dx * dx + dy * dy >= best_out2:
                                    continue
                            elif not in_box:
                                continue
                            dmin2, inside, qx, qy = polygon_nearest(px, py, seg_a, seg_b, poly_offsets[p],
                                                                    poly_offsets[p + 1])
                            if inside:
                                depth = math.sqrt(dmin2)
                                if depth > best_in:
                                    best_in = depth
                                    bi_x = qx
                                    bi_y = qy
                            elif dmin2 < best_out2:
                                best_out2 = dmin2
                                bo_x = qx
                                bo_y = qy
            # every polygon whose bounding box holds the point lists the point's cell (ring 0):
            # inside one, the deepest is known
            if best_in >= 0.0:
                break
            # unvisited polygons lie beyond the block of cells visited, past one of its sides
            # that is not the grid's edge (less a slack: the cells' edges are rounded)
            bound = _beyond(px, py, x0, y0, cell, nx, ny, cx, cy, ring) - slack
            if bound == np.inf:
                break  # the whole grid is visited
            if bound > 0.0 and bound * bound >= best_out2:
                break
            ring += 1
        for c in range(n_circ):
            ccx = circ_c[c, 0] - px
            ccy = circ_c[c, 1] - py
            rc = circ_r[c]
            dc = math.sqrt(ccx * ccx + ccy * ccy)
            d = dc - rc
            if dc > 0.0:
                ux = ccx / dc
                uy = ccy / dc
            else:
                ux = -1.0
                uy = 0.0
            if d < 0.0:
                if -d > best_in:
                    best_in = -d
                    bi_x = -ux * (-d)
                    bi_y = -uy * (-d)
            elif d * d < best_out2:
                best_out2 = d * d
                bo_x = ux * d
                bo_y = uy * d
        if best_in >= 0.0:
            dist = -best_in
            vx = bi_x
            vy = bi_y
            norm = best_in
        else:
            norm = math.sqrt(best_out2)
            dist = norm
            vx = bo_x
            vy = bo_y
        out_d[i] = dist
        if want_dir:
            if norm > 0.0 and norm < np.inf:
                out_dir[i, 0] = vx / norm
                out_dir[i, 1] = vy / norm
            else:
                out_dir[i, 0] = 0.0
                out_dir[i, 1] = 0.0


@njit(cache=True)
def nearest_kernel(seg_a, seg_b, poly_offsets, circ_c, circ_r, bbox_lo, bbox_hi, points,
                   out_d, out_dir, want_dir):
    """Signed distance [m] to the obstacles and unit direction toward the nearest boundary point.

    Outside every obstacle: distance to the nearest boundary (the exact distance to the union).
    Inside: minus the depth in the deepest containing obstacle (its own boundary distance);
    identical to the union's signed distance when obstacles do not overlap. Every polygon, in
    order, then every circle: :func:`nearest_cells_kernel` on one cell that lists them all.
    """
    n_poly = poly_offsets.shape[0] - 1
    start = np.array([0, n_poly], dtype=np.int64)
    items = np.arange(n_poly, dtype=np.int64)
    nearest_cells_kernel(seg_a, seg_b, poly_offsets, circ_c, circ_r, bbox_lo, bbox_hi,
                         0.0, 0.0, 1.0, 1, 1, start, items, points, out_d, out_dir, want_dir)


@njit(cache=True)
def surfaces_within_kernel(seg_a, seg_b, poly_offsets, circ_c, circ_r, bbox_lo, bbox_hi, points, reach,
                           out_point, out_d, out_dir, fill):
    """Every (point, obstacle) pair whose boundary lies within ``reach`` [m] of the point: the
    point's index, its signed distance to that obstacle alone (negative inside it) and the unit
    direction from the point toward that obstacle's nearest boundary point. Returns the number of
    pairs; writes them only when ``fill`` (a first pass with ``fill=False`` sizes the arrays)."""
    n_poly = poly_offsets.shape[0] - 1
    n_circ = circ_r.shape[0]
    k = 0
    for i in range(points.shape[0]):
        px = points[i, 0]
        py = points[i, 1]
        for p in range(n_poly):
            dx = max(bbox_lo[p, 0] - px, 0.0, px - bbox_hi[p, 0])
            dy = max(bbox_lo[p, 1] - py, 0.0, py - bbox_hi[p, 1])
            if dx * dx + dy * dy > reach * reach:
                continue
            dmin2, inside, qx, qy = polygon_nearest(px, py, seg_a, seg_b, poly_offsets[p], poly_offsets[p + 1])
            norm = math.sqrt(dmin2)
            if not inside and norm > reach:
                continue
            if fill:
                out_point[k] = i
                out_d[k] = -norm if inside else norm
                out_dir[k, 0] = qx / norm if norm > 0.0 else 0.0
                out_dir[k, 1] = qy / norm if norm > 0.0 else 0.0
            k += 1
        for c in range(n_circ):
            cx = circ_c[c, 0] - px
            cy = circ_c[c, 1] - py
            dc = math.sqrt(cx * cx + cy * cy)
            d = dc - circ_r[c]
            if d > reach:
                continue
            if fill:
                out_point[k] = i
                out_d[k] = d
                if dc > 0.0:  # toward the nearest boundary point: along c - p outside, p - c inside
                    s = 1.0 if d >= 0.0 else -1.0
                    out_dir[k, 0] = s * cx / dc
                    out_dir[k, 1] = s * cy / dc
                else:
                    out_dir[k, 0] = -1.0
                    out_dir[k, 1] = 0.0
            k += 1
    return k


# ---------------------------------------------------------------------------------------------
# Segment blocking
# ---------------------------------------------------------------------------------------------


@njit(cache=True)
def _on_box(ax, ay, bx, by, cx, cy):
    """c lies in the closed bounding box of segment a-b (used once c is known collinear)."""
    return min(ax, bx) <= cx <= max(ax, bx) and min(ay, by) <= cy <= max(ay, by)


@njit(cache=True)
def _segments_touch(p0x, p0y, p1x, p1y, ax, ay, bx, by):
    """Closed segments p0-p1 and a-b share at least one point (orientation predicates)."""
    d1 = (bx - ax) * (p0y - ay) - (by - ay) * (p0x - ax)
    d2 = (bx - ax) * (p1y - ay) - (by - ay) * (p1x - ax)
    d3 = (p1x - p0x) * (ay - p0y) - (p1y - p0y) * (ax - p0x)
    d4 = (p1x - p0x) * (by - p0y) - (p1y - p0y) * (bx - p0x)
    if ((d1 > 0.0 and d2 < 0.0) or (d1 < 0.0 and d2 > 0.0)) and \
            ((d3 > 0.0 and d4 < 0.0) or (d3 < 0.0 and d4 > 0.0)):
        return True
    if d1 == 0.0 and _on_box(ax, ay, bx, by, p0x, p0y):
        return True
    if d2 == 0.0 and _on_box(ax, ay, bx, by, p1x, p1y):
        return True
    if d3 == 0.0 and _on_box(p0x, p0y, p1x, p1y, ax, ay):
        return True
    if d4 == 0.0 and _on_box(p0x, p0y, p1x, p1y, bx, by):
        return True
    return False


@njit(cache=True)
def segment_meets_polygon(ax, ay, bx, by, seg_a, seg_b, k0, k1):
    """The closed segment a-b touches or lies inside the polygon with edges ``k0:k1``."""
    for k in range(k0, k1):
        if _segments_touch(ax, ay, bx, by, seg_a[k, 0], seg_a[k, 1], seg_b[k, 0], seg_b[k, 1]):
            return True
    # No edge is touched: the segment is wholly inside or wholly outside, so testing one
    # endpoint decides.
    return _polygon_status(ax, ay, seg_a, seg_b, k0, k1) != OUTSIDE


@njit(cache=True)
def segment_meets_disc(ax, ay, bx, by, cx, cy, r):
    """The closed segment a-b meets the closed disc (c, r)."""
    ex = bx - ax
    ey = by - ay
    wx = cx - ax
    wy = cy - ay
    ee = ex * ex + ey * ey
    s = 0.0
    if ee > 0.0:
        s = min(max((wx * ex + wy * ey) / ee, 0.0), 1.0)
    dx = wx - s * ex
    dy = wy - s * ey
    return dx * dx + dy * dy <= r * r


@njit(cache=True)
def segments_blocked_kernel(seg_a, seg_b, poly_offsets, circ_c, circ_r, bbox_lo, bbox_hi, p, q, out):
    """``out[m]`` is True if the closed segment p[m]-q[m] meets any closed obstacle."""
    n_poly = poly_offsets.shape[0] - 1
    n_circ = circ_r.shape[0]
    for m in range(p.shape[0]):
        p0x = p[m, 0]
        p0y = p[m, 1]
        p1x = q[m, 0]
        p1y = q[m, 1]
        lox = min(p0x, p1x)
        hix = max(p0x, p1x)
        loy = min(p0y, p1y)
        hiy = max(p0y, p1y)
        blocked = False
        for pg in range(n_poly):
            if hix < bbox_lo[pg, 0] or lox > bbox_hi[pg, 0] or hiy < bbox_lo[pg, 1] or loy > bbox_hi[pg, 1]:
                continue
            blocked = segment_meets_polygon(p0x, p0y, p1x, p1y, seg_a, seg_b, poly_offsets[pg], poly_offsets[pg + 1])
            if blocked:
                break
        if not blocked:
            for c in range(n_circ):
                if segment_meets_disc(p0x, p0y, p1x, p1y, circ_c[c, 0], circ_c[c, 1], circ_r[c]):
                    blocked = True
                    break
        out[m] = blocked


# ---------------------------------------------------------------------------------------------
# ESDF bilinear query
# ---------------------------------------------------------------------------------------------


@njit(cache=True)
def esdf_query_kernel(values, ox, oy, res, points, out_v, out_g):
    """Bilinear interpolation of node values and its analytic gradient; clamps to the grid.

    Cells whose corners are not all finite (an empty world stores +inf) give the minimum
    corner value and a zero gradient.
    """
    ny = values.shape[0]
    nx = values.shape[1]
    xmax = (nx - 1) * 1.0
    ymax = (ny - 1) * 1.0
    inv = 1.0 / res
    for m in range(points.shape[0]):
        fx = min(max((points[m, 0] - ox) * inv, 0.0), xmax)
        fy = min(max((points[m, 1] - oy) * inv, 0.0), ymax)
        ix = min(int(math.floor(fx)), nx - 2)
        iy = min(int(math.floor(fy)), ny - 2)
        u = fx - ix
        v = fy - iy
        v00 = values[iy, ix]
        v10 = values[iy, ix + 1]
        v01 = values[iy + 1, ix]
        v11 = values[iy + 1, ix + 1]
        if not (math.isfinite(v00) and math.isfinite(v10) and math.isfinite(v01) and math.isfinite(v11)):
            out_v[m] = min(min(v00, v10), min(v01, v11))
            out_g[m, 0] = 0.0
            out_g[m, 1] = 0.0
            continue
        out_v[m] = (1.0 - v) * ((1.0 - u) * v00 + u * v10) + v * ((1.0 - u) * v01 + u * v11)
        out_g[m, 0] = ((1.0 - v) * (v10 - v00) + v * (v11 - v01)) * inv
        out_g[m, 1] = ((1.0 - u) * (v01 - v00) + u * (v11 - v10)) * inv
