"""Numba kernels of the Vicsek family: cell-list neighbour lists, layers, heading and force sums.

Everything works on a sparse neighbour list in CSR form: the neighbours of agent ``i`` are
``indices[indptr[i]:indptr[i + 1]]`` with squared distances ``dist2`` alongside. No kernel
ever holds an N x N array, so one step costs O(N k) for k neighbours per agent (the models run
at N = 10^5).

Conventions shared by every kernel:

* ``j`` is a neighbour of ``i`` iff ``0 < |x_i - x_j| <= radius`` (HWVEM Section 2.2: an agent
  is not its own neighbour, and coincident agents are not neighbours either).
* In a periodic square of side ``box`` with ``wrap = True`` distances are minimum-image; with
  ``wrap = False`` (or ``box <= 0``) they are plain Euclidean distances of the stored points.
* A layer is an int64; :data:`NO_LAYER` marks an agent the layer information has not reached.
* Heading angles live in ``[-pi, pi)``.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

#: Layer of an agent not (yet) connected to the information UAV: "infinitely deep".
NO_LAYER = np.int64(1) << np.int64(60)

# Model codes of :func:`genuine_heading`.
VEM, VEM_A, IVEM, IVEM_A, WVEM, HWVEM = 0, 1, 2, 3, 4, 5


@njit(cache=True)
def wrap_angle(a):
    """``a`` mapped to ``[-pi, pi)``."""
    t = (a + math.pi) % (2.0 * math.pi) - math.pi
    if t >= math.pi:  # floating-point guard: the modulo can round up to 2 pi
        t -= 2.0 * math.pi
    return t


# ---------------------------------------------------------------------------------------------
# Neighbour lists
# ---------------------------------------------------------------------------------------------


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


@njit(cache=True)
def neighbour_csr(pos, radius, box, wrap, indices, dist2):
    """Fill ``indices`` / ``dist2`` with every neighbour of every agent, row by row.

    Args:
        pos: (N, 2) positions [m] (in ``[0, box)`` when periodic).
        radius: neighbour radius [m].
        box: side of the periodic square [m], or <= 0 for open space.
        wrap: use minimum-image distances in the periodic square.
        indices: (cap,) int64 output buffer.
        dist2: (cap,) float64 output buffer of squared distances [m^2].

    Returns:
        ``(indptr, total)``: the (N + 1,) row offsets and the number of entries. If ``total``
        exceeds ``cap`` the buffers hold only a prefix; call again with ``total`` capacity.
    """
    n = pos.shape[0]
    cap = indices.shape[0]
    periodic = box > 0.0 and wrap
    x0, y0, h, ncx, ncy = _grid(pos, radius, box, periodic, 4 * n + 64)
    ncell = ncx * ncy
    cell = np.empty(n, dtype=np.int64)
    start = np.zeros(ncell + 1, dtype=np.int64)
    for i in range(n):
        cx = min(max(int((pos[i, 0] - x0) / h), 0), ncx - 1)
        cy = min(max(int((pos[i, 1] - y0) / h), 0), ncy - 1)
        cell[i] = cx + ncx * cy
        start[cell[i] + 1] += 1
    for c in range(ncell):
        start[c + 1] += start[c]
    fill = start[:-1].copy()
    order = np.empty(n, dtype=np.int64)
    for i in range(n):  # counting sort: agents of a cell stay in index order
        order[fill[cell[i]]] = i
        fill[cell[i]] += 1
    sx = np.empty(n)
    sy = np.empty(n)
    for s in range(n):
        sx[s] = pos[order[s], 0]
        sy[s] = pos[order[s], 1]

    r2 = radius * radius
    half = 0.5 * box
    indptr = np.zeros(n + 1, dtype=np.int64)
    total = 0
    # Stencil per axis: the 3 cells around, or every cell once when the axis has fewer than 3.
    wx = 3 if ncx >= 3 else ncx
    wy = 3 if ncy >= 3 else ncy
    for i in range(n):
        px = pos[i, 0]
        py = pos[i, 1]
        cx = cell[i] % ncx
        cy = cell[i] // ncx
        for a in range(wy):
            if ncy >= 3:
                qy = cy + a - 1
                if periodic:
                    qy = (qy + ncy) % ncy
                elif qy < 0 or qy >= ncy:
                    continue
            else:
                qy = a
            for b in range(wx):
                if ncx >= 3:
                    qx = cx + b - 1
                    if periodic:
                        qx = (qx + ncx) % ncx
                    elif qx < 0 or qx >= ncx:
                        continue
                else:
                    qx = b
                c = qx + ncx * qy
                for s in range(start[c], start[c + 1]):
                    dx = sx[s] - px
                    dy = sy[s] - py
                    if periodic:  # minimum image (|dx| < box for stored points in [0, box))
                        if dx > half:
                            dx -= box
                        elif dx < -half:
                            dx += box
                        if dy > half:
                            dy -= box
                        elif dy < -half:
                            dy += box
                    d2 = dx * dx + dy * dy
                    if d2 > 0.0 and d2 <= r2:
                        if total < cap:
                            indices[total] = order[s]
                            dist2[total] = d2
                        total += 1
        indptr[i + 1] = total
    return indptr, total


# ---------------------------------------------------------------------------------------------
# Layers (HWVEM eq. 2-5)
# ---------------------------------------------------------------------------------------------


@njit(cache=True)
def next_layers(indptr, indices, dist2, r2, layers, iu, out):
    """Eq. (5): ``l_i(k) = min {l_j(k-1) + 1 | j in N_i(k-1)}``; the information UAV is layer 1.

    ``layers`` are the previous step's layers and the CSR the previous step's neighbours
    (entries farther than ``sqrt(r2)`` are skipped). Unreached agents keep :data:`NO_LAYER`.
    """
    n = layers.shape[0]
    for i in range(n):
        best = NO_LAYER
        for e in range(indptr[i], indptr[i + 1]):
            if dist2[e] <= r2:
                lj = layers[indices[e]]
                if lj < best:
                    best = lj
        out[i] = best + 1 if best < NO_LAYER else NO_LAYER
    if iu >= 0:
        out[iu] = 1


@njit(cache=True)
def bfs_layers(indptr, indices, dist2, r2, iu, out):
    """Hop distance + 1 from agent ``iu`` in the current graph (eq. 2-4: the shortest neighbour
    sequence); :data:`NO_LAYER` for agents in another connected component. This is the fixed
    point of eq. (5) on a frozen graph."""
    n = out.shape[0]
    for i in range(n):
        out[i] = NO_LAYER
    if iu < 0:
        return
    queue = np.empty(n, dtype=np.int64)
    out[iu] = 1
    queue[0] = iu
    head = 0
    tail = 1
    while head < tail:
        i = queue[head]
        head += 1
        for e in range(indptr[i], indptr[i + 1]):
            if dist2[e] <= r2:
                j = indices[e]
                if out[j] == NO_LAYER:
                    out[j] = out[i] + 1
                    queue[tail] = j
                    tail += 1


# ---------------------------------------------------------------------------------------------
# Heading update
# ---------------------------------------------------------------------------------------------


@njit(cache=True)
def genuine_heading(code, indptr, indices, dist2, r2, theta, theta_g, layers, avoiding, iu, iu_nb,
                    theta_d, p1, p2, use_nei, k_alpha, k_beta, k_gamma, info_weight, out):
    """New genuine desired heading of every agent (HWVEM eq. 18, without noise).

    Weighted models (VEM, VEM-A, WVEM, HWVEM, and IVEM-A next to the information UAV)::

        theta_i <- atan2(sum_j h_ij o_j sin theta_j, sum_j h_ij o_j cos theta_j)

    over neighbours ``j`` within ``sqrt(r2)`` that are not avoiding an obstacle (``o_j = 1``).
    ``h_ij`` is 1 (VEM, VEM-A), ``k_alpha`` / ``k_beta`` / ``k_gamma`` by the type of ``j``
    (WVEM), ``info_weight`` for the information UAV (IVEM-A), or eq. (13)-(17) (HWVEM):
    ``(1/l_j + p1) * p2^-(l_j - l_min) * w_nei_ij``; the factor ``p2^l_min`` common to a row
    leaves the angle unchanged and keeps deep layers from underflowing. Unreached
    neighbours (``l_j`` infinite) weigh ``p1 * w_nei`` if ``p2 == 1`` and 0 otherwise (the
    limit of eq. 14-15); a row whose contributors are all unreached averages them uniformly.

    IVEM (and IVEM-A away from the information UAV), eq. (30)-(31)::

        theta_i <- theta_i + lambda * (max_j theta_j - min_j theta_j) / 2

    with ``lambda = 1`` if ``theta_i <= min``, ``-1`` if ``theta_i >= max``, else 0.

    An agent with no contributing neighbour keeps ``theta_g``; the information UAV gets
    ``theta_d`` (eq. 9 with ``b_ij = 0`` for ``i`` in layer 1).
    """
    n = theta.shape[0]
    max_deg = 0
    for i in range(n):
        max_deg = max(max_deg, indptr[i + 1] - indptr[i])
    lay_val = np.empty(max_deg + 1, dtype=np.int64)
    lay_cnt = np.empty(max_deg + 1, dtype=np.int64)
    log_p2 = math.log(p2)
    sin_t = np.sin(theta)  # once per agent, not once per neighbour entry
    cos_t = np.cos(theta)
    for i in range(n):
        if i == iu:
            out[i] = theta_d
            continue
        a = indptr[i]
        b = indptr[i + 1]
        if code == IVEM or (code == IVEM_A and not iu_nb[i]):
            lo = np.inf
            hi = -np.inf
            for e in range(a, b):
                if dist2[e] <= r2:
                    j = indices[e]
                    if not avoiding[j]:
                        lo = min(lo, theta[j])
                        hi = max(hi, theta[j])
            if lo > hi:
                out[i] = theta_g[i]
                continue
            lam = 0.0
            if theta[i] <= lo:
                lam = 1.0
            elif theta[i] >= hi:
                lam = -1.0
            out[i] = wrap_angle(theta[i] + lam * (hi - lo) / 2.0)
            continue

        l_min = NO_LAYER
        n_i = 0
        nd = 0
        if code == HWVEM:
            # |N_i|, the count of neighbours per layer (eq. 16) and the shallowest contributor.
            for e in range(a, b):
                if dist2[e] <= r2:
                    j = indices[e]
                    lj = layers[j]
                    n_i += 1
                    found = False
                    for q in range(nd):
                        if lay_val[q] == lj:
                            lay_cnt[q] += 1
                            found = True
                            break
                    if not found:
                        lay_val[nd] = lj
                        lay_cnt[nd] = 1
                        nd += 1
                    if not avoiding[j] and lj < l_min:
                        l_min = lj
        s = 0.0
        c = 0.0
        su = 0.0
        cu = 0.0
        n_contrib = 0
        for e in range(a, b):
            if dist2[e] > r2:
                continue
            j = indices[e]
            if avoiding[j]:
                continue
            sj = sin_t[j]
            cj = cos_t[j]
            n_contrib += 1
            su += sj
            cu += cj
            w = 1.0
            if code == WVEM:
                if j == iu:
                    w = k_alpha
                elif iu_nb[j]:
                    w = k_beta
                else:
                    w = k_gamma
            elif code == IVEM_A:
                w = info_weight if j == iu else 1.0
            elif code == HWVEM:
                lj = layers[j]
                w_nei = 1.0
                if use_nei:
                    for q in range(nd):
                        if lay_val[q] == lj:
                            d = n_i / lay_cnt[q]
                            if d > math.e:
                                w_nei = math.log(d)
                            break
                if l_min == NO_LAYER:
                    w = 1.0  # only unreached contributors: uniform (below)
                elif lj == NO_LAYER:
                    w = p1 * w_nei if p2 == 1.0 else 0.0
                else:
                    w = (1.0 / lj + p1) * math.exp(-(lj - l_min) * log_p2) * w_nei
            s += w * sj
            c += w * cj
        if n_contrib == 0:
            out[i] = theta_g[i]
        elif s == 0.0 and c == 0.0:
            # every weight vanished (only unreached contributors): plain average of them
            out[i] = math.atan2(su, cu)
        else:
            out[i] = math.atan2(s, c)


@njit(cache=True)
def attraction_repulsion(indptr, indices, dist2, pos, box, wrap, r_rep, r_att, iu, att, rep):
    """Eq. (23)-(24) with ``x_ij = x_i - x_j``: repulsion ``(r_rep - d)/r_rep`` along ``x_ij`` for
    ``0 < d <= r_rep``, attraction ``(r_rep - d)/(r_att - r_rep)`` along ``x_ij`` (negative:
    toward j) for ``r_rep < d <= r_att``. The information UAV feels neither (Section 2.4)."""
    n = pos.shape[0]
    periodic = box > 0.0 and wrap
    for i in range(n):
        ax = 0.0
        ay = 0.0
        rx = 0.0
        ry = 0.0
        if i != iu:
            for e in range(indptr[i], indptr[i + 1]):
                d = math.sqrt(dist2[e])
                if d > r_att and d > r_rep:
                    continue
                j = indices[e]
                dx = pos[i, 0] - pos[j, 0]
                dy = pos[i, 1] - pos[j, 1]
                if periodic:
                    dx -= box * math.floor(dx / box + 0.5)
                    dy -= box * math.floor(dy / box + 0.5)
                ux = dx / d
                uy = dy / d
                if d <= r_rep:
                    f = (r_rep - d) / r_rep
                    rx += f * ux
                    ry += f * uy
                elif d <= r_att:
                    f = (r_rep - d) / (r_att - r_rep)
                    ax += f * ux
                    ay += f * uy
        att[i, 0] = ax
        att[i, 1] = ay
        rep[i, 0] = rx
        rep[i, 1] = ry
