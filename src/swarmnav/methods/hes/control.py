"""Stage 5 of a HES step: the eight force terms of eq. (38) and the saturation of eq. (39).

In order: the couplings of each agent (its subleader, the centroid and nearest neighbour of its
cohesion group, its c_s), the occlusion factors of eq. (30), the parts' ``steer`` hook (single
members re-targeted, safety distances lowered), the reference velocity of eq. (23), the eight
terms (``push_back``: a part may edit them), the parts' ``brake`` hook, saturation (eq. 39), the
parts' ``guard`` hook.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from swarmnav.methods.hes import forces as F
from swarmnav.methods.hes.decision import NAVIGATE
from swarmnav.methods.hes.hierarchy import gather_rows
from swarmnav.methods.hes.neighbours import neighbour_rows
from swarmnav.methods.hes.step import Step
from swarmnav.sensing import segments_blocked_kernel


def _sub_rows(h):
    """The partition and its sub-swarms' subleaders, c_s and navigate flags, in column order."""
    part = h.partition()
    subs = [h.subs[s] for s in part.ids]
    return (part, np.array([sub.subleader for sub in subs]), np.array([sub.waypoint for sub in subs]),
            np.array([sub.mode == NAVIGATE for sub in subs]))


def couplings(h, step: Step) -> None:
    """Each agent's subleader, c_s, mode, cohesion centroid and nearest neighbour (eq. 26-32).

    An agent routed on its own (``Step.own``) forms a cohesion group with the others routed to
    the same point, heads for that point (its c_s) and is not coupled to a subleader."""
    x = step.x
    part, sub_sl, sub_wp, sub_nav = _sub_rows(h)
    col = part.col
    rows = step.rows = neighbour_rows(x, h.pair_radius)
    if step.n_own:  # agents routed on their own
        sl_idx, wp, nav = sub_sl[col], sub_wp[col], sub_nav[col]
        follower = sl_idx != h.arange
        queued = step.own >= 0
        cgrp = col * (int(step.own.max()) + 2) + step.own + 1  # (sub-swarm, own group) pairs, in that order
        uniq, cgrp = np.unique(cgrp, return_inverse=True)
        cent = F.group_centroids(x, cgrp, len(uniq))[cgrp]
        wp[queued] = step.own_target[queued]
        follower &= ~queued
        nn = F.nearest_in_group(x, cgrp, *rows)
    else:
        sl_idx, wp, nav, follower, cent, nn = couple(x, h.labels, col, sub_sl, sub_wp, sub_nav, *rows)
    step.col, step.sl_idx, step.wp, step.nav = col, sl_idx, wp, nav
    step.follower, step.cent, step.nn = follower, cent, nn


@njit(cache=True)
def couple(x, labels, col, sub_sl, sub_wp, sub_nav, ptr, idx):
    """:func:`couplings` with no agent routed on its own, in one pass: each agent's subleader,
    c_s and mode from its sub-swarm's (``sub_*``, rows in ``col`` order), whether it is a
    follower, its sub-swarm's centroid and its nearest neighbour in it."""
    n = x.shape[0]
    out = (np.empty(n, dtype=np.int64), np.empty((n, 2)), np.empty(n, dtype=np.bool_), np.empty(n, dtype=np.bool_),
           np.empty((n, 2)), np.empty(n, dtype=np.int64))
    couple_into(x, labels, col, sub_sl, sub_wp, sub_nav, ptr, idx, *out)
    return out


@njit(cache=True)
def couple_into(x, labels, col, sub_sl, sub_wp, sub_nav, ptr, idx, sl_idx, wp, nav, follower, cent, nn):
    """:func:`couple` written into ``sl_idx``, ``wp``, ``nav``, ``follower``, ``cent``, ``nn``."""
    g = F.group_centroids(x, col, sub_sl.shape[0])
    for i in range(x.shape[0]):
        c = col[i]
        sl_idx[i] = sub_sl[c]
        follower[i] = sl_idx[i] != i
        nav[i] = sub_nav[c]
        wp[i, 0], wp[i, 1] = sub_wp[c, 0], sub_wp[c, 1]
        cent[i, 0], cent[i, 1] = g[c, 0], g[c, 1]
    nn[:] = F.nearest_in_group(x, labels, ptr, idx)


def couple_occlude(h, step: Step) -> None:
    """:func:`couplings` and :func:`occlusion` in one compiled pass when no agent is routed on
    its own (the same values), written into the run's workspace (``couple_workspace``): these
    arrays of a step are rewritten by the next step."""
    p = h.params
    part, sub_sl, sub_wp, sub_nav = _sub_rows(h)
    rows = step.rows = neighbour_rows(step.x, h.pair_radius)
    check = not (h.no_obstacles or (p.sigma == 1.0 and not h.needs_blocked))
    step.col = part.col
    ws = h.couple_ws
    step.sl_idx, step.wp, step.nav, step.follower, step.cent, step.nn, step.blocked, step.sig = ws
    couple_occlude_kernel(step.x, h.labels, part.col, sub_sl, sub_wp, sub_nav, *rows, step.slot, p.sigma, check,
                          *h.obstacles.planar_arrays, *ws)


def couple_workspace(n: int) -> tuple:
    """The arrays :func:`couple_occlude_kernel` writes for ``n`` agents: ``sl_idx``, ``wp``,
    ``nav``, ``follower``, ``cent``, ``nn``, ``blocked``, ``sig``."""
    return (np.empty(n, dtype=np.int64), np.empty((n, 2)), np.empty(n, dtype=np.bool_), np.empty(n, dtype=np.bool_),
            np.empty((n, 2)), np.empty(n, dtype=np.int64), np.empty((n, 4), dtype=np.bool_), np.empty((n, 4)))


@njit(cache=True)
def couple_occlude_kernel(x, labels, col, sub_sl, sub_wp, sub_nav, ptr, idx, slot, sigma, check, seg_a, seg_b,
                          poly_offsets, circ_c, circ_r, bbox_lo, bbox_hi, sl_idx, wp, nav, follower, cent, nn,
                          blocked, sig):
    """:func:`couple`, then (``check``) the segments of eq. (30) tested against the obstacles,
    written into the last eight arguments (``couple_workspace``): the couplings, ``blocked``
    (N, 4) and ``sig`` (N, 4); without ``check`` nothing is blocked."""
    couple_into(x, labels, col, sub_sl, sub_wp, sub_nav, ptr, idx, sl_idx, wp, nav, follower, cent, nn)
    n = x.shape[0]
    blocked[:] = False
    sig[:] = 1.0
    if check:
        P, Q = np.empty((4 * n, 2)), np.empty((4 * n, 2))
        occlusion_segments(x, slot, nn, sl_idx, cent, P, Q)
        flat = np.empty(4 * n, dtype=np.bool_)
        segments_blocked_kernel(seg_a, seg_b, poly_offsets, circ_c, circ_r, bbox_lo, bbox_hi, P, Q, flat)
        for c in range(4):
            for i in range(n):
                if flat[c * n + i]:
                    blocked[i, c] = True
                    sig[i, c] = sigma


def occlusion(h, step: Step) -> None:
    """Eq. (30): ``step.sig`` (N, 4), sigma_occ where the segment to the slot / nearest neighbour /
    subleader / centroid meets an obstacle, 1 otherwise; ``step.blocked`` the segments that meet
    one (computed also with sigma_occ = 1 when a part reads them)."""
    p = h.params
    x, n = step.x, h.n
    if h.no_obstacles or (p.sigma == 1.0 and not h.needs_blocked):
        step.blocked = np.zeros((n, 4), dtype=np.bool_)
        step.sig = np.ones((n, 4))
        return
    P, Q = np.empty((4 * n, 2)), np.empty((4 * n, 2))
    occlusion_segments(x, step.slot, step.nn, step.sl_idx, step.cent, P, Q)
    step.blocked = h.obstacles.blocked_into(P, Q, np.empty(4 * n, dtype=np.bool_)).reshape(4, n).T
    step.sig = np.where(step.blocked, p.sigma, 1.0)


@njit(cache=True)
def occlusion_segments(x, slot, nn, sl_idx, cent, P, Q):
    """The 4N segments of eq. (30) into ``P`` (starts) and ``Q`` (ends), (4N, 2) each: agent i to
    its slot (row i), nearest neighbour (itself if none; row N + i), subleader (2N + i) and
    centroid (3N + i)."""
    n = x.shape[0]
    for i in range(n):
        j = nn[i] if nn[i] >= 0 else i
        s = sl_idx[i]
        for c in range(2):
            P[i, c] = P[n + i, c] = P[2 * n + i, c] = P[3 * n + i, c] = x[i, c]
            Q[i, c] = slot[i, c]
            Q[n + i, c] = x[j, c]
            Q[2 * n + i, c] = x[s, c]
            Q[3 * n + i, c] = cent[i, c]


def control(h, step: Step) -> np.ndarray:
    """The commanded acceleration (N, 2) [m/s^2] of eq. (38)-(39) with the parts' hooks."""
    p = h.params
    x, v = step.x, step.v
    if step.n_own or h.obstacles.geom.dim != 2:
        couplings(h, step)
        occlusion(h, step)
    else:
        couple_occlude(h, step)
    step.dsafe = np.empty(h.n)
    step.dsafe.fill(p.paper.d_safe)
    step.exit_dir = np.zeros((h.n, 2))
    step.exit_free = np.zeros(h.n, dtype=np.bool_)
    for part in h.at["steer"]:
        part.steer(step)
    args = (x, v, h.labels, step.sl_idx, step.follower, step.cent, step.wp, step.nav, step.slot, step.speed,
            p.core.eps_v, step.nn, step.sig, step.ring, h.cos, h.sin, h.gains, step.dsafe, *step.rows)
    edit = [part for part in h.at["push_back"] if part.push_back(step)]
    if edit:
        t = eq38_terms(*args)
        for part in edit:
            part.edit_terms(step, t)
        a = t.sum(axis=0)
    else:
        a = eq38(*args)
    for part in h.at["brake"]:
        a = part.brake(step, a)
    a = F.saturate(a, p.a_bound)
    for part in h.at["guard"]:
        a = part.guard(step, a)
    return a


@njit(cache=True)
def eq38_terms(x, v, labels, sl_idx, follower, cent, wp, nav, slot, speed, eps_v, nn, sig, ring, cos_t, sin_t,
               g, dsafe, ptr, idx):
    """The eight terms of eq. (38) (``forces.force_terms``), the reference velocity of eq. (23)
    and the subleaders' rows gathered in the same call."""
    vslot = F.slot_velocity(x, slot, speed, eps_v)
    sl_pos, sl_vel = gather_rows(x, v, sl_idx)
    return F.force_terms(x, v, labels, sl_pos, sl_vel, follower, cent, wp, nav, slot, vslot, nn, sig, ring,
                         cos_t, sin_t, g, dsafe, ptr, idx)


@njit(cache=True)
def eq38(x, v, labels, sl_idx, follower, cent, wp, nav, slot, speed, eps_v, nn, sig, ring, cos_t, sin_t,
         g, dsafe, ptr, idx):
    """Eq. (38), the sum of :func:`eq38_terms` (as ``forces.synthesize``), (N, 2) [m/s^2]: the pair
    and LiDAR terms by their own passes, the six per-agent terms and the sum in one loop, every
    term computed and added in the stack's order (0 + att + sep + ... + obs, as the stack's sum)
    without the (8, N, 2) stack and its temporaries -- the same bits."""
    n = x.shape[0]
    sep = F.separation(x, labels, g[F.G_KSEP], g[F.G_RSEP], g[F.G_DFLOOR], False, ptr, idx)
    ir = F.separation(x, labels, g[F.G_KIR], g[F.G_DIR], g[F.G_DFLOOR], True, ptr, idx)
    obs = F.lidar_repulsion_each(ring, cos_t, sin_t, g[F.G_KREP], g[F.G_RT], g[F.G_KB], g[F.G_GAMMA], g[F.G_KE],
                                 dsafe, g[F.G_DFLOOR], g[F.G_KE_RATIO] > 0.5)
    j = np.where(nn >= 0, nn, np.arange(n))
    return eq38_sum(x, v, x[j], x[sl_idx], v[sl_idx], nn >= 0, follower, cent, wp, nav, slot, speed, eps_v, sig,
                    sep, ir, obs, g)


@njit(cache=True)
def eq38_sum(x, v, nn_pos, sl_pos, sl_vel, has_nn, follower, cent, wp, nav, slot, speed, eps_v, sig, sep, ir, obs, g):
    """Eq. (38)'s six per-agent terms and the sum, every term computed and added in the stack's
    order (0 + att + sep + ... + obs), given each agent's nearest group mate ``nn_pos``, subleader
    ``sl_pos`` / ``sl_vel`` (N, 2) as it knows them and the pair and LiDAR terms ``sep``, ``ir``,
    ``obs`` (N, 2): shared by the ideal path (:func:`eq38`) and the network's (``eq38_known``)."""
    n = x.shape[0]
    k_p, k_v, k_path, k_vl = g[F.G_KP], g[F.G_KV], g[F.G_KPATH], g[F.G_KVL]
    out = np.empty((n, 2))
    for i in range(n):
        ex = slot[i, 0] - x[i, 0]  # eq. (23)'s v*, as forces.slot_velocity
        ey = slot[i, 1] - x[i, 1]
        s = speed[i] / (math.sqrt(ex * ex + ey * ey) + eps_v)
        vs = (s * ex, s * ey)
        intra = _spring(x, i, nn_pos[i, 0], nn_pos[i, 1], g[F.G_KINTRA], g[F.G_DTHR], has_nn[i])
        fol = _spring(x, i, sl_pos[i, 0], sl_pos[i, 1], g[F.G_KL], g[F.G_D0], follower[i])
        coh = _spring(x, i, cent[i, 0], cent[i, 1], g[F.G_KCOH], g[F.G_DC], True)
        for c in range(2):
            att = (k_p * (slot[i, c] - x[i, c]) + k_v * (vs[c] - v[i, c])) * sig[i, F.SIG_SLOT]
            path = k_path * (wp[i, c] - x[i, c]) if nav[i] else 0.0
            vm = k_vl * (sl_vel[i, c] - v[i, c]) if follower[i] else 0.0
            acc = 0.0 + att
            acc += sep[i, c]
            acc += path
            acc += intra[c] * sig[i, F.SIG_NN]
            acc += ir[i, c] if nav[i] else 0.0
            acc += (fol[c] + vm) * sig[i, F.SIG_SL]
            acc += coh[c] * sig[i, F.SIG_CENT]
            acc += obs[i, c]
            out[i, c] = acc
    return out


@njit(cache=True, inline="always")
def _spring(x, i, qx, qy, k, d0, on):
    """Agent i's row of ``forces.spring`` toward ``(qx, qy)`` (zero unless ``on``)."""
    if not on:
        return 0.0, 0.0
    ex = qx - x[i, 0]
    ey = qy - x[i, 1]
    d = math.sqrt(ex * ex + ey * ey)
    if d > d0 and d > 0.0:
        s = k * (d - d0) / d
        return s * ex, s * ey
    return 0.0, 0.0
