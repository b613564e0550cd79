"""A uniform grid over the primitives of a large 3-D world (voxel maps, point clouds, mockamap
worlds: ``docs/maps.md``), so a query visits only the primitives near it.

A 3-D geometry with at least :data:`INDEX3D_MIN_PRIMITIVES` primitives (prisms, cylinders and
spheres together) is indexed: the bounding box of all primitives is cut into cubic cells, each
listing the primitives whose bounding box (grown by a rounding margin) overlaps it. The signed
distance visits the cells in cubic shells around the point until no unvisited primitive can be
nearer; the inside test reads the point's own cell; the line-of-sight test and the range scan
walk the cells under each segment or ray, a cell-long piece at a time, a ray stopping once its
nearest hit ends before the next piece. Per primitive they call the plain kernels' own
per-primitive functions (:mod:`._kernels3d`), and the results are minima (or any-of) over the same
candidates, so distances, directions, ranges, inside and line-of-sight tests equal the plain
kernels' bit for bit. Smaller geometries (every built-in and generated forest) keep the plain
scan, and the ESDF of an indexed world is its exact signed distance node by node.

The design is the planar index's (:mod:`swarmnav.sensing.index`) with a third axis.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from swarmnav.sensing._kernels3d import (
    _bbox_gap2,
    _cull2,
    _extrude_offset,
    _extrude_sd,
    _poly_sd2,
    _ray_box,
    box_misses,
    cylinder_contains,
    cylinder_ray,
    cylinder_sd,
    extruded_meets_segment,
    prism_contains,
    prism_ray,
    sphere_contains,
    sphere_meets_segment,
    sphere_ray,
    sphere_sd,
    unit_direction,
)
from swarmnav.sensing.index import MAX_CELL, _cell_range

#: Primitives from which a 3-D geometry is indexed (our choice: the SPH 3-D forests of Table II
#: have about 100-200 and scan faster plainly, and stay on the plain kernels; a voxel map or a
#: mockamap world has thousands).
INDEX3D_MIN_PRIMITIVES = 256

#: Primitives a cell lists on average, at most (our choice: on the default mockamap world 1 gave
#: 0.65 m cells listing 3.8 primitives each and the fastest range scan of 0.25-4, `bench_maps.py --3d`).
CELL_LOAD = 1.0

#: Cells per primitive at most (our choice: bounds the grid's memory when the primitives'
#: bounding boxes span a large, mostly empty volume).
MAX_CELLS_PER_PRIMITIVE = 8

_cache: dict[int, tuple] = {}


def box_index(geom) -> tuple | None:
    """The grid over a 3-D ``geom``'s primitives (built once per geometry and kept with it), or
    None for a planar geometry, one with fewer than :data:`INDEX3D_MIN_PRIMITIVES` primitives or
    one with an unbounded primitive.

    Returns ``(x0, y0, z0, cell, nx, ny, nz, start, items)``: cell ``(ix, iy, iz)`` covers
    ``[x0 + ix cell, x0 + (ix + 1) cell] x ...`` and lists the primitives (indices into the
    kernels' prisms-cylinders-spheres order) ``items[start[c]:start[c + 1]]``, ``c = (iz ny +
    iy) nx + ix``.
    """
    if geom.dim != 3:
        return None
    n = int(len(geom.bbox_lo))
    if n < INDEX3D_MIN_PRIMITIVES:
        return None
    hit = _cache.get(id(geom))
    if hit is not None and hit[0] is geom:
        return hit[1]
    lo = np.ascontiguousarray(geom.bbox_lo, dtype=np.float64).reshape(-1, 3)
    hi = np.ascontiguousarray(geom.bbox_hi, dtype=np.float64).reshape(-1, 3)
    index = None
    if np.isfinite(lo).all() and np.isfinite(hi).all():
        o = lo.min(axis=0)
        ext = np.maximum(hi.max(axis=0) - o, 1e-9)
        cell = min(float(np.cbrt(ext.prod() * CELL_LOAD / n)), MAX_CELL)
        while True:
            counts = [max(int(math.ceil(e / cell)), 1) for e in ext]
            if counts[0] * counts[1] * counts[2] <= MAX_CELLS_PER_PRIMITIVE * n:
                break
            cell *= 1.25
        nx, ny, nz = counts
        start, items = _build_kernel(lo, hi, float(o[0]), float(o[1]), float(o[2]), 1.0 / cell, nx, ny, nz)
        index = (float(o[0]), float(o[1]), float(o[2]), float(cell), nx, ny, nz, start, items)
    if len(_cache) >= 8:
        _cache.pop(next(iter(_cache)))
    _cache[id(geom)] = (geom, index)  # the geometry itself is kept, so its id is not reused
    return index


@njit(cache=True)
def _pad(v):
    """A margin [m] round a bounding-box coordinate that covers the rounding of the exact tests
    near it (a point an ulp outside a disc's box may still pass its test)."""
    return 1e-9 * (1.0 + abs(v))


@njit(cache=True)
def _build_kernel(lo, hi, x0, y0, z0, inv, nx, ny, nz):
    n = lo.shape[0]
    start = np.zeros(nx * ny * nz + 1, dtype=np.int64)
    for rep in range(2):  # count, then fill
        if rep == 1:
            for c in range(nx * ny * nz):
                start[c + 1] += start[c]
            items = np.empty(start[nx * ny * nz], dtype=np.int64)
            fill = start[:-1].copy()
        for k in range(n):
            ix0, ix1 = _cell_range(lo[k, 0] - _pad(lo[k, 0]), hi[k, 0] + _pad(hi[k, 0]), x0, inv, nx)
            iy0, iy1 = _cell_range(lo[k, 1] - _pad(lo[k, 1]), hi[k, 1] + _pad(hi[k, 1]), y0, inv, ny)
            iz0, iz1 = _cell_range(lo[k, 2] - _pad(lo[k, 2]), hi[k, 2] + _pad(hi[k, 2]), z0, inv, nz)
            for iz in range(iz0, iz1 + 1):
                for iy in range(iy0, iy1 + 1):
                    for ix in range(ix0, ix1 + 1):
                        c = (iz * ny + iy) * nx + ix
                        if rep == 0:
                            start[c + 1] += 1
                        else:
                            items[fill[c]] = k
                            fill[c] += 1
    return start, items


@njit(cache=True)
def _cell_of(p, o, inv, n):
    return min(max(int(math.floor((p - o) * inv)), 0), n - 1)


@njit(cache=True)
def _slack(px, py, pz, x0, y0, z0, cell, nx, ny, nz):
    """Rounding margin [m] of the cells' faces near the point."""
    return 1e-9 * (abs(px) + abs(py) + abs(pz) + abs(x0) + abs(y0) + abs(z0) + (nx + ny + nz) * cell + 1.0)


@njit(cache=True)
def _beyond3(px, py, pz, x0, y0, z0, cell, nx, ny, nz, cx, cy, cz, ring):
    """Distance from the point to the nearest face of the block of cells within ``ring`` of
    (cx, cy, cz) beyond which the grid goes on (inf when the block covers the grid)."""
    bound = np.inf
    if cx - ring > 0:
        bound = min(bound, px - (x0 + (cx - ring) * cell))
    if cx + ring < nx - 1:
        bound = min(bound, x0 + (cx + ring + 1) * cell - px)
    if cy - ring > 0:
        bound = min(bound, py - (y0 + (cy - ring) * cell))
    if cy + ring < ny - 1:
        bound = min(bound, y0 + (cy + ring + 1) * cell - py)
    if cz - ring > 0:
        bound = min(bound, pz - (z0 + (cz - ring) * cell))
    if cz + ring < nz - 1:
        bound = min(bound, z0 + (cz + ring + 1) * cell - pz)
    return bound


@njit(cache=True)
def _nearest_point(px, py, pz, seg_a, seg_b, poly_offsets, circ_c, circ_r, poly_z, circ_z, sph_c, sph_r,
                   bbox_lo, bbox_hi, x0, y0, z0, cell, nx, ny, nz, start, items, seen, stamp, want_dir):
    """``(best, vx, vy, vz)``: the signed distance [m] at the point and the offset to the nearest
    boundary point of the first primitive (in the plain order) that has it.

    Cells are visited in cubic shells of growing size around the point's; once the best value is
    no farther than the nearest face of the visited block (beyond which every unvisited primitive
    lies), no unvisited primitive can reach or tie it. Ties among visited primitives go to the
    lowest index, as the plain scan's strict minimum gives.
    """
    inv = 1.0 / cell
    slack = _slack(px, py, pz, x0, y0, z0, cell, nx, ny, nz)
    n_poly = poly_offsets.shape[0] - 1
    n_circ = circ_r.shape[0]
    best = np.inf
    bk = -1
    vx = 0.0
    vy = 0.0
    vz = 0.0
    cx = _cell_of(px, x0, inv, nx)
    cy = _cell_of(py, y0, inv, ny)
    cz = _cell_of(pz, z0, inv, nz)
    ring = 0
    while True:
        for iz in range(max(cz - ring, 0), min(cz + ring, nz - 1) + 1):
            for iy in range(max(cy - ring, 0), min(cy + ring, ny - 1) + 1):
                face = ring == 0 or iz == cz - ring or iz == cz + ring or iy == cy - ring or iy == cy + ring
                step = 1 if face else 2 * ring
                for ix in range(cx - ring, cx + ring + 1, step):
                    if ix < 0 or ix >= nx:
                        continue
                    c = (iz * ny + iy) * nx + ix
                    for j in range(start[c], start[c + 1]):
                        k = items[j]
                        if seen[k] == stamp:
                            continue
                        seen[k] = stamp
                        if _bbox_gap2(px, py, pz, bbox_lo, bbox_hi, k) > _cull2(best):
                            continue
                        if k < n_poly:
                            d2, qx, qy = _poly_sd2(px, py, seg_a, seg_b, poly_offsets[k], poly_offsets[k + 1])
                            za = poly_z[k, 0]
                            zb = poly_z[k, 1]
                            sd = _extrude_sd(d2, pz, za, zb)
                        elif k < n_poly + n_circ:
                            c = k - n_poly
                            za = circ_z[c, 0]
                            zb = circ_z[c, 1]
                            sd, d2, qx, qy = cylinder_sd(px, py, pz, circ_c[c, 0], circ_c[c, 1], circ_r[c], za, zb)
                        else:
                            b = k - n_poly - n_circ
                            sd, ox, oy, oz = sphere_sd(px, py, pz, sph_c[b, 0], sph_c[b, 1], sph_c[b, 2], sph_r[b])
                        if sd < best or (sd == best and k < bk):
                            best = sd
                            bk = k
                            if want_dir:
                                if k < n_poly + n_circ:
                                    vx, vy, vz = _extrude_offset(d2, qx, qy, pz, za, zb)
                                else:
                                    vx = ox
                                    vy = oy
                                    vz = oz
        # an unvisited primitive's box lies beyond a face of the visited block: its distance is
        # at least `bound` (less the cells' rounding and the 1e-9 m of _cull2)
        bound = _beyond3(px, py, pz, x0, y0, z0, cell, nx, ny, nz, cx, cy, cz, ring) - slack - 1e-9
        if bound == np.inf or best < bound:
            break
        ring += 1
    return best, vx, vy, vz


@njit(cache=True)
def nearest3d_indexed_kernel(seg_a, seg_b, poly_offsets, circ_c, circ_r, poly_z, circ_z, sph_c, sph_r,
                             bbox_lo, bbox_hi, x0, y0, z0, cell, nx, ny, nz, start, items,
                             points, out_d, out_dir, want_dir):
    """As :func:`nearest3d_kernel`, visiting only the primitives the grid lists near each point."""
    seen = np.full(bbox_lo.shape[0], -1, dtype=np.int64)
    for i in range(points.shape[0]):
        px = points[i, 0]
        py = points[i, 1]
        pz = points[i, 2]
        best, vx, vy, vz = _nearest_point(px, py, pz, seg_a, seg_b, poly_offsets, circ_c, circ_r, poly_z, circ_z,
                                          sph_c, sph_r, bbox_lo, bbox_hi, x0, y0, z0, cell, nx, ny, nz, start, items,
                                          seen, i, want_dir)
        out_d[i] = best
        if want_dir:
            unit_direction(best, vx, vy, vz, out_dir, i)


@njit(cache=True)
def esdf3d_indexed_build_kernel(seg_a, seg_b, poly_offsets, circ_c, circ_r, poly_z, circ_z, sph_c, sph_r,
                                bbox_lo, bbox_hi, x0, y0, z0, cell, nx, ny, nz, start, items, ox, oy, oz, res, out):
    """``out[iz, iy, ix]`` <- the exact signed distance [m] at node ``o + res * (ix, iy, iz)``,
    bit for bit :func:`nearest3d_kernel` there, each node searched through the grid."""
    gz, gy, gx = out.shape
    seen = np.full(bbox_lo.shape[0], -1, dtype=np.int64)
    stamp = 0
    for iz in range(gz):
        pz = oz + res * iz
        for iy in range(gy):
            py = oy + res * iy
            for ix in range(gx):
                px = ox + res * ix
                best, _, _, _ = _nearest_point(px, py, pz, seg_a, seg_b, poly_offsets, circ_c, circ_r, poly_z, circ_z,
                                               sph_c, sph_r, bbox_lo, bbox_hi, x0, y0, z0, cell, nx, ny, nz, start,
                                               items, seen, stamp, False)
                out[iz, iy, ix] = best
                stamp += 1


@njit(cache=True)
def _in_collision_indexed(px, py, pz, seg_a, seg_b, poly_offsets, circ_c, circ_r, poly_z, circ_z, sph_c, sph_r,
                          bbox_lo, bbox_hi, x0, y0, z0, cell, nx, ny, nz, start, items):
    """As the plain inside test: a primitive holding the point lists the point's cell (its box,
    grown by the margin, holds the point; the cell is found by the same floor and clamp)."""
    n_poly = poly_offsets.shape[0] - 1
    n_circ = circ_r.shape[0]
    inv = 1.0 / cell
    c = (_cell_of(pz, z0, inv, nz) * ny + _cell_of(py, y0, inv, ny)) * nx + _cell_of(px, x0, inv, nx)
    for j in range(start[c], start[c + 1]):
        k = items[j]
        if k < n_poly:
            if _bbox_gap2(px, py, pz, bbox_lo, bbox_hi, k) > 0.0:
                continue
            if prism_contains(px, py, pz, seg_a, seg_b, poly_offsets[k], poly_offsets[k + 1], poly_z[k, 0],
                              poly_z[k, 1]):
                return True
        elif k < n_poly + n_circ:
            q = k - n_poly
            if cylinder_contains(px, py, pz, circ_c[q, 0], circ_c[q, 1], circ_r[q], circ_z[q, 0], circ_z[q, 1]):
                return True
        else:
            b = k - n_poly - n_circ
            if sphere_contains(px, py, pz, sph_c[b, 0], sph_c[b, 1], sph_c[b, 2], sph_r[b]):
                return True
    return False


@njit(cache=True)
def points_inside3d_indexed_kernel(seg_a, seg_b, poly_offsets, circ_c, circ_r, poly_z, circ_z, sph_c, sph_r,
                                   bbox_lo, bbox_hi, x0, y0, z0, cell, nx, ny, nz, start, items, points, out):
    """``out[m]``: ``points[m]`` is inside or on a primitive (as ``points_inside3d_kernel``)."""
    for i in range(points.shape[0]):
        out[i] = _in_collision_indexed(points[i, 0], points[i, 1], points[i, 2], seg_a, seg_b, poly_offsets, circ_c,
                                       circ_r, poly_z, circ_z, sph_c, sph_r, bbox_lo, bbox_hi, x0, y0, z0, cell, nx,
                                       ny, nz, start, items)


@njit(cache=True)
def _piece_cells(ax, ay, az, bx, by, bz, slack, x0, y0, z0, inv, nx, ny, nz):
    """Cell ranges under the box of the piece a-b grown by ``slack``."""
    ix0, ix1 = _cell_range(min(ax, bx) - slack, max(ax, bx) + slack, x0, inv, nx)
    iy0, iy1 = _cell_range(min(ay, by) - slack, max(ay, by) + slack, y0, inv, ny)
    iz0, iz1 = _cell_range(min(az, bz) - slack, max(az, bz) + slack, z0, inv, nz)
    return ix0, ix1, iy0, iy1, iz0, iz1


@njit(cache=True)
def segments_blocked3d_indexed_kernel(seg_a, seg_b, poly_offsets, circ_c, circ_r, poly_z, circ_z, sph_c, sph_r,
                                      bbox_lo, bbox_hi, x0, y0, z0, cell, nx, ny, nz, start, items, p, q, out):
    """As ``segments_blocked3d_kernel``: only the primitives listed in the cells under the segment,
    walked a cell-long piece at a time (each piece's box grown by the cells' rounding margin),
    can meet it."""
    n_poly = poly_offsets.shape[0] - 1
    n_circ = circ_r.shape[0]
    inv = 1.0 / cell
    seen = np.full(bbox_lo.shape[0], -1, dtype=np.int64)
    cell_seen = np.full(nx * ny * nz, -1, dtype=np.int64)
    for m in range(p.shape[0]):
        p0x = p[m, 0]
        p0y = p[m, 1]
        p0z = p[m, 2]
        p1x = q[m, 0]
        p1y = q[m, 1]
        p1z = q[m, 2]
        ex = p1x - p0x
        ey = p1y - p0y
        ez = p1z - p0z
        lox = min(p0x, p1x)
        hix = max(p0x, p1x)
        loy = min(p0y, p1y)
        hiy = max(p0y, p1y)
        loz = min(p0z, p1z)
        hiz = max(p0z, p1z)
        slack = _slack(abs(p0x) + abs(p1x), abs(p0y) + abs(p1y), abs(p0z) + abs(p1z), x0, y0, z0, cell, nx, ny, nz)
        pieces = max(int(math.ceil(math.sqrt(ex * ex + ey * ey + ez * ez) * inv)), 1)
        blocked = False
        for s in range(pieces):
            s0 = s / pieces
            s1 = (s + 1) / pieces
            ix0, ix1, iy0, iy1, iz0, iz1 = _piece_cells(p0x + s0 * ex, p0y + s0 * ey, p0z + s0 * ez,
                                                        p0x + s1 * ex, p0y + s1 * ey, p0z + s1 * ez,
                                                        slack, x0, y0, z0, inv, nx, ny, nz)
            for iz in range(iz0, iz1 + 1):
                for iy in range(iy0, iy1 + 1):
                    for ix in range(ix0, ix1 + 1):
                        c = (iz * ny + iy) * nx + ix
                        if cell_seen[c] == m:
                            continue
                        cell_seen[c] = m
                        for j in range(start[c], start[c + 1]):
                            k = items[j]
                            if seen[k] == m:
                                continue
                            seen[k] = m
                            if box_misses(lox, hix, loy, hiy, loz, hiz, bbox_lo, bbox_hi, k):
                                continue
                            if k < n_poly:
                                blocked = extruded_meets_segment(p0x, p0y, p0z, p1x, p1y, p1z, poly_z[k, 0],
                                                                 poly_z[k, 1], seg_a, seg_b, poly_offsets[k],
                                                                 poly_offsets[k + 1], 0.0, 0.0, 0.0)
                            elif k < n_poly + n_circ:
                                c2 = k - n_poly
                                blocked = extruded_meets_segment(p0x, p0y, p0z, p1x, p1y, p1z, circ_z[c2, 0],
                                                                 circ_z[c2, 1], seg_a, seg_b, 0, 0, circ_c[c2, 0],
                                                                 circ_c[c2, 1], circ_r[c2])
                            else:
                                b = k - n_poly - n_circ
                                blocked = sphere_meets_segment(p0x, p0y, p0z, p1x, p1y, p1z, sph_c[b, 0], sph_c[b, 1],
                                                               sph_c[b, 2], sph_r[b])
                            if blocked:
                                break
                        if blocked:
                            break
                    if blocked:
                        break
                if blocked:
                    break
            if blocked:
                break
        out[m] = blocked


@njit(cache=True)
def range_scan_indexed_kernel(seg_a, seg_b, poly_offsets, circ_c, circ_r, poly_z, circ_z, sph_c, sph_r,
                              bbox_lo, bbox_hi, x0, y0, z0, cell, nx, ny, nz, start, items,
                              positions, dirs, max_range, out):
    """As ``range_scan_kernel``: each ray walks the cells under it, a cell-long piece at a time,
    and stops once its nearest hit ends before the next piece.

    A primitive that shortens a ray meets it at a point nearer than the ray's current end; that
    point lies in a piece walked (grown by the cells' rounding margin) and in the primitive's
    box, so the cell holding it lists the primitive: no hit is missed, and each primitive lowers
    the ray as the plain scan's does.
    """
    n_poly = poly_offsets.shape[0] - 1
    n_circ = circ_r.shape[0]
    inv = 1.0 / cell
    n_rays = dirs.shape[0]
    r2max = max_range * max_range
    seen = np.full(bbox_lo.shape[0], -1, dtype=np.int64)
    cell_seen = np.full(nx * ny * nz, -1, dtype=np.int64)
    for i in range(positions.shape[0]):
        px = positions[i, 0]
        py = positions[i, 1]
        pz = positions[i, 2]
        row = out[i]
        if _in_collision_indexed(px, py, pz, seg_a, seg_b, poly_offsets, circ_c, circ_r, poly_z, circ_z, sph_c, sph_r,
                                 bbox_lo, bbox_hi, x0, y0, z0, cell, nx, ny, nz, start, items):
            for r in range(n_rays):
                row[r] = 0.0
            continue
        slack = _slack(px, py, pz, x0, y0, z0, cell, nx, ny, nz) + 1e-9 * max_range
        for r in range(n_rays):
            ux = dirs[r, 0]
            uy = dirs[r, 1]
            uz = dirs[r, 2]
            stamp = i * n_rays + r
            t_end = max_range
            t = 0.0
            while t < t_end:
                t1 = min(t + cell, t_end)
                ix0, ix1, iy0, iy1, iz0, iz1 = _piece_cells(px + t * ux, py + t * uy, pz + t * uz,
                                                            px + t1 * ux, py + t1 * uy, pz + t1 * uz,
                                                            slack, x0, y0, z0, inv, nx, ny, nz)
                for iz in range(iz0, iz1 + 1):
                    for iy in range(iy0, iy1 + 1):
                        for ix in range(ix0, ix1 + 1):
                            c = (iz * ny + iy) * nx + ix
                            if cell_seen[c] == stamp:
                                continue
                            cell_seen[c] = stamp
                            for j in range(start[c], start[c + 1]):
                                k = items[j]
                                if seen[k] == stamp:
                                    continue
                                seen[k] = stamp
                                if _bbox_gap2(px, py, pz, bbox_lo, bbox_hi, k) >= r2max:
                                    continue  # as the plain scan: out of range from this position
                                if _ray_box(px, py, pz, ux, uy, uz, bbox_lo, bbox_hi, k, t_end) == np.inf:
                                    continue
                                if k < n_poly:
                                    t_end = prism_ray(px, py, pz, ux, uy, uz, t_end, seg_a, seg_b, poly_offsets[k],
                                                      poly_offsets[k + 1], poly_z[k, 0], poly_z[k, 1])
                                elif k < n_poly + n_circ:
                                    q = k - n_poly
                                    t_end = cylinder_ray(px, py, pz, ux, uy, uz, t_end, circ_c[q, 0], circ_c[q, 1],
                                                         circ_r[q], circ_z[q, 0], circ_z[q, 1])
                                else:
                                    b = k - n_poly - n_circ
                                    t_end = sphere_ray(px, py, pz, ux, uy, uz, t_end, sph_c[b, 0], sph_c[b, 1],
                                                       sph_c[b, 2], sph_r[b])
                t = t1
            row[r] = t_end
