"""Cell-list neighbour lists (numba): every agent's neighbours within a radius, never N x N.

Agents are binned into square cells at least ``radius`` wide (a periodic square is split into
a whole number of them; a far-flung swarm gets coarser cells, at most ~4N of them) and each
agent reads its own and the 8 surrounding cells. The result is a CSR-like list: the neighbours
of agent ``i`` are ``indices[start[i]:end[i]]`` with squared distances ``dist2`` alongside.
Used by the Vicsek models (their neighbour lists) and by the metrics (contacts over a run).
(N, 3) positions (open space only) use cubic cells and the 27 surrounding ones, same contract.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True)
def _grid(pos, radius, box, periodic, max_cells):
    """Cell size and grid of the cell list: cells at least ``radius`` wide."""
    n = pos.shape[0]
    if periodic:
        nc = max(1, int(math.floor(box / radius)))
        while nc * nc > max_cells and nc > 1:
            nc -= 1
        h = box / nc
        return 0.0, 0.0, h, nc, nc
    x0 = np.inf
    y0 = np.inf
    x1 = -np.inf
    y1 = -np.inf
    for i in range(n):
        x0 = min(x0, pos[i, 0])
        y0 = min(y0, pos[i, 1])
        x1 = max(x1, pos[i, 0])
        y1 = max(y1, pos[i, 1])
    h = radius
    ncx = int((x1 - x0) / h) + 1
    ncy = int((y1 - y0) / h) + 1
    while ncx * ncy > max_cells:  # agents spread far apart: coarser cells, same result
        h *= 2.0
        ncx = int((x1 - x0) / h) + 1
        ncy = int((y1 - y0) / h) + 1
    return x0, y0, h, ncx, ncy


@njit(cache=True, inline="always")
def _stencil_cell(c, k, nc, periodic):
    """Cell k (0, 1, 2) of the 3-wide stencil around cell ``c`` on an axis of ``nc`` cells:
    wrapped in a periodic square, -1 beyond an open edge. An axis under 3 cells wide lists
    each of its cells once (cell k), so no pair is visited twice."""
    if nc < 3:
        return k
    q = c + k - 1
    if q < 0 or q >= nc:
        if not periodic:
            return -1
        q = q + nc if q < 0 else q - nc
    return q


@njit(cache=True, inline="always")
def _min_image(d, box, half):
    """Minimum-image coordinate difference for |d| < box [m]."""
    if d > half:
        return d - box
    if d < -half:
        return d + box
    return d


@njit(cache=True)
def _counting_sort(cell, ncell):
    """``(first, order)``: the agents grouped by cell (a counting sort), index order kept within
    a cell; the agents of cell ``c`` are ``order[first[c]:first[c + 1]]``."""
    n = cell.shape[0]
    first = np.zeros(ncell + 1, dtype=np.int64)
    for i in range(n):
        first[cell[i] + 1] += 1
    for c in range(ncell):
        first[c + 1] += first[c]
    fill = first[:-1].copy()
    order = np.empty(n, dtype=np.int64)
    for i in range(n):
        order[fill[cell[i]]] = i
        fill[cell[i]] += 1
    return first, order


@njit(cache=True)
def _neighbour_csr3(pos, radius, indices, dist2, min_d2):
    """:func:`neighbour_csr` for (N, 3) positions in open space: cubic cells at least ``radius``
    wide (doubled while there are more than ~4N of them), the 27 cells around each agent's."""
    n = pos.shape[0]
    cap = indices.shape[0]
    max_cells = 4 * n + 64
    x0 = np.inf
    y0 = np.inf
    z0 = np.inf
    x1 = -np.inf
    y1 = -np.inf
    z1 = -np.inf
    for i in range(n):
        x0 = min(x0, pos[i, 0])
        y0 = min(y0, pos[i, 1])
        z0 = min(z0, pos[i, 2])
        x1 = max(x1, pos[i, 0])
        y1 = max(y1, pos[i, 1])
        z1 = max(z1, pos[i, 2])
    h = radius if radius > 0.0 else 1.0
    if n == 0:
        x0 = y0 = z0 = 0.0
        x1 = y1 = z1 = 0.0
    # counted in floating point: a tiny radius over a wide swarm would overflow an int product
    while ((x1 - x0) / h + 1.0) * ((y1 - y0) / h + 1.0) * ((z1 - z0) / h + 1.0) > max_cells:
        h *= 2.0
    ncx = int((x1 - x0) / h) + 1
    ncy = int((y1 - y0) / h) + 1
    ncz = int((z1 - z0) / h) + 1
    ncell = ncx * ncy * ncz
    cell = np.empty(n, dtype=np.int64)
    for i in range(n):
        cx = min(max(int((pos[i, 0] - x0) / h), 0), ncx - 1)
        cy = min(max(int((pos[i, 1] - y0) / h), 0), ncy - 1)
        cz = min(max(int((pos[i, 2] - z0) / h), 0), ncz - 1)
        cell[i] = cx + ncx * (cy + ncy * cz)
    first, order = _counting_sort(cell, ncell)
    sp = np.empty((n, 3))
    for s in range(n):
        sp[s, 0] = pos[order[s], 0]
        sp[s, 1] = pos[order[s], 1]
        sp[s, 2] = pos[order[s], 2]
    r2 = radius * radius
    start = np.empty(n, dtype=np.int64)
    end = np.empty(n, dtype=np.int64)
    total = 0
    wx = 3 if ncx >= 3 else ncx
    wy = 3 if ncy >= 3 else ncy
    wz = 3 if ncz >= 3 else ncz
    for c0 in range(ncell):
        cx = c0 % ncx
        cy = (c0 // ncx) % ncy
        cz = c0 // (ncx * ncy)
        for si in range(first[c0], first[c0 + 1]):
            px = sp[si, 0]
            py = sp[si, 1]
            pz = sp[si, 2]
            start[order[si]] = total
            for e in range(wz):
                qz = _stencil_cell(cz, e, ncz, False)
                if qz < 0:
                    continue
                for a in range(wy):
                    qy = _stencil_cell(cy, a, ncy, False)
                    if qy < 0:
                        continue
                    for b in range(wx):
                        qx = _stencil_cell(cx, b, ncx, False)
                        if qx < 0:
                            continue
                        c = qx + ncx * (qy + ncy * qz)
                        for s in range(first[c], first[c + 1]):
                            dx = sp[s, 0] - px
                            dy = sp[s, 1] - py
                            dz = sp[s, 2] - pz
                            d2 = dx * dx + dy * dy + dz * dz
                            if total < cap:
                                indices[total] = order[s]
                                dist2[total] = d2
                            total += (d2 > min_d2) & (d2 <= r2)
            end[order[si]] = total
    return order, start, end, total


@njit(cache=True)
def neighbour_csr(pos, radius, box, wrap, indices, dist2, min_d2=0.0):
    """Fill ``indices`` / ``dist2`` with every neighbour of every agent.

    Agents are visited cell by cell (a counting sort of the cell list), so consecutive agents
    read the same few cells and the row of agent ``i`` is ``indices[start[i]:end[i]]``; rows are
    contiguous but stored in cell order, not in agent order. The candidate test is branch-free:
    every candidate is written and the write position advances only for a true neighbour.

    Args:
        pos: (N, 2) positions [m] (in ``[0, box)`` when periodic), or (N, 3) in open space.
        radius: neighbour radius [m].
        box: side of the periodic square [m], or <= 0 for open space.
        wrap: use minimum-image distances in the periodic square.
        indices: (cap,) int64 output buffer.
        dist2: (cap,) float64 output buffer of squared distances [m^2].
        min_d2: an entry needs ``min_d2 < d^2 <= radius^2`` [m^2]. The default 0 drops the agent
            itself and coincident agents (the Vicsek convention); a negative value keeps both
            (the agent itself is then in its own row, with ``dist2 = 0``).

    Returns:
        ``(order, start, end, total)``: the agents in the order their rows are stored (the
        kernels below visit agents in this order, reading the entries sequentially), (N,) row
        bounds and the number of entries. If ``total`` exceeds the buffers' length they hold
        only a prefix; call again with ``total`` capacity.
    """
    if pos.shape[1] == 3:
        if box > 0.0 and wrap:
            raise ValueError("neighbour_csr: the periodic box is planar, positions must be (N, 2)")
        return _neighbour_csr3(pos, radius, indices, dist2, min_d2)
    n = pos.shape[0]
    cap = indices.shape[0]
    periodic = box > 0.0 and wrap
    x0, y0, h, ncx, ncy = _grid(pos, radius, box, periodic, 4 * n + 64)
    ncell = ncx * ncy
    cell = np.empty(n, dtype=np.int64)
    for i in range(n):
        cx = min(max(int((pos[i, 0] - x0) / h), 0), ncx - 1)
        cy = min(max(int((pos[i, 1] - y0) / h), 0), ncy - 1)
        cell[i] = cx + ncx * cy
    first, order = _counting_sort(cell, ncell)
    sx = np.empty(n)
    sy = np.empty(n)
    for s in range(n):
        sx[s] = pos[order[s], 0]
        sy[s] = pos[order[s], 1]

    r2 = radius * radius
    half = 0.5 * box
    start = np.empty(n, dtype=np.int64)
    end = np.empty(n, dtype=np.int64)
    total = 0
    # Stencil per axis: the 3 cells around, or every cell once when the axis has fewer than 3.
    wx = 3 if ncx >= 3 else ncx
    wy = 3 if ncy >= 3 else ncy
    for c0 in range(ncell):
        cx = c0 % ncx
        cy = c0 // ncx
        for si in range(first[c0], first[c0 + 1]):
            px = sx[si]
            py = sy[si]
            start[order[si]] = total
            for a in range(wy):
                qy = _stencil_cell(cy, a, ncy, periodic)
                if qy < 0:
                    continue
                for b in range(wx):
                    qx = _stencil_cell(cx, b, ncx, periodic)
                    if qx < 0:
                        continue
                    c = qx + ncx * qy
                    for s in range(first[c], first[c + 1]):
                        dx = sx[s] - px
                        dy = sy[s] - py
                        if periodic:  # minimum image (|dx| < box for stored points in [0, box))
                            dx = _min_image(dx, box, half)
                            dy = _min_image(dy, box, half)
                        d2 = dx * dx + dy * dy
                        if total < cap:
                            indices[total] = order[s]
                            dist2[total] = d2
                        total += (d2 > min_d2) & (d2 <= r2)
            end[order[si]] = total
    return order, start, end, total
