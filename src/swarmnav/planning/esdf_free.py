"""ESDF-free collision cost of EGO-Planner (Zhou et al., RA-L 2020, Section III-B / IV-A).

No distance field is built. Where the control polygon of a B-spline crosses occupied cells of a
robot's occupancy map, a collision-free guide path Γ is searched around that stretch (A* between
the control points before and after it); every control point ``Q_i`` inside the stretch then gets
a ``{p, v}`` pair:

- ``v``: the unit vector from ``Q_i`` to where the plane through ``Q_i`` normal to the local
  tangent ``R_i = Q_{i+1} - Q_{i-1}`` cuts Γ;
- ``p``: the obstacle surface on that ray: walking from the cut point back towards ``Q_i``, the
  last free point before an occupied one (``Q_i`` itself if the ray stays free).

The distance of ``Q_i`` to the obstacle along the pair is ``d = (Q_i - p) . v`` (negative
inside), and with ``c = s_f - d`` (``s_f``: the clearance ``dist0``) the cost of a pair is

    j(c) = 0 (c <= 0);  c^3 (0 < c <= s_f);  3 s_f c^2 - 3 s_f^2 c + s_f^3 (c > s_f),

twice differentiable, cubic near the surface and quadratic deep inside (EGO-Planner eq. 3-4,
our reading); its gradient is ``-j'(c) v``. A control point may hold several pairs (one per
obstacle met during the rebounds). Maps are flat uint8 arrays (index ``(iz * ny + iy) * nx + ix``)
with their cell counts ``(nx, ny[, nz])``: a cell is occupied when its class is at least
``blocked`` (``OccupancyMaps``' classes); outside the map counts as occupied. The functions serve
2-D and 3-D alike (the dimension is the length of a point).
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def occupied(grid, counts, origin, res, blocked, p) -> bool:
    """Whether point ``p`` [m] lies in an occupied (or out-of-map) cell of the flat map ``grid``."""
    flat = 0
    stride = 1
    for k in range(p.shape[0]):
        i = int(np.floor((p[k] - origin[k]) / res + 0.5))
        if i < 0 or i >= counts[k]:
            return True
        flat += i * stride
        stride *= counts[k]
    return grid[flat] >= blocked


@njit(cache=True)
def polygon_hits(ctrl, grid, counts, origin, res, blocked, step):
    """Per control-polygon segment ``Q_i -> Q_{i+1}`` (K of them): whether any point sampled every
    ``step`` [m] along it (ends included) is occupied."""
    n, dim = ctrl.shape
    hit = np.zeros(n - 1, dtype=np.bool_)
    p = np.empty(dim)
    for i in range(n - 1):
        length = 0.0
        for d in range(dim):
            length += (ctrl[i + 1, d] - ctrl[i, d]) ** 2
        length = np.sqrt(length)
        m = max(int(np.ceil(length / step)), 1)
        for s in range(m + 1):
            u = s / m
            for d in range(dim):
                p[d] = ctrl[i, d] + u * (ctrl[i + 1, d] - ctrl[i, d])
            if occupied(grid, counts, origin, res, blocked, p):
                hit[i] = True
                break
    return hit


@njit(cache=True)
def points_occupied(points, grid, counts, origin, res, blocked):
    """Occupancy of each point of ``points`` (M, D)."""
    out = np.zeros(points.shape[0], dtype=np.bool_)
    for j in range(points.shape[0]):
        out[j] = occupied(grid, counts, origin, res, blocked, points[j])
    return out


def colliding_runs(hit: np.ndarray) -> list[tuple[int, int]]:
    """Stretches of consecutive colliding segments as ``(in_id, out_id)``: the control point before
    the first colliding segment and the one after the last (segment ``i`` joins ``Q_i, Q_{i+1}``)."""
    runs = []
    i, k = 0, len(hit)
    while i < k:
        if hit[i]:
            j = i
            while j + 1 < k and hit[j + 1]:
                j += 1
            runs.append((i, j + 1))
            i = j + 1
        else:
            i += 1
    return runs


@njit(cache=True)
def find_pairs(ctrl, lo, hi, path, grid, counts, origin, res, blocked):
    """``{p, v}`` pairs of control points ``lo .. hi`` (inclusive) against the guide path ``path``
    (P, D) (module docstring). Returns ``(index (M,), p (M, D), v (M, D))`` for the points whose
    normal plane cuts the path (the cut nearest to the point)."""
    dim = ctrl.shape[1]
    m_max = max(hi - lo + 1, 0)
    idx = np.empty(m_max, dtype=np.int64)
    ps = np.empty((m_max, dim))
    vs = np.empty((m_max, dim))
    count = 0
    q = np.empty(dim)
    x = np.empty(dim)
    for i in range(lo, hi + 1):
        if i < 1 or i >= ctrl.shape[0] - 1:
            continue
        for d in range(dim):
            q[d] = ctrl[i, d]
        tang = ctrl[i + 1] - ctrl[i - 1]
        tn = np.sqrt(np.sum(tang * tang))
        if tn < 1e-9:
            continue
        best = np.inf
        found = False
        for s in range(path.shape[0] - 1):
            a = np.sum((path[s] - q) * tang)
            b = np.sum((path[s + 1] - q) * tang)
            if (a <= 0.0 and b >= 0.0) or (a >= 0.0 and b <= 0.0):
                u = 0.0 if a == b else a / (a - b)
                cut = path[s] + u * (path[s + 1] - path[s])
                dist = np.sqrt(np.sum((cut - q) ** 2))
                if dist < best:
                    best = dist
                    for d in range(dim):
                        x[d] = cut[d]
                    found = True
        if not found or best < 1e-6:
            continue
        v = (x - q) / best
        # from the cut point (free) back towards Q_i: p = the last free point before an occupied one
        n_steps = int(np.ceil(best / (0.5 * res)))
        pnt = q.copy()
        for s in range(n_steps + 1):
            a = best * (1.0 - s / n_steps)
            cand = q + a * v
            if occupied(grid, counts, origin, res, blocked, cand):
                a_free = min(a + 0.5 * res, best)
                pnt = q + a_free * v
                break
        idx[count] = i
        ps[count] = pnt
        vs[count] = v
        count += 1
    return idx[:count].copy(), ps[:count].copy(), vs[:count].copy()


@njit(cache=True)
def pair_cost(ctrl, pair_idx, pair_p, pair_v, sf, weight, grad):
    """``weight * sum_pairs j(c)`` (module docstring), its gradient added into ``grad``."""
    dim = ctrl.shape[1]
    total = 0.0
    for m in range(pair_idx.shape[0]):
        i = pair_idx[m]
        d = 0.0
        for k in range(dim):
            d += (ctrl[i, k] - pair_p[m, k]) * pair_v[m, k]
        c = sf - d
        if c <= 0.0:
            continue
        if c <= sf:
            total += c * c * c
            dj = 3.0 * c * c
        else:
            total += 3.0 * sf * c * c - 3.0 * sf * sf * c + sf * sf * sf
            dj = 6.0 * sf * c - 3.0 * sf * sf
        for k in range(dim):
            grad[i, k] -= weight * dj * pair_v[m, k]
    return weight * total
