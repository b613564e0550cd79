"""Corridor detection from one LiDAR ring, HES Section 3.2 (gap detection by local-minimum pairing).

The paper defers the details to its reference [38]; this is our reconstruction, kept small:

1. **Anchors**: the local minima of the ring among rays that hit something (the nearest point
   of every visible obstacle surface; a flat run of equal ranges counts once).
2. **Pairing**: every two angularly consecutive anchors ``a, b`` bound one sector of the ring.
   Between them the ring rises to a peak and falls again; if the peak is at least ``h_open``
   above the nearer anchor the sector is an *opening* (an obstacle-free direction between two
   obstacle surfaces).
3. **Throat and width**: the sector's hit points are split at the peak into the side of ``a``
   and the side of ``b``; the closest pair of points across the two sides is the throat
   ``(q_a, q_b)`` and its length is the corridor width ``w``. A concave corner, whose two
   sides meet, gets a width of about one ray spacing and is thus never passable.
4. **Direction**: the corridor's exit direction ``n`` is the throat normal on the side of the
   peak ray; the corridor target lies ``through`` metres beyond the throat midpoint along ``n``.

:func:`detect_gaps` (numba) returns every opening; :func:`corridors_toward` keeps those wider
than ``w_pass`` whose exit direction lies within ``toward_deg`` of the goal bearing, the
*candidate corridors leading toward the goal*, and adds the route cost used to choose among them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from swarmnav.methods.hes.forces import candidate_rays, is_local_min

# Columns of the detect_gaps output rows.
GAP_QA_X, GAP_QA_Y, GAP_QB_X, GAP_QB_Y, GAP_W, GAP_NX, GAP_NY, GAP_PEAK = range(8)


@njit(cache=True, inline="always")
def _wrap(i, n):
    """``i % n`` for 0 <= i < 2n, without the division (detect_gaps' inner loops)."""
    return i - n if i >= n else i


@njit(cache=True)
def ring_anchors(ring, max_range):
    """Indices of the local minima of a ring among rays that hit (``d < max_range``); the same
    test (flat runs included) as the active set of the LiDAR repulsion, eq. (35)."""
    n = ring.shape[0]
    out = np.empty(n, dtype=np.int64)
    cand = np.empty(n, dtype=np.int64)
    m = 0
    for c in range(candidate_rays(ring, max_range, np.empty(8 * ((n + 7) // 8), dtype=np.uint8), cand)):
        r = cand[c]
        if ring[r] < max_range and is_local_min(ring, r):
            out[m] = r
            m += 1
    return out[:m]


BLOCK = 8  # rays per block of detect_gaps' closest-pair search


@njit(cache=True)
def _side_boxes(ring, hx, hy, a, t0, t1, n, max_range, box):
    """The rays ``a + t0 .. a + t1`` (mod n) in blocks of BLOCK: ``box[k]`` the x and y range
    (min x, max x, min y, max y) of block k's returns (empty: +inf / -inf); returns the count."""
    nb = (t1 - t0 + BLOCK) // BLOCK
    for k in range(nb):
        box[k, 0] = box[k, 2] = np.inf
        box[k, 1] = box[k, 3] = -np.inf
        for t in range(t0 + k * BLOCK, min(t0 + (k + 1) * BLOCK, t1 + 1)):
            r = _wrap(a + t, n)
            if ring[r] >= max_range:
                continue
            box[k, 0] = min(box[k, 0], hx[r])
            box[k, 1] = max(box[k, 1], hx[r])
            box[k, 2] = min(box[k, 2], hy[r])
            box[k, 3] = max(box[k, 3], hy[r])
    return nb


@njit(cache=True)
def _closest_across(ring, hx, hy, a, pk, span, n, max_range, box):
    """The closest pair of returns across the peak of the sector of ``span`` rays from anchor ``a``
    (side a: rays a .. a + pk - 1, side b: a + pk + 1 .. a + span; returns at ``hx, hy``), the
    first in scan order (side a outer, both ascending): ``(w^2, q_a x, y, q_b x, y)``, w^2 = inf if
    none. ``box``: workspace of (n + BLOCK - 1) // BLOCK rows."""
    # the b side's returns in blocks of BLOCK rays, each with the bounding box of its hits
    nb = _side_boxes(ring, hx, hy, a, pk + 1, span, n, max_range, box)
    wbest = np.inf
    ax = ay = bx = by = 0.0
    for s in range(0, pk):
        ra = _wrap(a + s, n)
        da = ring[ra]
        if da >= max_range:
            continue
        qx = hx[ra]
        qy = hy[ra]
        for k in range(nb):
            # every pair of this block is at least as far as its box (rounding is monotone):
            # one that cannot beat wbest is skipped, the scan order is kept
            ex = max(box[k, 0] - qx, 0.0, qx - box[k, 1])
            ey = max(box[k, 2] - qy, 0.0, qy - box[k, 3])
            if ex * ex + ey * ey >= wbest:
                continue
            t1 = min(pk + 1 + (k + 1) * BLOCK, span + 1)
            for t in range(pk + 1 + k * BLOCK, t1):
                rb = _wrap(a + t, n)
                db = ring[rb]
                if db >= max_range or (da - db) * (da - db) >= wbest:  # |q_a - q_b| >= |d_a - d_b|
                    continue
                ux = hx[rb] - qx
                uy = hy[rb] - qy
                w2 = ux * ux + uy * uy
                if w2 < wbest:
                    wbest = w2
                    ax, ay = qx, qy
                    bx, by = qx + ux, qy + uy
    return wbest, ax, ay, bx, by


@njit(cache=True)
def detect_gaps(ring, px, py, cos_t, sin_t, max_range, h_open):
    """All openings of one ring (see module docstring).

    Args:
        ring: (R,) ranges [m] of the agent at ``(px, py)``; cos_t, sin_t: (R,) ray directions.
        max_range: R_L [m] (rays at R_L hit nothing); h_open: opening depth threshold [m].

    Returns:
        (M, 8) rows ``qa_x, qa_y, qb_x, qb_y, width, n_x, n_y, peak_ray``: throat end points
        [m], width [m], unit exit direction, index of the peak ray.
    """
    n = ring.shape[0]
    anchors = ring_anchors(ring, max_range)
    na = anchors.shape[0]
    out = np.empty((max(na, 1), 8))
    m = 0
    if na == 0:
        return out[:0]
    box = np.empty(((n + BLOCK - 1) // BLOCK, 4))
    hx = np.empty(n)  # every ray's return [m] (read only where it hits), computed once
    hy = np.empty(n)
    for r in range(n):
        hx[r] = px + ring[r] * cos_t[r]
        hy[r] = py + ring[r] * sin_t[r]
    for i in range(na):
        a = anchors[i]
        b = anchors[(i + 1) % na]
        span = (b - a) % n
        if na == 1:
            span = n
        if span < 2:
            continue
        pk = -1
        best = -1.0
        for s in range(1, span):
            d = ring[_wrap(a + s, n)]
            if d > best:
                best = d
                pk = s
        if best - min(ring[a], ring[b]) < h_open:
            continue
        wbest, ax, ay, bx, by = _closest_across(ring, hx, hy, a, pk, span, n, max_range, box)
        if not np.isfinite(wbest) or wbest <= 0.0:
            continue
        w = math.sqrt(wbest)
        nx = -(by - ay) / w
        ny = (bx - ax) / w
        rp = (a + pk) % n
        if nx * cos_t[rp] + ny * sin_t[rp] < 0.0:
            nx, ny = -nx, -ny
        out[m, 0], out[m, 1], out[m, 2], out[m, 3] = ax, ay, bx, by
        out[m, 4], out[m, 5], out[m, 6], out[m, 7] = w, nx, ny, rp
        m += 1
    return out[:m]


@njit(cache=True)
def segment_clear(ring, sx, sy, cos_t, sin_t, ax, ay, bx, by, rho, max_range):
    """True if no return of the ring sensed at ``(sx, sy)`` lies within ``rho`` [m] of the segment
    ``(ax, ay) -> (bx, by)`` (world coordinates): a straight route of half-width ``rho`` is free
    as far as this ring can tell. The rays are tested in blocks of 64, branch-free within a block
    (so that it vectorises), and the test stops after the first block with a return too close."""
    n = ring.shape[0]
    ex = bx - ax
    ey = by - ay
    ee = ex * ex + ey * ey
    rr = rho * rho
    for r0 in range(0, n, 64):
        m = min(64, n - r0)
        rg, cs, sn = ring[r0:r0 + m], cos_t[r0:r0 + m], sin_t[r0:r0 + m]
        near = False
        for j in range(m):
            d = rg[j]  # a ray at max_range hit nothing: masked out below
            qx = sx + d * cs[j] - ax
            qy = sy + d * sn[j] - ay
            s = min(max((qx * ex + qy * ey) / ee, 0.0), 1.0) if ee > 0.0 else 0.0
            dx = qx - s * ex
            dy = qy - s * ey
            near |= (d < max_range) & (dx * dx + dy * dy < rr)
        if near:
            return False
    return True


@njit(cache=True)
def free_points(ring, px, py, cos_t, sin_t, pts, clear, max_range):
    """(M,) bool: no LiDAR return of this ring lies within ``clear`` [m] of ``pts[m]``."""
    n = ring.shape[0]
    out = np.ones(pts.shape[0], dtype=np.bool_)
    if pts.shape[0] == 0:
        return out
    c2 = clear * clear
    # the points' bounding box grown by ``clear`` (and a micrometre): a return outside it is
    # farther than ``clear`` from every point, and is skipped without the per-point test
    lo_x, hi_x = pts[:, 0].min() - clear - 1e-6, pts[:, 0].max() + clear + 1e-6
    lo_y, hi_y = pts[:, 1].min() - clear - 1e-6, pts[:, 1].max() + clear + 1e-6
    for r in range(n):
        d = ring[r]
        if d >= max_range:
            continue
        qx = px + d * cos_t[r]
        qy = py + d * sin_t[r]
        if qx < lo_x or qx > hi_x or qy < lo_y or qy > hi_y:
            continue
        for k in range(pts.shape[0]):
            if out[k]:
                dx = pts[k, 0] - qx
                dy = pts[k, 1] - qy
                if dx * dx + dy * dy < c2:
                    out[k] = False
    return out


@dataclass(slots=True)  # not frozen: a step builds several, and a frozen init costs twice as much
class Corridor:
    """A candidate corridor toward the goal, in world coordinates.

    Attributes:
        mid: (2,) throat midpoint [m]; normal: (2,) unit exit direction.
        width: throat width [m] (``inf`` for the direct route to a visible goal).
        target: (2,) point ``through`` metres beyond the throat [m] (the goal for ``direct``).
        cost: route length estimate ``|mid - p| + |goal - mid|`` plus the width penalty [m].
        direct: True for the straight route to the goal.
    """

    mid: np.ndarray
    normal: np.ndarray
    width: float
    target: np.ndarray
    cost: float
    direct: bool = False


@njit(cache=True)
def _filter_gaps(gaps, px, py, gx, gy, w_pass, cos_toward, ring, sx, sy, cos_t, sin_t, cx, cy, rho_vis,
                 max_range, check_vis, approach, approach_w, through):
    """The rows of ``gaps`` that are candidate corridors toward the goal, as (K, 8) rows
    ``mid_x, mid_y, n_x, n_y, width, target_x, target_y, cost`` in the order of ``gaps``."""
    m = gaps.shape[0]
    out = np.empty((m, 8))
    k = 0
    ux = gx - px
    uy = gy - py
    un = math.sqrt(ux * ux + uy * uy)
    if un > 0.0:
        ux /= un
        uy /= un
    else:
        ux, uy = 1.0, 0.0
    for j in range(m):
        if gaps[j, 4] < w_pass or gaps[j, 5] * ux + gaps[j, 6] * uy < cos_toward:
            continue
        mx = 0.5 * (gaps[j, 0] + gaps[j, 2])
        my = 0.5 * (gaps[j, 1] + gaps[j, 3])
        if check_vis:
            # straight to the mouth `approach` m in front of a throat narrower than `approach_w`,
            # then along the normal
            ap = approach if gaps[j, 4] < approach_w else 0.0
            ax = mx - ap * gaps[j, 5]
            ay = my - ap * gaps[j, 6]
            if not (segment_clear(ring, sx, sy, cos_t, sin_t, cx, cy, ax, ay, rho_vis, max_range)
                    and segment_clear(ring, sx, sy, cos_t, sin_t, ax, ay, mx, my, rho_vis, max_range)):
                continue
        out[k, 0], out[k, 1] = mx, my
        out[k, 2], out[k, 3] = gaps[j, 5], gaps[j, 6]
        out[k, 4] = gaps[j, 4]
        out[k, 5], out[k, 6] = mx + through * gaps[j, 5], my + through * gaps[j, 6]
        out[k, 7] = math.sqrt((mx - px) ** 2 + (my - py) ** 2) + math.sqrt((gx - mx) ** 2 + (gy - my) ** 2)
        k += 1
    return out[:k]


def corridors_toward(gaps: np.ndarray, p: np.ndarray, goal: np.ndarray, *, w_pass: float, toward_deg: float,
                     through: float, ring: np.ndarray | None = None, sensor: np.ndarray | None = None,
                     origin: np.ndarray | None = None, rho_vis: float = 0.4, max_range: float = 20.0,
                     rays: tuple[np.ndarray, np.ndarray] | None = None, approach: float = 0.0,
                     approach_w: float = math.inf) -> list[Corridor]:
    """The candidate corridors leading toward the goal among the openings ``gaps`` seen from ``p``.

    Keeps openings at least ``w_pass`` wide whose exit direction is within ``toward_deg`` of the
    bearing to the goal and, if ``ring`` (sensed at ``sensor``) and ``origin`` are given, whose
    throat midpoint can be reached from ``origin`` along a straight line of half-width
    ``rho_vis`` free of that ring's returns (with ``approach`` > 0, for throats narrower than
    ``approach_w``: a straight line to the mouth ``approach`` m in front of the throat, then along
    the throat normal; a gap in a wall seen at a grazing angle is reached through its mouth, not
    along the wall). Cost = ``|mid - p| + |goal - mid|`` [m] (the length
    of the route through the throat midpoint). Sorted by cost.
    """
    if len(gaps) == 0:
        return []
    check = ring is not None and origin is not None
    if not check:
        ring, sensor, origin = np.zeros(1), np.zeros(2), np.zeros(2)
    cos_t, sin_t = rays if rays is not None else _rays(len(ring))
    rows = _filter_gaps(gaps, float(p[0]), float(p[1]), float(goal[0]), float(goal[1]), w_pass,
                        math.cos(math.radians(toward_deg)), ring, float(sensor[0]), float(sensor[1]), cos_t, sin_t,
                        float(origin[0]), float(origin[1]), rho_vis, max_range, check, float(approach),
                        float(approach_w), float(through))
    out = [Corridor(r[0:2], r[2:4], w, r[5:7], c) for r, w, c in zip(rows, rows[:, 4].tolist(), rows[:, 7].tolist())]
    out.sort(key=lambda c: c.cost)
    return out


@njit(cache=True)
def seen_passages(gaps, ring, px, py, cos_t, sin_t, depth, max_range):
    """(M,) bool: the openings ``gaps`` (from :func:`detect_gaps` on ``ring`` sensed at
    ``(px, py)``) that are not concave corners: where the peak ray hits (range < ``max_range``),
    its return lies at least ``depth`` [m] from the throat segment, i.e. the ring sees on through
    the opening, at least past the thickness of the wall it is cut in.

    A concave corner seen at a grazing angle fails: consecutive hits metres apart on one wall
    make its closest pair across the two sides look wide, but the corner, the peak, lies about
    one ray spacing (<= 0.35 m at R_L) behind that pair. An opening whose peak reads R_L is
    kept: the ring cannot tell a passage from a corner out of range.
    """
    m = gaps.shape[0]
    out = np.empty(m, dtype=np.bool_)
    for j in range(m):
        pk = int(gaps[j, GAP_PEAK])
        d = ring[pk]
        if d >= max_range:
            out[j] = True
            continue
        hx = px + d * cos_t[pk]  # the peak ray's return
        hy = py + d * sin_t[pk]
        ax, ay = gaps[j, GAP_QA_X], gaps[j, GAP_QA_Y]
        ex, ey = gaps[j, GAP_QB_X] - ax, gaps[j, GAP_QB_Y] - ay
        ee = max(ex * ex + ey * ey, 1e-12)
        s = min(max(((hx - ax) * ex + (hy - ay) * ey) / ee, 0.0), 1.0)
        out[j] = math.hypot(hx - ax - s * ex, hy - ay - s * ey) >= depth  # its distance from the throat segment
    return out


def _rays(n: int) -> tuple[np.ndarray, np.ndarray]:
    from swarmnav.sensing import ray_table as _ray_table

    return _ray_table(max(n, 1))


def direct_corridor(p: np.ndarray, goal: np.ndarray) -> Corridor:
    """The straight route to the goal (used when :func:`segment_clear` says it is free)."""
    g = goal - p
    d = math.hypot(g[0], g[1])
    u = g / d if d > 0 else np.array([1.0, 0.0])
    return Corridor(mid=p.copy(), normal=u, width=math.inf, target=goal.copy(), cost=d, direct=True)


@njit(cache=True)
def newest_visible(ring, sx, sy, cos_t, sin_t, trail, count, members, rho, reach, max_range):
    """Index ``(t, j)`` of the newest trail point ``trail[t, j]`` (t < ``count``, j in ``members``)
    within ``reach`` [m] of the sensor ``(sx, sy)`` and joined to it by a straight segment of
    half-width ``rho`` free of this ring's returns; ``(-1, -1)`` if none. Newest: largest t,
    then the nearest point."""
    r2 = reach * reach
    for t in range(count - 1, -1, -1):
        best, jb = np.inf, -1
        for j in members:
            dx = trail[t, j, 0] - sx
            dy = trail[t, j, 1] - sy
            d2 = dx * dx + dy * dy
            if not d2 <= r2 or d2 >= best:  # (a NaN point: a mate not heard at that sample, on a network)
                continue
            if segment_clear(ring, sx, sy, cos_t, sin_t, sx, sy, trail[t, j, 0], trail[t, j, 1], rho, max_range):
                best, jb = d2, j
        if jb >= 0:
            return t, jb
    return -1, -1
