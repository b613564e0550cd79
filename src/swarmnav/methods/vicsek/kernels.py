"""Numba kernels of the Vicsek family: cell-list neighbour lists, layers, heading and force sums.

Everything works on a sparse neighbour list (CSR-like): the neighbours of agent ``i`` are
``indices[start[i]:end[i]]`` with squared distances ``dist2`` alongside, and ``order`` lists the
agents in the order their rows are stored (cell by cell), which is the order the kernels visit
them in: the entries are then read sequentially. No kernel
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
    if -math.pi <= a < math.pi:  # the common case: already in range
        return a
    t = a - 2.0 * math.pi * math.floor((a + math.pi) / (2.0 * math.pi))
    if t >= math.pi:  # floating-point guards at the ends of the range
        t -= 2.0 * math.pi
    elif t < -math.pi:
        t += 2.0 * math.pi
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
    """Fill ``indices`` / ``dist2`` with every neighbour of every agent.

    Agents are visited cell by cell (a counting sort of the cell list), so consecutive agents
    read the same few cells and the row of agent ``i`` is ``indices[start[i]:end[i]]``; rows are
    contiguous but stored in cell order, not in agent order. The candidate test is branch-free:
    every candidate is written and the write position advances only for a true neighbour.

    Args:
        pos: (N, 2) positions [m] (in ``[0, box)`` when periodic).
        radius: neighbour radius [m].
        box: side of the periodic square [m], or <= 0 for open space.
        wrap: use minimum-image distances in the periodic square.
        indices: (cap,) int64 output buffer.
        dist2: (cap,) float64 output buffer of squared distances [m^2].

    Returns:
        ``(order, start, end, total)``: the agents in the order their rows are stored (the
        kernels below visit agents in this order, reading the entries sequentially), (N,) row
        bounds and the number of entries. If ``total`` exceeds the buffers' length they hold
        only a prefix; call again with ``total`` capacity.
    """
    n = pos.shape[0]
    cap = indices.shape[0]
    periodic = box > 0.0 and wrap
    x0, y0, h, ncx, ncy = _grid(pos, radius, box, periodic, 4 * n + 64)
    ncell = ncx * ncy
    cell = np.empty(n, dtype=np.int64)
    first = np.zeros(ncell + 1, dtype=np.int64)
    for i in range(n):
        cx = min(max(int((pos[i, 0] - x0) / h), 0), ncx - 1)
        cy = min(max(int((pos[i, 1] - y0) / h), 0), ncy - 1)
        cell[i] = cx + ncx * cy
        first[cell[i] + 1] += 1
    for c in range(ncell):
        first[c + 1] += first[c]
    fill = first[:-1].copy()
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
                if ncy >= 3:
                    qy = cy + a - 1
                    if qy < 0 or qy >= ncy:
                        if not periodic:
                            continue
                        qy = qy + ncy if qy < 0 else qy - ncy
                else:
                    qy = a
                for b in range(wx):
                    if ncx >= 3:
                        qx = cx + b - 1
                        if qx < 0 or qx >= ncx:
                            if not periodic:
                                continue
                            qx = qx + ncx if qx < 0 else qx - ncx
                    else:
                        qx = b
                    c = qx + ncx * qy
                    for s in range(first[c], first[c + 1]):
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
                        if total < cap:
                            indices[total] = order[s]
                            dist2[total] = d2
                        total += (d2 > 0.0) & (d2 <= r2)
            end[order[si]] = total
    return order, start, end, total


# ---------------------------------------------------------------------------------------------
# Layers (HWVEM eq. 2-5)
# ---------------------------------------------------------------------------------------------


@njit(cache=True)
def next_layers(order, start, end, indices, dist2, r2, layers, iu, out):
    """Eq. (5): ``l_i(k) = min {l_j(k-1) + 1 | j in N_i(k-1)}``; the information UAV is layer 1.

    ``layers`` are the previous step's layers and the CSR the previous step's neighbours
    (entries farther than ``sqrt(r2)`` are skipped). Unreached agents keep :data:`NO_LAYER`.
    """
    n = layers.shape[0]
    for t in range(n):
        i = order[t]
        best = NO_LAYER
        for e in range(start[i], end[i]):
            if dist2[e] <= r2:
                lj = layers[indices[e]]
                if lj < best:
                    best = lj
        out[i] = best + 1 if best < NO_LAYER else NO_LAYER
    if iu >= 0:
        out[iu] = 1


@njit(cache=True)
def bfs_layers(order, start, end, indices, dist2, r2, iu, out):
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
        for e in range(start[i], end[i]):
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
def genuine_heading(code, order, start, end, indices, dist2, r2, theta, theta_g, layers, avoiding, iu, iu_nb,
                    theta_d, p1, p2, use_nei, k_alpha, k_beta, k_gamma, info_weight, noise, out):
    """New genuine desired heading of every agent (HWVEM eq. 18) plus the noise of eq. (6).

    Weighted models (VEM, VEM-A, WVEM, HWVEM, and IVEM-A next to the information UAV)::

        theta_i <- atan2(sum_j h_ij o_j sin theta_j, sum_j h_ij o_j cos theta_j)

    over neighbours ``j`` within ``sqrt(r2)`` that are not avoiding an obstacle (``o_j = 1``);
    ``r2 = inf`` declares that every listed neighbour is within r (no distance test).
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
    ``theta_d`` (eq. 9 with ``b_ij = 0`` for ``i`` in layer 1). ``noise`` (N,) [rad] is added to
    every other agent and the sum wrapped to ``[-pi, pi)``; an empty array means no noise.
    """
    noisy = noise.shape[0] == theta.shape[0]
    n = theta.shape[0]
    filt = r2 < np.inf  # r2 = inf: every entry is within r (the list was built at r)
    any_av = False  # nobody avoiding (always so in open space): skip the o_j lookups
    for i in range(n):
        if avoiding[i]:
            any_av = True
            break
    max_deg = 0
    for i in range(n):
        max_deg = max(max_deg, end[i] - start[i])
    lay_val = np.empty(max_deg + 1, dtype=np.int64)
    lay_cnt = np.empty(max_deg + 1, dtype=np.int64)
    log_p2 = math.log(p2)
    sin_t = np.sin(theta)  # once per agent, not once per neighbour entry
    cos_t = np.cos(theta)
    for t in range(n):
        i = order[t]
        if i == iu:
            out[i] = theta_d
            continue
        a = start[i]
        b = end[i]
        if code == IVEM or (code == IVEM_A and not iu_nb[i]):
            lo = np.inf  # min and max neighbour heading
            hi = -np.inf
            for e in range(a, b):
                if dist2[e] <= r2:
                    j = indices[e]
                    if not avoiding[j]:
                        lo = min(lo, theta[j])
                        hi = max(hi, theta[j])
            if lo > hi:
                out[i] = theta_g[i]
            else:
                lam = 0.0
                if theta[i] <= lo:
                    lam = 1.0
                elif theta[i] >= hi:
                    lam = -1.0
                out[i] = wrap_angle(theta[i] + lam * (hi - lo) / 2.0)
            if noisy:
                out[i] = wrap_angle(out[i] + noise[i])
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
            if filt and dist2[e] > r2:
                continue
            j = indices[e]
            if any_av and avoiding[j]:
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
        if noisy:
            out[i] = wrap_angle(out[i] + noise[i])


@njit(cache=True)
def attraction_repulsion(order, start, end, indices, dist2, pos, box, wrap, r_rep, r_att, iu, att, rep):
    """Eq. (23)-(24) with ``x_ij = x_i - x_j``: repulsion ``(r_rep - d)/r_rep`` along ``x_ij`` for
    ``0 < d <= r_rep``, attraction ``(r_rep - d)/(r_att - r_rep)`` along ``x_ij`` (negative:
    toward j) for ``r_rep < d <= r_att``. The information UAV feels neither (Section 2.4)."""
    n = pos.shape[0]
    periodic = box > 0.0 and wrap
    for t in range(n):
        i = order[t]
        ax = 0.0
        ay = 0.0
        rx = 0.0
        ry = 0.0
        if i != iu:
            for e in range(start[i], end[i]):
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


# ---------------------------------------------------------------------------------------------
# Velocity and consistency
# ---------------------------------------------------------------------------------------------


@njit(cache=True)
def velocity(theta, avoiding, att, rep, speed0, c_rep, c_att, v_max, tangent, out):
    """Eq. (25)-(26): ``v_des = speed0 (cos theta, sin theta) + c_rep rep + c_att att`` with
    ``speed0 = c_align v0``, scaled to ``min(|v_des|, v_max)``. ``att`` / ``rep`` may be empty
    (terms off). With ``tangent``, an avoiding agent keeps that speed but flies along its
    heading theta_obs (Section 2.3: it moves along the tangent)."""
    n = theta.shape[0]
    forces = att.shape[0] == n
    for i in range(n):
        ux = math.cos(theta[i])
        uy = math.sin(theta[i])
        vx = speed0 * ux
        vy = speed0 * uy
        if forces:
            vx += c_rep * rep[i, 0] + c_att * att[i, 0]
            vy += c_rep * rep[i, 1] + c_att * att[i, 1]
        sp = math.sqrt(vx * vx + vy * vy)
        cap = min(sp, v_max)
        if tangent and avoiding[i]:
            out[i, 0] = cap * ux
            out[i, 1] = cap * uy
        elif sp > 0.0:
            out[i, 0] = vx * (cap / sp)
            out[i, 1] = vy * (cap / sp)
        else:
            out[i, 0] = 0.0
            out[i, 1] = 0.0


@njit(cache=True)
def consistency(theta, ref, use_mean, l2):
    """Deg_con of eq. (28) against ``ref`` [rad], or against the circular mean of ``theta`` when
    ``use_mean``; the norm is L1 (mean absolute deviation) or, with ``l2``, L2 / N. The same
    number as ``measures.deg_con`` in one pass."""
    n = theta.shape[0]
    if use_mean:
        s = 0.0
        c = 0.0
        for i in range(n):
            s += math.sin(theta[i])
            c += math.cos(theta[i])
        ref = math.atan2(s, c)
    acc = 0.0
    for i in range(n):
        d = abs(wrap_angle(theta[i] - ref))
        acc += d * d if l2 else d
    m = math.sqrt(acc) / n if l2 else acc / n
    return (math.pi - m) / math.pi
