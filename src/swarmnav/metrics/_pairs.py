"""Close pairs over a whole trajectory in one compiled pass (cell lists, never N x N).

``close_pairs_run`` walks the K + 1 recorded steps once; per step it bins agents into square
cells of side >= ``rc`` (the periodic cell is split into an integer number of them) and
compares each agent with the agents of its own and the 8 surrounding cells. It returns the
smallest distance among the pairs closer than ``rc`` and the number of contact episodes (a pair
closer than ``contact`` counts once per run of consecutive steps), so ``contact <= rc``.
"""

from __future__ import annotations

import numba as nb
import numpy as np


@nb.njit(cache=True)
def _step_pairs(P, box, rc, contact, keys):
    """Fill ``keys`` with i * N + j for pairs i < j closer than ``contact``; return (count,
    smallest distance among pairs closer than ``rc``, inf if none). A count above
    ``len(keys)`` means the buffer was too small: call again with a larger one."""
    N = P.shape[0]
    periodic = box > 0.0
    if periodic:
        nx = max(int(box // rc), 1)
        ny = nx
        cell = box / nx
        x0 = 0.0
        y0 = 0.0
    else:
        x0, y0 = P[0, 0], P[0, 1]
        x1, y1 = x0, y0
        for i in range(N):
            x0 = min(x0, P[i, 0])
            y0 = min(y0, P[i, 1])
            x1 = max(x1, P[i, 0])
            y1 = max(y1, P[i, 1])
        cell = rc
        area = (x1 - x0 + rc) * (y1 - y0 + rc)
        if area > (4 * N + 16) * rc * rc:  # a far-flung swarm: wider cells, at most ~4N of them
            cell = np.sqrt(area / (4 * N + 16))
        nx = int((x1 - x0) // cell) + 1
        ny = int((y1 - y0) // cell) + 1
    stencil = 3 if (not periodic or nx >= 3) else nx  # a periodic grid under 3 cells wide: no repeats
    cx = np.empty(N, np.int64)
    cy = np.empty(N, np.int64)
    count = np.zeros(nx * ny + 1, np.int64)
    for i in range(N):
        xi = P[i, 0] % box if periodic else P[i, 0] - x0
        yi = P[i, 1] % box if periodic else P[i, 1] - y0
        cx[i] = min(int(xi / cell), nx - 1)
        cy[i] = min(int(yi / cell), ny - 1)
        count[cx[i] * ny + cy[i] + 1] += 1
    for c in range(nx * ny):
        count[c + 1] += count[c]
    order = np.empty(N, np.int64)
    fill = count[:-1].copy()
    for i in range(N):
        c = cx[i] * ny + cy[i]
        order[fill[c]] = i
        fill[c] += 1
    best = np.inf
    n = 0
    rc2 = rc * rc
    for i in range(N):
        for a in range(stencil):
            ox = cx[i] + a - (1 if stencil == 3 else 0)
            if periodic:
                ox %= nx
            elif ox < 0 or ox >= nx:
                continue
            for b in range(stencil):
                oy = cy[i] + b - (1 if stencil == 3 else 0)
                if periodic:
                    oy %= ny
                elif oy < 0 or oy >= ny:
                    continue
                c = ox * ny + oy
                for s in range(count[c], count[c + 1]):
                    j = order[s]
                    if j <= i:
                        continue
                    dx = P[j, 0] - P[i, 0]
                    dy = P[j, 1] - P[i, 1]
                    if periodic:
                        dx -= box * np.round(dx / box)
                        dy -= box * np.round(dy / box)
                    d2 = dx * dx + dy * dy
                    if d2 < rc2:
                        d = np.sqrt(d2)
                        if d < best:
                            best = d
                        if d < contact:
                            if n < keys.shape[0]:
                                keys[n] = i * N + j
                            n += 1
    return n, best


@nb.njit(cache=True)
def close_pairs_run(positions, box, rc, contact):
    """(smallest pair distance below ``rc`` over the run or inf, contact episodes).

    Args:
        positions: (K + 1, N, 2) [m].
        box: periodic cell side [m], or 0 for an open world.
        rc: search radius [m] (>= contact).
        contact: contact distance [m].
    """
    K1, N, _ = positions.shape
    best = np.inf
    hits = 0
    keys = np.empty(8 * N, np.int64)
    prev = np.empty(0, np.int64)
    for k in range(K1):
        n, b = _step_pairs(positions[k], box, rc, contact, keys)
        if n > keys.shape[0]:
            keys = np.empty(2 * n, np.int64)
            n, b = _step_pairs(positions[k], box, rc, contact, keys)
        if b < best:
            best = b
        cur = np.sort(keys[:n])
        p = 0
        for t in range(n):  # keys in cur but not in prev are new contact episodes
            while p < prev.shape[0] and prev[p] < cur[t]:
                p += 1
            if p >= prev.shape[0] or prev[p] != cur[t]:
                hits += 1
        prev = cur
    return best, hits
