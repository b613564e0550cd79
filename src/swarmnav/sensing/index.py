"""A uniform grid over the polygons of a large planar world, so a query visits only the polygons
near it (maps from files: ``docs/maps.md``).

A geometry with at least :data:`INDEX_MIN_POLYGONS` polygons is indexed: the bounding box of
all polygons is cut into square cells, each listing the polygons whose bounding box overlaps
it. The LiDAR ring visits the cells in rings around the agent until no ray reaches past them,
the signed distance the cells in rings until no unvisited polygon can be nearer, the inside
test the point's own cell, the line-of-sight test the cells under the segment. They compute, per polygon, exactly what the plain scan computes, and their results are
minima over the same candidates, so ranges, distances and inside tests are the plain
kernels' bit for bit (only the direction to the nearest point may differ where two boundary
points are exactly as near). Smaller geometries (every built-in and generated scene) keep the
plain scan.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from swarmnav.sensing._kernels import (
    OUTSIDE,
    _polygon_status,
    _beyond,
    circles_rays,
    nearest_cells_kernel,
    polygon_orientations,
    polygon_rays,
    segment_meets_disc,
    segment_meets_polygon,
)

#: Polygons from which a planar geometry is indexed (our choice: below a few hundred boxes the
#: plain scan costs less than a 20 m LiDAR ring's walk over grid cells; every built-in and
#: generated scene stays below it, so their runs are unchanged).
INDEX_MIN_POLYGONS = 256
#: Polygons a cell lists on average, at most (our choice: a cell about twice a random map's box).
CELL_LOAD = 4.0

#: Largest cell side [m] (our choice: a fifth of a 20 m LiDAR range, so a query near a few long
#: walls does not walk cells far larger than its range).
MAX_CELL = 4.0

_cache: dict[int, tuple] = {}


def polygon_index(geom) -> tuple | None:
    """The grid over ``geom``'s polygons (built once per geometry and kept with it), or None when
    the geometry is 3-D or has fewer than :data:`INDEX_MIN_POLYGONS` polygons.

    Returns ``(x0, y0, cell, nx, ny, start, items)``: cell ``(ix, iy)`` covers
    ``[x0 + ix cell, x0 + (ix + 1) cell] x [y0 + iy cell, ...]`` and lists the polygons
    ``items[start[iy nx + ix]:start[iy nx + ix + 1]]``.
    """
    n_poly = len(geom.poly_offsets) - 1
    if geom.dim != 2 or n_poly < INDEX_MIN_POLYGONS:
        return None
    hit = _cache.get(id(geom))
    if hit is not None and hit[0] is geom:
        return hit[1]
    lo = np.ascontiguousarray(geom.bbox_lo[:n_poly], dtype=np.float64)
    hi = np.ascontiguousarray(geom.bbox_hi[:n_poly], dtype=np.float64)
    x0, y0 = lo.min(axis=0)
    w, h = hi.max(axis=0) - (x0, y0)
    cell = max(min(math.sqrt(max(w * h, 1e-300) * CELL_LOAD / n_poly), MAX_CELL), 1e-9)
    nx, ny = max(int(math.ceil(w / cell)), 1), max(int(math.ceil(h / cell)), 1)
    start, items = _build_kernel(lo, hi, float(x0), float(y0), 1.0 / cell, nx, ny)
    index = (float(x0), float(y0), float(cell), nx, ny, start, items)
    if len(_cache) >= 8:
        _cache.pop(next(iter(_cache)))
    _cache[id(geom)] = (geom, index)  # the geometry itself is kept, so its id is not reused
    return index


@njit(cache=True)
def _cell_range(lo, hi, o, inv, n):
    a = int(math.floor((lo - o) * inv))
    b = int(math.floor((hi - o) * inv))
    return min(max(a, 0), n - 1), min(max(b, 0), n - 1)


@njit(cache=True)
def _build_kernel(lo, hi, x0, y0, inv, nx, ny):
    n_poly = lo.shape[0]
    start = np.zeros(nx * ny + 1, dtype=np.int64)
    for p in range(n_poly):
        ix0, ix1 = _cell_range(lo[p, 0], hi[p, 0], x0, inv, nx)
        iy0, iy1 = _cell_range(lo[p, 1], hi[p, 1], y0, inv, ny)
        for iy in range(iy0, iy1 + 1):
            for ix in range(ix0, ix1 + 1):
                start[iy * nx + ix + 1] += 1
    for c in range(nx * ny):
        start[c + 1] += start[c]
    items = np.empty(start[nx * ny], dtype=np.int64)
    fill = start[:-1].copy()
    for p in range(n_poly):
        ix0, ix1 = _cell_range(lo[p, 0], hi[p, 0], x0, inv, nx)
        iy0, iy1 = _cell_range(lo[p, 1], hi[p, 1], y0, inv, ny)
        for iy in range(iy0, iy1 + 1):
            for ix in range(ix0, ix1 + 1):
                items[fill[iy * nx + ix]] = p
                fill[iy * nx + ix] += 1
    return start, items


@njit(cache=True)
def _in_collision_indexed(px, py, seg_a, seg_b, poly_offsets, circ_c, circ_r, bbox_lo, bbox_hi,
                          x0, y0, cell, nx, ny, start, items):
    """As the plain inside test: only the polygons listed in the point's cell can hold it."""
    # a polygon whose bounding box holds the point is listed in the point's cell: cells are found
    # by the same rounding (floor, then clamped to the grid), which keeps lo <= p <= hi in order
    inv = 1.0 / cell
    ix = min(max(int(math.floor((px - x0) * inv)), 0), nx - 1)
    iy = min(max(int(math.floor((py - y0) * inv)), 0), ny - 1)
    for k in range(start[iy * nx + ix], start[iy * nx + ix + 1]):
        p = items[k]
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
def points_inside_indexed_kernel(seg_a, seg_b, poly_offsets, circ_c, circ_r, bbox_lo, bbox_hi,
                                 x0, y0, cell, nx, ny, start, items, points, out):
    """``out[m]``: ``points[m]`` is inside or on an obstacle (as ``points_inside_kernel``)."""
    for i in range(points.shape[0]):
        out[i] = _in_collision_indexed(points[i, 0], points[i, 1], seg_a, seg_b, poly_offsets, circ_c, circ_r,
                                       bbox_lo, bbox_hi, x0, y0, cell, nx, ny, start, items)


@njit(cache=True)
def lidar_indexed_kernel(seg_a, seg_b, poly_offsets, circ_c, circ_r, bbox_lo, bbox_hi,
                         x0, y0, cell, nx, ny, start, items, positions, cos_t, sin_t, max_range, out):
    """As ``lidar_kernel``, visiting the polygons cell ring by cell ring from the agent's cell and
    stopping once no ray reaches beyond the cells visited (at ``max_range`` at the latest)."""
    n_rays = cos_t.shape[0]
    n_poly = poly_offsets.shape[0] - 1
    inv_dth = n_rays / (2.0 * math.pi)
    r2max = max_range * max_range
    inv = 1.0 / cell
    orient = polygon_orientations(seg_a, seg_b, poly_offsets)
    seen = np.full(n_poly, -1, dtype=np.int64)
    open_limit = n_rays // 8  # our choice: rings while more rays than this reach past them
    for i in range(positions.shape[0]):
        px = positions[i, 0]
        py = positions[i, 1]
        row = out[i]
        if _in_collision_indexed(px, py, seg_a, seg_b, poly_offsets, circ_c, circ_r, bbox_lo, bbox_hi,
                                 x0, y0, cell, nx, ny, start, items):
            for r in range(n_rays):
                row[r] = 0.0
            continue
        for r in range(n_rays):
            row[r] = max_range
        circles_rays(row, px, py, circ_c, circ_r, cos_t, sin_t, max_range, inv_dth)
        slack = 1e-9 * (abs(px) + abs(py) + abs(x0) + abs(y0) + (nx + ny) * cell)
        cx = min(max(int(math.floor((px - x0) * inv)), 0), nx - 1)
        cy = min(max(int(math.floor((py - y0) * inv)), 0), ny - 1)
        ring = 0
        while True:  # cells in square rings around the agent's, nearest first
            for iy in range(max(cy - ring, 0), min(cy + ring, ny - 1) + 1):
                step = 1 if (iy == cy - ring or iy == cy + ring or ring == 0) else 2 * ring
                for ix in range(cx - ring, cx + ring + 1, step):
                    if ix < 0 or ix >= nx:
                        continue
                    for k in range(start[iy * nx + ix], start[iy * nx + ix + 1]):
                        p = items[k]
                        if seen[p] == i:
                            continue
                        seen[p] = i
                        polygon_rays(row, p, px, py, orient[p], seg_a, seg_b, poly_offsets, bbox_lo, bbox_hi,
                                     cos_t, sin_t, r2max, inv_dth)
            # a polygon not visited lies beyond the block of visited cells, at least `bound` away:
            # once every ray is that short, it can shorten none (a hit must be nearer to count)
            bound = _beyond(px, py, x0, y0, cell, nx, ny, cx, cy, ring) - slack
            if bound == np.inf:
                break
            longest = 0.0
            n_open = 0
            for r in range(n_rays):
                longest = max(longest, row[r])
                if row[r] > bound:
                    n_open += 1
            if longest <= bound:
                break
            if n_open <= open_limit:
                # a few rays reach on (through gaps, on a map of scattered cells): walk the
                # cells along each of them instead of whole rings
                _walk_open_rays(row, px, py, bound, slack, seg_a, seg_b, poly_offsets, bbox_lo, bbox_hi, orient,
                                x0, y0, cell, inv, nx, ny, start, items, seen, i, cos_t, sin_t, r2max, inv_dth)
                break
            ring += 1


@njit(cache=True)
def _walk_open_rays(row, px, py, bound, slack, seg_a, seg_b, poly_offsets, bbox_lo, bbox_hi, orient,
                    x0, y0, cell, inv, nx, ny, start, items, seen, i, cos_t, sin_t, r2max, inv_dth):
    """Every ray longer than ``bound`` [m] (all polygons nearer than that are handled): the
    polygons listed in the cells under each piece, a cell long, of the ray from ``bound`` to its
    current end, handled as the ring handles them, until the ray ends before the next piece.

    A polygon that shortens ray r meets it at some point q with |q - p| < row[r]; q lies in the
    piece's box (grown by ``slack``) and in the polygon's bounding box, so the cell holding q is
    in both cell ranges and lists the polygon: no hit is missed, and each polygon lowers the rays
    exactly as the plain scan does.
    """
    for r in range(cos_t.shape[0]):
        t = max(bound, 0.0)
        while t < row[r]:
            t1 = min(t + cell, row[r])
            ax = px + t * cos_t[r]
            ay = py + t * sin_t[r]
            bx = px + t1 * cos_t[r]
            by = py + t1 * sin_t[r]
            ix0, ix1 = _cell_range(min(ax, bx) - slack, max(ax, bx) + slack, x0, inv, nx)
            iy0, iy1 = _cell_range(min(ay, by) - slack, max(ay, by) + slack, y0, inv, ny)
            for iy in range(iy0, iy1 + 1):
                for ix in range(ix0, ix1 + 1):
                    for k in range(start[iy * nx + ix], start[iy * nx + ix + 1]):
                        p = items[k]
                        if seen[p] == i:
                            continue
                        seen[p] = i
                        polygon_rays(row, p, px, py, orient[p], seg_a, seg_b, poly_offsets, bbox_lo, bbox_hi,
                                     cos_t, sin_t, r2max, inv_dth)
            t = t1


#: The signed distance over the index: the plain scan's kernel, walking the index's cells.
nearest_indexed_kernel = nearest_cells_kernel


@njit(cache=True)
def segments_blocked_indexed_kernel(seg_a, seg_b, poly_offsets, circ_c, circ_r, bbox_lo, bbox_hi,
                                    x0, y0, cell, nx, ny, start, items, p, q, out):
    """As ``segments_blocked_kernel``: only the polygons listed in the cells under the segment's
    bounding box can meet it."""
    n_poly = poly_offsets.shape[0] - 1
    inv = 1.0 / cell
    seen = np.full(n_poly, -1, dtype=np.int64)
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
        ix0, ix1 = _cell_range(lox, hix, x0, inv, nx)
        iy0, iy1 = _cell_range(loy, hiy, y0, inv, ny)
        for iy in range(iy0, iy1 + 1):
            for ix in range(ix0, ix1 + 1):
                for k in range(start[iy * nx + ix], start[iy * nx + ix + 1]):
                    pg = items[k]
                    if seen[pg] == m:
                        continue
                    seen[pg] = m
                    if hix < bbox_lo[pg, 0] or lox > bbox_hi[pg, 0] or hiy < bbox_lo[pg, 1] or loy > bbox_hi[pg, 1]:
                        continue
                    if segment_meets_polygon(p0x, p0y, p1x, p1y, seg_a, seg_b, poly_offsets[pg], poly_offsets[pg + 1]):
                        blocked = True
                        break
                if blocked:
                    break
            if blocked:
                break
        if not blocked:
            for c in range(circ_r.shape[0]):
                if segment_meets_disc(p0x, p0y, p1x, p1y, circ_c[c, 0], circ_c[c, 1], circ_r[c]):
                    blocked = True
                    break
        out[m] = blocked
