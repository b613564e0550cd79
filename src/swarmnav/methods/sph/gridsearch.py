"""Initial paths for the B-spline planner: a grid search on each robot's own occupancy map.

The SPH paper's robots build an occupancy grid from onboard perception (Fig. 1) and seed the
B-spline optimisation with a grid-search path (the released code: A* at 0.1 m). Here every
robot keeps its own map: an obstacle enters it once the obstacle's bounding box comes within
the perception range (the paper equates sensing range and R, Section IV); unknown space is
free. Each cell stores a clearance class: the number of clearances it is inside, counting
``inflation`` (no room for the body) as all of them; with ``margin = d_thr`` and a wider
``wide`` clearance: 3 within ``inflation``, 2 within d_thr (the ESDF threshold of eq. 10), 1
within ``wide``, 0 free. The search first looks for a path that keeps d_thr (classes 0-1,
class 1 costing ``1 + wide_cost`` per metre, so the path keeps the wide clearance unless that
costs a long detour), and falls back to the body clearance. It is A* on the 8-connected grid
(no corner
cutting), compiled with numba.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from swarmnav.sensing import signed_distance
from swarmnav.world.obstacles import Geometry, Obstacle

_SQRT2 = math.sqrt(2.0)


class OccupancyMaps:
    """Per-robot occupancy grids over the scene bounds, grown from what each robot has seen.

    Attributes:
        origin: (2,) centre of cell (0, 0) [m]; resolution: cell size [m];
        shape: (ny, nx); grids: (N, ny, nx) uint8, 1 = occupied for that robot.
    """

    def __init__(self, obstacles: tuple[Obstacle, ...], bounds, n_robots: int, resolution: float,
                 inflation: float, sensing_range: float, margin: float | None = None, wide: float = 0.0,
                 wide_cost: float = 0.0):
        x0, y0, x1, y1 = bounds
        self.resolution = float(resolution)
        self.origin = np.array([x0, y0], dtype=float) + 0.5 * self.resolution
        nx = max(int(math.ceil((x1 - x0) / resolution)), 2)
        ny = max(int(math.ceil((y1 - y0) / resolution)), 2)
        self.shape = (ny, nx)
        self.sensing_range = float(sensing_range)
        self.grids = np.zeros((n_robots, ny, nx), dtype=np.uint8)
        self.known = np.zeros((n_robots, len(obstacles)), dtype=bool)
        self.levels = sorted({m for m in (margin or 0.0, wide) if m > inflation})  # clearances beyond the body's [m]
        margin = max([inflation, *self.levels])
        top = len(self.levels) + 1
        # A* step-cost factor per class: 1 + wide_cost inside the wide band (classes 1 .. top - 2)
        self.cost = np.array([1.0] + [1.0 + wide_cost] * max(top - 2, 0) + [1.0, 1.0])[: top + 1]
        lo, hi, cells = [], [], []
        for o in obstacles:
            g = Geometry.from_obstacles([o])
            blo, bhi = g.bbox_lo.min(axis=0), g.bbox_hi.max(axis=0)
            lo.append(blo)
            hi.append(bhi)
            cells.append(self._footprint(g, blo - margin, bhi + margin, inflation))
        self.bbox_lo = np.array(lo).reshape(-1, 2)
        self.bbox_hi = np.array(hi).reshape(-1, 2)
        self.footprints = cells

    def _footprint(self, g: Geometry, lo, hi, inflation: float) -> tuple[np.ndarray, np.ndarray]:
        """Flat indices and clearance classes (see the module docstring) of the cells around
        one obstacle."""
        ny, nx = self.shape
        ix0, iy0 = np.maximum(np.floor((lo - self.origin) / self.resolution).astype(int), 0)
        ix1, iy1 = np.minimum(np.ceil((hi - self.origin) / self.resolution).astype(int), [nx - 1, ny - 1])
        if ix1 < ix0 or iy1 < iy0:
            return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.uint8)
        iy, ix = np.mgrid[iy0:iy1 + 1, ix0:ix1 + 1]
        pts = self.origin + self.resolution * np.column_stack([ix.ravel(), iy.ravel()])
        d = signed_distance(g, pts)
        top = len(self.levels) + 1
        near = d < (self.levels[-1] if self.levels else inflation)
        dn = d[near]
        level = sum((dn < m).astype(np.uint8) for m in self.levels) if self.levels else np.zeros(len(dn), np.uint8)
        level = np.where(dn < inflation, top, level).astype(np.uint8)
        return (iy.ravel()[near] * nx + ix.ravel()[near]).astype(np.int64), level

    def observe(self, robot: int, position: np.ndarray) -> int:
        """Add to ``robot``'s map every obstacle whose bounding box is within the sensing
        range of ``position``; returns how many were new."""
        if not len(self.footprints):
            return 0
        d = np.maximum(np.maximum(self.bbox_lo - position, position - self.bbox_hi), 0.0)
        near = np.einsum("ij,ij->i", d, d) <= self.sensing_range**2
        new = np.flatnonzero(near & ~self.known[robot])
        flat = self.grids[robot].reshape(-1)
        for o in new:
            idx, level = self.footprints[o]
            flat[idx] = np.maximum(flat[idx], level)
        self.known[robot, new] = True
        return len(new)

    def cell(self, p: np.ndarray) -> tuple[int, int]:
        ny, nx = self.shape
        ix = int(np.clip(round((p[0] - self.origin[0]) / self.resolution), 0, nx - 1))
        iy = int(np.clip(round((p[1] - self.origin[1]) / self.resolution), 0, ny - 1))
        return iy, ix

    def center(self, iy: np.ndarray, ix: np.ndarray) -> np.ndarray:
        return self.origin + self.resolution * np.column_stack([ix, iy])

    def search(self, robot: int, start: np.ndarray, goal: np.ndarray, max_expand: int,
               others: np.ndarray | None = None, others_radius: float = 0.0) -> np.ndarray | None:
        """A* path from ``start`` to ``goal`` [m] on ``robot``'s map: (P, 2) cell centres, the
        first replaced by ``start`` itself; None if no path. A start or goal inside an
        inflated obstacle is moved to the nearest free cell (as the released planner does)."""
        occ = self.grids[robot]
        if others is not None and len(others) and others_radius > 0 and len(self.levels) > 1:
            occ = occ.copy()  # neighbours: cells within others_radius join the wide (costly) band
            _mark_discs(occ, (np.asarray(others) - self.origin) / self.resolution, others_radius / self.resolution)
        idx = np.zeros(0, dtype=np.int64)
        gc = self.cell(goal)
        top = len(self.levels) + 1
        for blocked in (top - 1, top) if top > 1 else (1,):  # keep d_thr if possible, else the body clearance
            s = _nearest_free(occ, *self.cell(start), 40, blocked)
            g = _nearest_free(occ, *gc, 40, blocked)
            if s[0] >= 0 and g[0] >= 0:
                idx = _astar(occ, s[0], s[1], g[0], g[1], max_expand, blocked, self.cost)
                if len(idx):
                    break
        if len(idx) == 0:
            return None
        nx = self.shape[1]
        path = self.center(idx // nx, idx % nx)
        path[0] = start
        if g == gc:  # the goal itself is free: end exactly on it
            path[-1] = goal
        return path


@njit(cache=True)
def _mark_discs(occ, centres, radius):
    """Raise cells within ``radius`` [cells] of each centre [cells] to at least class 1."""
    ny, nx = occ.shape
    r = int(radius) + 1
    for k in range(centres.shape[0]):
        cx, cy = centres[k, 0], centres[k, 1]
        for y in range(max(int(cy) - r, 0), min(int(cy) + r + 2, ny)):
            for x in range(max(int(cx) - r, 0), min(int(cx) + r + 2, nx)):
                if (x - cx) ** 2 + (y - cy) ** 2 <= radius * radius and occ[y, x] == 0:
                    occ[y, x] = 1


@njit(cache=True)
def _nearest_free(occ, iy, ix, max_r, blocked):
    """Nearest cell with ``occ < blocked`` (Chebyshev rings, Euclidean within a ring) to
    (iy, ix); (-1, -1) if none within ``max_r`` cells."""
    ny, nx = occ.shape
    if occ[iy, ix] < blocked:
        return iy, ix
    for r in range(1, max_r + 1):
        best = 1e18
        by, bx = -1, -1
        for dy in range(-r, r + 1):
            for dx in range(-r, r + 1):
                if max(abs(dy), abs(dx)) != r:
                    continue
                y, x = iy + dy, ix + dx
                if 0 <= y < ny and 0 <= x < nx and occ[y, x] < blocked:
                    d = dy * dy + dx * dx
                    if d < best:
                        best, by, bx = d, y, x
        if by >= 0:
            return by, bx
    return -1, -1


@njit(cache=True)
def _heap_push(keys, vals, size, key, val):
    if size == keys.shape[0]:
        nk = np.empty(2 * size)
        nv = np.empty(2 * size, dtype=np.int64)
        nk[:size] = keys
        nv[:size] = vals
        keys, vals = nk, nv
    k = size
    keys[k] = key
    vals[k] = val
    while k > 0:
        p = (k - 1) // 2
        if keys[p] <= keys[k]:
            break
        keys[p], keys[k] = keys[k], keys[p]
        vals[p], vals[k] = vals[k], vals[p]
        k = p
    return keys, vals, size + 1


@njit(cache=True)
def _heap_pop(keys, vals, size):
    val = vals[0]
    size -= 1
    keys[0] = keys[size]
    vals[0] = vals[size]
    k = 0
    while True:
        l = 2 * k + 1
        if l >= size:
            break
        c = l
        if l + 1 < size and keys[l + 1] < keys[l]:
            c = l + 1
        if keys[k] <= keys[c]:
            break
        keys[c], keys[k] = keys[k], keys[c]
        vals[c], vals[k] = vals[k], vals[c]
        k = c
    return val, size


@njit(cache=True)
def _astar(occ, sy, sx, gy, gx, max_expand, blocked, cost):
    """A* over the cells with ``occ < blocked`` of an 8-connected grid, step length 1 (diagonal
    sqrt(2)) times ``cost[occ]`` of the entered cell (all >= 1), no corner cutting, octile
    heuristic (ties broken towards larger g). Returns flat cell indices start -> goal, empty
    if the goal is unreachable within ``max_expand`` expansions."""
    ny, nx = occ.shape
    n = ny * nx
    g = np.full(n, np.inf)
    parent = np.full(n, -1, dtype=np.int64)
    closed = np.zeros(n, dtype=np.bool_)
    keys = np.empty(1024)
    vals = np.empty(1024, dtype=np.int64)
    s = sy * nx + sx
    goal = gy * nx + gx
    g[s] = 0.0
    keys, vals, size = _heap_push(keys, vals, 0, 0.0, s)
    dys = np.array([-1, -1, -1, 0, 0, 1, 1, 1])
    dxs = np.array([-1, 0, 1, -1, 1, -1, 0, 1])
    expanded = 0
    found = False
    while size > 0:
        cur, size = _heap_pop(keys, vals, size)
        if closed[cur]:
            continue
        if cur == goal:
            found = True
            break
        closed[cur] = True
        expanded += 1
        if expanded > max_expand:
            break
        cy = cur // nx
        cx = cur - cy * nx
        for k in range(8):
            y = cy + dys[k]
            x = cx + dxs[k]
            if y < 0 or y >= ny or x < 0 or x >= nx or occ[y, x] >= blocked:
                continue
            diag = dys[k] != 0 and dxs[k] != 0
            if diag and (occ[cy, x] >= blocked or occ[y, cx] >= blocked):
                continue
            nb = y * nx + x
            if closed[nb]:
                continue
            ng = g[cur] + (1.4142135623730951 if diag else 1.0) * cost[occ[y, x]]
            if ng < g[nb]:
                g[nb] = ng
                parent[nb] = cur
                ady = abs(gy - y)
                adx = abs(gx - x)
                h = (ady + adx) + (1.4142135623730951 - 2.0) * min(ady, adx)
                keys, vals, size = _heap_push(keys, vals, size, ng + h * 1.001, nb)
    if not found:
        return np.zeros(0, dtype=np.int64)
    count = 1
    c = goal
    while c != s:
        c = parent[c]
        count += 1
    out = np.empty(count, dtype=np.int64)
    c = goal
    for k in range(count - 1, -1, -1):
        out[k] = c
        c = parent[c]
    return out


def resample(path: np.ndarray, spacing: float) -> np.ndarray:
    """Points every ``spacing`` [m] of arc length along a polyline, from its first point to
    its last (a remainder shorter than half a spacing stretches the last interval)."""
    seg = np.linalg.norm(np.diff(path, axis=0), axis=1)
    s = np.concatenate([[0.0], np.cumsum(seg)])
    total = s[-1]
    if total <= 1e-12:
        return path[:1].copy()
    n = int(math.floor(total / spacing))
    ts = spacing * np.arange(n + 1)
    if total - ts[-1] > 0.5 * spacing or n == 0:
        ts = np.append(ts, total)
    else:  # a short remainder: stretch the last interval rather than add a near-duplicate point
        ts[-1] = total
    out = np.column_stack([np.interp(ts, s, path[:, d]) for d in range(path.shape[1])])
    return out
