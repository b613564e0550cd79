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
* On a network each agent has its own picture of the others (``networked.py``): a neighbour then
  is a *ghost slot* N + e holding agent i's picture of agent j (its position, heading, layer),
  read by agent i only. The per-agent arrays hold the N agents' own values first and the ghosts
  after them; the loops run over the N rows of ``order``.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from swarmnav.sensing.cells import neighbour_csr  # noqa: F401  (the models' neighbour lists, K.neighbour_csr)

#: Layer of an agent not (yet) connected to the information UAV: "infinitely deep".
NO_LAYER = np.int64(1) << np.int64(60)

# Model codes of :func:`genuine_heading`.
VEM, VEM_A, IVEM, IVEM_A, WVEM, HWVEM = 0, 1, 2, 3, 4, 5
# Readings of IVEM's eq. (30)-(31) (``ivem_rule`` of :func:`genuine_heading`): the printed update
# theta_i + lambda (max - min) / 2, or the text's "middle of the two neighbours' directions with
# the maximum deviation" (max + min) / 2; angles compared as numbers in [-pi, pi) or as
# differences wrap(theta_j - theta_i) from the agent's own heading (on the circle).
IVEM_PRINTED, IVEM_MIDDLE, IVEM_PRINTED_CIRCULAR, IVEM_MIDDLE_CIRCULAR = 0, 1, 2, 3
# Norms of Deg_con, eq. (28) (``norm`` of :func:`consistency`).
NORM_L1, NORM_L2, NORM_LINF = 1, 2, 0


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
# Layers (HWVEM eq. 2-5)
# ---------------------------------------------------------------------------------------------


@njit(cache=True)
def next_layers(order, start, end, indices, dist2, r2, layers, iu, out):
    """Eq. (5): ``l_i(k) = min {l_j(k-1) + 1 | j in N_i(k-1)}``; the information UAV is layer 1.

    ``layers`` are the previous step's layers and the CSR the previous step's neighbours
    (entries farther than ``sqrt(r2)`` are skipped). Unreached agents keep :data:`NO_LAYER`.
    ``layers`` may hold more slots than there are agents (ghost neighbours, module docstring).
    """
    n = order.shape[0]
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
                    theta_d, p1, p2, use_nei, k_alpha, k_beta, k_gamma, info_weight, noise, out,
                    ivem_rule=IVEM_PRINTED, ivem_shift=0.0, ivem_self=False, key_in=None, key_out=None, ident=None):
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

    IVEM (and IVEM-A away from the information UAV), eq. (30)-(31), ``ivem_rule``
    :data:`IVEM_PRINTED` (as printed)::

        theta_i <- theta_i + lambda * (max_j theta_j - min_j theta_j) / 2

    with ``lambda = 1`` if ``theta_i <= min``, ``-1`` if ``theta_i >= max``, else 0;
    :data:`IVEM_MIDDLE`: ``theta_i <- (max_j theta_j + min_j theta_j) / 2`` (the text's "middle of
    the two neighbours' directions with the maximum deviation"). The ``_CIRCULAR`` readings
    take max and min of ``wrap(theta_j - theta_i)`` (the neighbours seen from the agent's own
    heading, which is then 0) instead of the angles as numbers in ``[-pi, pi)``.
    ``ivem_shift`` [rad] moves the range the non-circular readings compare numbers in to
    ``[ivem_shift - pi, ivem_shift + pi)`` (0: ``[-pi, pi)``; pi: ``[0, 2 pi)``, the range the
    initial headings are drawn from). ``ivem_self``: the agent's own heading counts among the
    neighbours' min and max (the original Vicsek neighbourhood, ``|x_i - x_j| <= r``).
    ``key_in`` (N,), if given, are the numbers the non-circular readings compare instead (the
    headings as the paper's equations leave them, never wrapped: ``ivem_range = raw``), and
    ``key_out`` (N,) receives the new numbers: eq. (30)'s sum for the IVEM rows, the arc tangent
    of eq. (9) (in ``[-pi, pi]``) for the weighted rows, ``theta_d`` for the information UAV,
    each plus its noise and unwrapped (an agent that keeps ``theta_g`` turns its number by
    ``wrap(theta_g - theta)``); the wrapped headings go to ``out`` as always.

    ``theta``, ``layers``, ``avoiding``, ``iu_nb`` and ``key_in`` may hold ghost slots beyond the
    N agents (module docstring); ``ident`` (slots,) then names the agent each slot stands for (the
    information UAV's weight); None: slot j is agent j.

    An agent with no contributing neighbour keeps ``theta_g``; the information UAV gets
    ``theta_d`` (eq. 9 with ``b_ij = 0`` for ``i`` in layer 1). ``noise`` (N,) [rad] is added to
    every other agent and the sum wrapped to ``[-pi, pi)``; an empty array means no noise.
    """
    n = order.shape[0]
    noisy = noise.shape[0] == n
    filt = r2 < np.inf  # r2 = inf: every entry is within r (the list was built at r)
    any_av = False  # nobody avoiding (always so in open space): skip the o_j lookups
    for i in range(avoiding.shape[0]):
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
            if key_out is not None:
                key_out[i] = theta_d
            continue
        a = start[i]
        b = end[i]
        if code == IVEM or (code == IVEM_A and not iu_nb[i]):
            circ = ivem_rule == IVEM_PRINTED_CIRCULAR or ivem_rule == IVEM_MIDDLE_CIRCULAR
            # the agent's heading in the frame of lo, hi: relative to itself (circular), as a
            # number in [ivem_shift - pi, ivem_shift + pi), or the number key_in holds
            own = 0.0
            if not circ:
                if key_in is None:
                    own = wrap_angle(theta[i] - ivem_shift)
                else:
                    own = key_in[i]
            lo = np.inf  # min and max neighbour heading
            hi = -np.inf
            for e in range(a, b):
                if dist2[e] <= r2:
                    j = indices[e]
                    if not avoiding[j]:
                        if circ:
                            tj = wrap_angle(theta[j] - theta[i])
                        elif key_in is None:
                            tj = wrap_angle(theta[j] - ivem_shift)
                        else:
                            tj = key_in[j]
                        lo = min(lo, tj)
                        hi = max(hi, tj)
            if lo <= hi and ivem_self:
                lo = min(lo, own)
                hi = max(hi, own)
            new_key = own
            if lo > hi:
                out[i] = theta_g[i]
                new_key = own + wrap_angle(theta_g[i] - theta[i])  # the number turns with the heading
            elif ivem_rule == IVEM_MIDDLE or ivem_rule == IVEM_MIDDLE_CIRCULAR:
                new_key = (hi + lo) / 2.0
                out[i] = wrap_angle(theta[i] - own + new_key)
            else:
                lam = 0.0
                if own <= lo:
                    lam = 1.0
                elif own >= hi:
                    lam = -1.0
                new_key = own + lam * (hi - lo) / 2.0
                out[i] = wrap_angle(theta[i] + lam * (hi - lo) / 2.0)
            if noisy:
                out[i] = wrap_angle(out[i] + noise[i])
                new_key += noise[i]
            if key_out is not None:
                key_out[i] = out[i] if circ else new_key
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
                if (j if ident is None else ident[j]) == iu:
                    w = k_alpha
                elif iu_nb[j]:
                    w = k_beta
                else:
                    w = k_gamma
            elif code == IVEM_A:
                w = info_weight if (j if ident is None else ident[j]) == iu else 1.0
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
        kept = n_contrib == 0
        if kept:
            out[i] = theta_g[i]
        elif s == 0.0 and c == 0.0:
            # every weight vanished (only unreached contributors): plain average of them
            out[i] = math.atan2(su, cu)
        else:
            out[i] = math.atan2(s, c)
        raw = out[i]
        if noisy:
            raw += noise[i]
            out[i] = wrap_angle(raw)
        if key_out is not None:
            if kept and key_in is not None:  # the number turns with the heading
                key_out[i] = key_in[i] + wrap_angle(theta_g[i] - theta[i]) + (noise[i] if noisy else 0.0)
            else:
                key_out[i] = raw


@njit(cache=True)
def attraction_repulsion(order, start, end, indices, dist2, pos, box, wrap, r_rep, r_att, iu, att, rep):
    """Eq. (23)-(24) with ``x_ij = x_i - x_j``: repulsion ``(r_rep - d)/r_rep`` along ``x_ij`` for
    ``0 < d <= r_rep``, attraction ``(r_rep - d)/(r_att - r_rep)`` along ``x_ij`` (negative:
    toward j) for ``r_rep < d <= r_att``. The information UAV feels neither (Section 2.4).
    ``pos`` may hold ghost slots beyond the N agents (module docstring)."""
    n = order.shape[0]
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
def consistency(theta, ref, use_mean, norm):
    """Deg_con of eq. (28) against ``ref`` [rad], or against the circular mean of ``theta`` when
    ``use_mean``; ``norm`` is :data:`NORM_L1` (mean absolute deviation), :data:`NORM_L2`
    (Euclidean norm / N) or :data:`NORM_LINF` (largest deviation / N). The same number as
    ``measures.deg_con`` in one pass."""
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
        if norm == NORM_L2:
            acc += d * d
        elif norm == NORM_L1:
            acc += d
        else:
            acc = max(acc, d)
    m = math.sqrt(acc) / n if norm == NORM_L2 else acc / n
    return (math.pi - m) / math.pi
