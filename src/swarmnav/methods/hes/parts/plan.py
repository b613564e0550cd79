"""Stall planner numerics (ours, beyond the paper; the part is ``stall.StallPlanner``): a map of
what the swarm's LiDAR rings have seen and a shortest path through it that keeps clear of the returns.

The paper's planner is reactive: each step it picks one of the corridors the subleader's ring
shows. Where those corridors are pockets (a row of discs whose visible gaps close behind) and the
way through is a chain of 1-2 m gaps, that choice never commits and the swarm mills in front of
the first row. This module gives the planner a memory of the returns instead:

1. :func:`mark_hits` accumulates every agent's LiDAR returns in an occupancy grid (world-fixed,
   ``cell`` m cells; unseen cells count as free).
2. :func:`cost_to_go` runs Dijkstra from the goal over the 8-connected grid: a cell closer than
   ``clear_min`` to a return is blocked, a step costs its length times
   ``1 + weight * max(0, d_pref - clearance) / max(clearance, clear_min)`` (narrow places cost more, so a wide way
   round wins over a short squeeze unless the squeeze is much shorter, and a path through a gap
   keeps to its middle, where the cost is lowest).
3. :func:`descend` follows the cost-to-go field down from a start cell: the path.

All three are plain array functions (numba); the method calls them only while a sub-swarm has
stalled (see ``stall.StallPlanner``).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from scipy import ndimage

_SQ2 = math.sqrt(2.0)
_DI = np.array([-1, -1, -1, 0, 0, 1, 1, 1], dtype=np.int64)
_DJ = np.array([-1, 0, 1, -1, 1, -1, 0, 1], dtype=np.int64)


@njit(cache=True)
def mark_hits(occ, ring, x, cos_t, sin_t, max_range, x0, y0, cell):
    """Set ``occ[iy, ix] = True`` for every LiDAR return (range < ``max_range``) of the rings
    ``ring`` (N, R) sensed at ``x`` (N, 2); grid origin ``(x0, y0)`` [m], cell size ``cell`` [m].
    Returns outside the grid are dropped. Per ring, every ray's cell is computed in one
    branch-free pass (it vectorises), then the hits are marked."""
    ny, nx = occ.shape
    nr = ring.shape[1]
    ix = np.empty(nr, dtype=np.int64)
    iy = np.empty(nr, dtype=np.int64)
    for i in range(ring.shape[0]):
        row = ring[i]
        px, py = x[i, 0], x[i, 1]
        for r in range(nr):  # (a ray at max_range hit nothing: its cell is not marked below)
            ix[r] = int(math.floor((px + row[r] * cos_t[r] - x0) / cell))
            iy[r] = int(math.floor((py + row[r] * sin_t[r] - y0) / cell))
        for r in range(nr):
            if row[r] < max_range and 0 <= ix[r] < nx and 0 <= iy[r] < ny:
                occ[iy[r], ix[r]] = True


def clearance(occ: np.ndarray, cell: float) -> np.ndarray:
    """Distance [m] from every cell centre to the nearest occupied cell centre (inf if none)."""
    if not occ.any():
        return np.full(occ.shape, np.inf)
    return ndimage.distance_transform_edt(~occ) * cell


@njit(cache=True)
def _cell_cost(clr, clear_min, d_pref, weight):
    """Cost per metre of every cell: ``1 + weight * max(0, d_pref - clr) / max(clr, clear_min)``."""
    ny, nx = clr.shape
    c = np.empty((ny, nx))
    for i in range(ny):
        for j in range(nx):
            c[i, j] = 1.0 + weight * max(0.0, d_pref - clr[i, j]) / max(clr[i, j], clear_min)
    return c


@njit(cache=True)
def _heap_pop(hk, hv, size):
    """Pop the smallest entry of the binary heap ``(hk, hv)[:size]``: (key, value, new size)."""
    key, v = hk[0], hv[0]
    size -= 1
    if size > 0:  # move the last entry to the root and sift it down
        lk, lv = hk[size], hv[size]
        pos = 0
        while True:
            ch = 2 * pos + 1
            if ch >= size:
                break
            if ch + 1 < size and hk[ch + 1] < hk[ch]:
                ch += 1
            if hk[ch] >= lk:
                break
            hk[pos], hv[pos] = hk[ch], hv[ch]
            pos = ch
        hk[pos], hv[pos] = lk, lv
    return key, v, size


@njit(cache=True)
def _heap_push(hk, hv, size, key, val):
    """Push ``(key, val)`` onto the binary heap ``(hk, hv)[:size]``; returns the new size."""
    pos = size
    size += 1
    while pos > 0:
        par = (pos - 1) // 2
        if hk[par] <= key:
            break
        hk[pos], hv[pos] = hk[par], hv[par]
        pos = par
    hk[pos], hv[pos] = key, val
    return size


@njit(cache=True)
def cost_to_go(clr, gi, gj, cell, clear_min, d_pref, weight, need=np.empty((0, 2), dtype=np.int64), slack=0.0):
    """Dijkstra from the goal cell ``(gi, gj)`` (row, column) over the 8-connected grid.

    A cell with ``clr < clear_min`` is blocked (cost inf); a step between cells a and b costs
    ``length * (c(a) + c(b)) / 2`` with ``c = 1 + weight * max(0, d_pref - clr) / max(clr, clear_min)``.
    Returns the (ny, nx) cost-to-go [m-equivalent]; inf where the goal cannot be reached.

    ``need`` (M, 2): cells (row, column) the caller will query. Once every one of them that is
    open is settled, the search goes on only to ``slack`` beyond the largest of their costs and
    stops; cells left unsettled are inf. Every settled value is exact, and a descent from a
    settled cell only visits settled cells, so queries within ``slack`` of the needed cells give
    the full field's answers (the planner's field is 4-10x cheaper when the swarm is far from the
    map's edges). An empty ``need`` computes the whole field."""
    ny, nx = clr.shape
    dist = np.full((ny, nx), np.inf)
    if clr[gi, gj] < clear_min:
        return dist
    pending = 0  # needed open cells not settled yet
    want = np.zeros((ny, nx), dtype=np.bool_)
    for q in range(need.shape[0]):
        a, b = need[q, 0], need[q, 1]
        if 0 <= a < ny and 0 <= b < nx and clr[a, b] >= clear_min and not want[a, b]:
            want[a, b] = True
            pending += 1
    bound = np.inf  # the cost up to which the search runs: set once every needed open cell is settled
    stopped = False
    c = _cell_cost(clr, clear_min, d_pref, weight)
    # binary heap of (cost, flat index) in two arrays
    cap = 8 * ny * nx + 1
    hk = np.empty(cap)
    hv = np.empty(cap, dtype=np.int64)
    size = 0
    dist[gi, gj] = 0.0
    hk[0], hv[0] = 0.0, gi * nx + gj
    size = 1
    done = np.zeros((ny, nx), dtype=np.bool_)
    while size > 0:
        key, v, size = _heap_pop(hk, hv, size)
        i, j = v // nx, v % nx
        if done[i, j]:
            continue
        if key > bound:
            stopped = True  # everything within slack of the needed cells is settled
            break
        done[i, j] = True
        if want[i, j]:
            pending -= 1
            if pending == 0:
                bound = key + slack
        for m in range(8):
            a, b = i + _DI[m], j + _DJ[m]
            if a < 0 or a >= ny or b < 0 or b >= nx or done[a, b] or clr[a, b] < clear_min:
                continue
            step = cell * (_SQ2 if _DI[m] != 0 and _DJ[m] != 0 else 1.0)
            nd = key + step * 0.5 * (c[i, j] + c[a, b])
            if nd < dist[a, b]:
                dist[a, b] = nd
                size = _heap_push(hk, hv, size, nd, a * nx + b)
    if stopped:  # tentative values are not exact
        for i in range(ny):
            for j in range(nx):
                if not done[i, j]:
                    dist[i, j] = np.inf
    return dist


@njit(cache=True)
def _down(dist, i, j):
    """The 8-neighbour of cell (i, j) with the lowest ``dist`` below ``dist[i, j]``, or (-1, -1)."""
    ny, nx = dist.shape
    bi, bj, bd = -1, -1, dist[i, j]
    for m in range(8):
        a, b = i + _DI[m], j + _DJ[m]
        if 0 <= a < ny and 0 <= b < nx and dist[a, b] < bd:
            bi, bj, bd = a, b, dist[a, b]
    return bi, bj


@njit(cache=True)
def descend(dist, si, sj, max_cells):
    """Cells (K, 2) (row, column) from ``(si, sj)`` down the cost-to-go ``dist`` to its minimum
    (steepest descent over the 8 neighbours; stops at a cell with no lower neighbour)."""
    out = np.empty((max_cells, 2), dtype=np.int64)
    i, j = si, sj
    k = 0
    while k < max_cells:
        out[k, 0], out[k, 1] = i, j
        k += 1
        bi, bj = _down(dist, i, j)
        if bi < 0:
            break
        i, j = bi, bj
    return out[:k]


def nearest_reachable(dist: np.ndarray, i: int, j: int, radius: int, cell: float) -> tuple[int, int] | None:
    """The cell within ``radius`` cells of ``(i, j)`` with the smallest ``dist`` + straight
    distance [m] (where to start when ``(i, j)`` itself is blocked, e.g. next to a disc), or None."""
    ny, nx = dist.shape
    i0, i1, j0, j1 = max(i - radius, 0), min(i + radius + 1, ny), max(j - radius, 0), min(j + radius + 1, nx)
    win = dist[i0:i1, j0:j1]
    if not np.isfinite(win).any():
        return None
    ii, jj = np.mgrid[i0:i1, j0:j1]
    r = np.hypot(ii - i, jj - j)
    score = np.where(r <= radius, win + r * cell, np.inf)
    if not np.isfinite(score).any():
        return None
    k = int(np.argmin(score))
    return int(ii.flat[k]), int(jj.flat[k])


@njit(cache=True)
def lookahead(dist, clr, pts, x0, y0, cell, look, near):
    """Each agent's own way down the cost-to-go: for every point ``pts[m]`` [m], follow the
    steepest descent from its cell for ``look`` m of arc. Returns (M, 2) the point reached [m]
    (the point itself if its cell has no finite cost) and (M,) the smallest clearance [m] along
    the first ``near`` m (the half-width of the narrow place the agent is in or entering)."""
    ny, nx = dist.shape
    m = pts.shape[0]
    out = pts.copy()
    half = np.full(m, np.inf)
    for k in range(m):
        j = int(math.floor((pts[k, 0] - x0) / cell))
        i = int(math.floor((pts[k, 1] - y0) / cell))
        if i < 0 or i >= ny or j < 0 or j >= nx or not np.isfinite(dist[i, j]):
            continue
        arc = 0.0
        h = clr[i, j]
        while arc < look:
            bi, bj = _down(dist, i, j)
            if bi < 0:
                break
            arc += cell * (_SQ2 if bi != i and bj != j else 1.0)
            i, j = bi, bj
            if arc <= near:
                h = min(h, clr[i, j])
        out[k, 0] = x0 + (j + 0.5) * cell
        out[k, 1] = y0 + (i + 0.5) * cell
        half[k] = h
    return out, half
