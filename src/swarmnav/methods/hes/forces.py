"""Low-level controller of HES, Section 4: the eight force terms of eq. (38) as pure functions.

Every term is a numba function of flat arrays that returns an (N, 2) acceleration [m/s^2];
:func:`force_terms` evaluates all eight into an (8, N, 2) stack (in the order of eq. (38)) and
:func:`synthesize` sums them. No Python loop over agents runs per step: the per-agent and
per-ray work is compiled.

Order of the stack (``TERMS``)::

    0 att    slot attraction                       eq. (24), attenuated by sigma(p_i, p*_i)
    1 sep    global separation                     eq. (25)
    2 path   corridor centering                    eq. (32), navigate only
    3 intra  nearest-neighbour cohesion            eq. (26), attenuated by sigma(p_i, p_nn)
    4 ir     intra-sub-swarm short-range repulsion eq. (31), navigate only
    5 fol    follower-subleader coupling           eq. (27), attenuated by sigma(p_i, p_s)
    6 coh    centroid cohesion                     eq. (29), attenuated by sigma(p_i, pbar_s)
    7 obs    LiDAR obstacle repulsion              eqs. (35)-(37)

The four attraction-type terms (att, intra, fol, coh) are multiplied by the occlusion factor
of eq. (30); ``sig`` holds it per agent and target, columns ``SIG_SLOT, SIG_NN, SIG_SL,
SIG_CENT``.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from swarmnav.methods.hes.neighbours import all_rows

TERMS = ("att", "sep", "path", "intra", "ir", "fol", "coh", "obs")
SIG_SLOT, SIG_NN, SIG_SL, SIG_CENT = 0, 1, 2, 3

# Indices of the gain vector passed to the kernels (one float64 array keeps the signature short).
G_KP, G_KV, G_KSEP, G_RSEP, G_KPATH, G_KINTRA, G_DTHR, G_KIR, G_DIR, G_KL, G_KVL, G_D0, G_KCOH, G_DC, \
    G_KREP, G_RT, G_KB, G_GAMMA, G_KE, G_DSAFE, G_DFLOOR, G_KE_RATIO = range(22)
N_GAINS = 22


def gain_vector(p) -> np.ndarray:
    """The kernels' gain vector from a :class:`HesParams`."""
    g = np.empty(N_GAINS)
    g[G_KP], g[G_KV], g[G_KSEP], g[G_RSEP] = p.paper.k_p, p.paper.k_v, p.paper.k_sep, p.core.r_sep
    g[G_KPATH], g[G_KINTRA], g[G_DTHR], g[G_KIR], g[G_DIR] = p.paper.k_path, p.paper.k_intra, p.core.d_thr, p.paper.k_ir, p.core.d_ir
    g[G_KL], g[G_KVL], g[G_D0], g[G_KCOH], g[G_DC] = p.paper.k_l, p.paper.k_vl, p.core.d_0, p.paper.k_coh, p.core.d_c
    g[G_KREP], g[G_RT], g[G_KB], g[G_GAMMA], g[G_KE] = p.paper.k_rep, p.paper.r_trigger, p.paper.k_b, p.paper.gamma, p.paper.k_e
    g[G_DSAFE], g[G_DFLOOR] = p.paper.d_safe, p.core.d_floor
    g[G_KE_RATIO] = 1.0 if p.core.ke_ratio else 0.0
    return g


# --------------------------------------------------------------------------- reference, eq. (23)

@njit(cache=True)
def slot_velocity(x, slot, speed, eps_v):
    """Reference velocity of eq. (23): ``v*_i = v_s (p*_i - p_i) / (||p*_i - p_i|| + eps_v)``.

    Args:
        x: (N, 2) positions [m]; slot: (N, 2) reference positions p*_i [m];
        speed: (N,) cruise speed v_s of each agent's sub-swarm [m/s]; eps_v [m].
    """
    n = x.shape[0]
    out = np.empty((n, 2))
    for i in range(n):
        ex = slot[i, 0] - x[i, 0]
        ey = slot[i, 1] - x[i, 1]
        s = speed[i] / (math.sqrt(ex * ex + ey * ey) + eps_v)
        out[i, 0] = s * ex
        out[i, 1] = s * ey
    return out


@njit(cache=True)
def group_centroids(x, col, n_groups):
    """Eq. (2) for all sub-swarms at once: (S, 2) mean position of the agents with ``col == s``."""
    out = np.zeros((n_groups, 2))
    cnt = np.zeros(n_groups)
    for i in range(x.shape[0]):
        out[col[i], 0] += x[i, 0]
        out[col[i], 1] += x[i, 1]
        cnt[col[i]] += 1.0
    for s in range(n_groups):
        if cnt[s] > 0:
            out[s, 0] /= cnt[s]
            out[s, 1] /= cnt[s]
    return out


# --------------------------------------------------------------------------- the eight terms

@njit(cache=True)
def attraction(x, v, slot, vslot, k_p, k_v):
    """Eq. (24): ``f_att = k_p (p* - p) + k_v (v* - v)``."""
    return k_p * (slot - x) + k_v * (vslot - v)


@njit(cache=True)
def separation(x, group, k, radius, d_floor, same_group, ptr=None, idx=None):
    """Inverse-distance repulsion ``sum_j k (p_i - p_j) / d_ij^2`` over ``d_ij < radius``.

    ``same_group=False``: all neighbours, eq. (25) (global separation, k_sep, r_sep);
    ``same_group=True``: members of i's own sub-swarm only, eq. (31) (k_ir, d_ir).
    Pairs from the neighbour rows ``ptr, idx`` (:func:`neighbour_rows`, which must cover
    ``radius``), or all pairs if not given; each pair once, partners in ascending index.
    """
    n = x.shape[0]
    if ptr is None or idx is None:
        ptr, idx = all_rows(n)
    out = np.zeros((n, 2))
    r2 = radius * radius
    f2 = d_floor * d_floor
    for i in range(n):
        for t in range(ptr[i], ptr[i + 1]):
            j = idx[t]
            if j <= i:
                continue
            if same_group and group[i] != group[j]:
                continue
            dx = x[i, 0] - x[j, 0]
            dy = x[i, 1] - x[j, 1]
            d2 = dx * dx + dy * dy
            if d2 >= r2:
                continue
            s = k / max(d2, f2)
            out[i, 0] += s * dx
            out[i, 1] += s * dy
            out[j, 0] -= s * dx
            out[j, 1] -= s * dy
    return out


@njit(cache=True)
def centering(x, target, k):
    """Eq. (32): ``f_path = k_path (c_s - p_i)`` with ``target[i] = c_s`` of i's sub-swarm."""
    return k * (target - x)


@njit(cache=True)
def spring(x, target, k, d0, mask):
    """Dead-band spring toward a target point: ``k max(0, ||q_i - p_i|| - d0) e_i``,
    ``e_i = (q_i - p_i) / ||q_i - p_i||``; zero where ``mask`` is False.

    The attraction part of eq. (26) (q = nearest neighbour, d0 = d_thr), eq. (27)
    (q = subleader, d0 = d_0) and eq. (29) (q = centroid, d0 = d_c).
    """
    n = x.shape[0]
    out = np.zeros((n, 2))
    for i in range(n):
        if not mask[i]:
            continue
        ex = target[i, 0] - x[i, 0]
        ey = target[i, 1] - x[i, 1]
        d = math.sqrt(ex * ex + ey * ey)
        if d > d0 and d > 0.0:
            s = k * (d - d0) / d
            out[i, 0] = s * ex
            out[i, 1] = s * ey
    return out


@njit(cache=True)
def velocity_match(v, v_target, k, mask):
    """Velocity part of eq. (27): ``k_vl (v_s - v_i)`` (v_s: the subleader's velocity)."""
    n = v.shape[0]
    out = np.zeros((n, 2))
    for i in range(n):
        if mask[i]:
            out[i, 0] = k * (v_target[i, 0] - v[i, 0])
            out[i, 1] = k * (v_target[i, 1] - v[i, 1])
    return out


@njit(cache=True)
def _nearest_mate(x, group, i, cand):
    """The member of i's group among ``cand`` (ascending) nearest to i; the first of equally near
    ones; -1 if none."""
    best = np.inf
    out = -1
    for j in cand:
        if j == i or group[i] != group[j]:
            continue
        dx = x[i, 0] - x[j, 0]
        dy = x[i, 1] - x[j, 1]
        d2 = dx * dx + dy * dy
        if d2 < best:
            best = d2
            out = j
    return out


@njit(cache=True)
def nearest_in_group(x, group, ptr=None, idx=None):
    """Index of each agent's nearest neighbour within its own sub-swarm (-1 if alone); the lowest
    index among equally near ones. Searched in the neighbour rows ``ptr, idx`` first (all agents
    if not given), then over all agents for those with no group mate in their row."""
    n = x.shape[0]
    if ptr is None or idx is None:
        ptr, idx = all_rows(n)
    out = np.full(n, -1, dtype=np.int64)
    for i in range(n):
        out[i] = _nearest_mate(x, group, i, idx[ptr[i]:ptr[i + 1]])
        if out[i] < 0 and ptr[i + 1] - ptr[i] < n:  # nobody of its group nearby: all agents
            out[i] = _nearest_mate(x, group, i, np.arange(n))
    return out


@njit(cache=True)
def is_local_min(ring, r):
    """Eq. (35) local-minimum test ``d_r < d_{r-1} and d_r < d_{r+1}`` with circular indexing.

    A flat run of equal ranges (two rays straddling a wall's foot point symmetrically) counts as
    one minimum, at its first ray, if the ring rises on both ends; the paper's strict test would
    drop such a minimum and with it the whole wall's repulsion for that step.
    """
    n = ring.shape[0]
    d = ring[r]
    if not d < ring[r - 1 if r > 0 else n - 1]:  # circular neighbours without a modulo (hot loop)
        return False
    j = r + 1 if r + 1 < n else 0
    steps = 0
    while ring[j] == d and steps < n:
        j = j + 1 if j + 1 < n else 0
        steps += 1
    return ring[j] > d


@njit(cache=True)
def minimum_candidates(ring, below, out):
    """``out[r]`` (R,) bool: ray r may be a local minimum of :func:`is_local_min` closer than
    ``below`` -- ``d_r < below``, ``d_r < d_{r-1}`` and ``d_r <= d_{r+1}``, which every such
    minimum meets (the two end rays are always candidates). A branch-free pass over the ring on
    0-based slices (so that it vectorises), so that the exact test runs on the few candidates only."""
    n = ring.shape[0]
    if n > 2:
        lo, mid, hi, o = ring[0:n - 2], ring[1:n - 1], ring[2:n], out[1:n - 1]
        for j in range(n - 2):
            d = mid[j]
            o[j] = (d < below) & (d < lo[j]) & (d <= hi[j])
    out[0] = True
    out[n - 1] = True


@njit(cache=True)
def candidate_rays(ring, below, mask, idx):
    """The rays of :func:`minimum_candidates`, ascending, written to ``idx`` (R,) int; returns
    their count. ``mask``: a uint8 workspace of at least R rounded up to a multiple of 8, read as
    64-bit words, so that the scan skips eight rays without a candidate at once."""
    n = ring.shape[0]
    nw = (n + 7) // 8
    mask[n:nw * 8] = 0
    minimum_candidates(ring, below, mask[:n].view(np.bool_))
    words = mask[:nw * 8].view(np.uint64)
    m = 0
    for w in range(nw):
        if words[w] == 0:
            continue
        for r in range(8 * w, min(8 * w + 8, n)):
            if mask[r]:
                idx[m] = r
                m += 1
    return m


@njit(cache=True)
def repulsion_magnitude(d, k_rep, r_t, k_b, gamma, k_e, d_safe, ratio=False):
    """Eq. (36): per-ray repulsive magnitude omega [m/s^2] at range d [m] (d already floored).

    ``k_rep max(0, 1/d - 1/R_t) / d^2 * (1 + k_b (max(0, R_t - d) / R_t)^gamma)
    + 1{d < d_safe} k_e (d_safe - d + 1)^2``; with ``ratio`` (``core.ke_ratio``) the last term
    is the other reading of the garbled text, ``k_e (d_safe / d + 1)^2``.
    """
    w = k_rep * max(0.0, 1.0 / d - 1.0 / r_t) / (d * d) * (1.0 + k_b * (max(0.0, r_t - d) / r_t) ** gamma)
    if d < d_safe:
        w += k_e * (d_safe / d + 1.0) ** 2 if ratio else k_e * (d_safe - d + 1.0) ** 2
    return w


@njit(cache=True)
def lidar_repulsion_each(ring, cos_t, sin_t, k_rep, r_t, k_b, gamma, k_e, d_safe, d_floor, ratio=False):
    """Eq. (37): ``f_obs,i = sum_{r in L_i} omega_{i,r} e_away,r``, ``e_away = -(cos, sin) theta_r``,
    over the active local-minimum set L_i of eq. (35) (local minima of the ring closer than R_t).

    Args:
        ring: (N, R) fused LiDAR ranges [m] (eq. 9).
        d_safe: (N,) safety distance of eq. (36) per agent [m]: d_safe everywhere, except for the
            members of a sub-swarm in passage mode inside their throat's tube (ours, see
            ``passage.passage_dsafe``).
        ratio: the near-obstacle term as ``k_e (d_safe / d + 1)^2`` (``repulsion_magnitude``).
    """
    n, nr = ring.shape
    out = np.zeros((n, 2))
    mask = np.empty(8 * ((nr + 7) // 8), dtype=np.uint8)
    cand = np.empty(nr, dtype=np.int64)
    for i in range(n):
        row = ring[i]
        for c in range(candidate_rays(row, r_t, mask, cand)):
            r = cand[c]
            d = row[r]
            if d >= r_t or not is_local_min(row, r):
                continue
            w = repulsion_magnitude(max(d, d_floor), k_rep, r_t, k_b, gamma, k_e, d_safe[i], ratio)
            out[i, 0] -= w * cos_t[r]
            out[i, 1] -= w * sin_t[r]
    return out


@njit(cache=True)
def lidar_repulsion(ring, cos_t, sin_t, k_rep, r_t, k_b, gamma, k_e, d_safe, d_floor):
    """Eq. (37) with one scalar d_safe [m] for every agent (the paper's law)."""
    return lidar_repulsion_each(ring, cos_t, sin_t, k_rep, r_t, k_b, gamma, k_e,
                                np.full(ring.shape[0], d_safe), d_floor)


# --------------------------------------------------------------------------- synthesis, eq. (38)

@njit(cache=True)
def force_terms(x, v, group, sl_pos, sl_vel, follower, cent, waypoint, nav, slot, vslot, nn, sig,
                ring, cos_t, sin_t, g, dsafe, ptr=None, idx=None):
    """All eight terms of eq. (38), an (8, N, 2) stack in the order of ``TERMS``.

    Args:
        x, v: (N, 2) positions [m] and velocities [m/s].
        group: (N,) sub-swarm index of each agent (any ints; equal = same sub-swarm).
        sl_pos, sl_vel: (N, 2) position and velocity of each agent's subleader.
        follower: (N,) bool, False for subleaders (the leader included): no coupling term.
        cent: (N, 2) centroid of each agent's sub-swarm; waypoint: (N, 2) its c_s.
        nav: (N,) bool, the agent's sub-swarm is in navigate mode (path, ir active).
        slot, vslot: (N, 2) reference position and velocity, eq. (23).
        nn: (N,) nearest same-sub-swarm neighbour (-1: none).
        sig: (N, 4) occlusion factors of eq. (30) for slot, nn, subleader, centroid.
        ring: (N, R) LiDAR ranges; cos_t, sin_t: (R,) ray directions; g: gain vector.
        dsafe: (N,) safety distance of eq. (36) per agent [m] (``g[G_DSAFE]`` outside passage mode).
        ptr, idx: neighbour rows covering max(r_sep, d_ir) (:func:`neighbour_rows`); all pairs if not given.
    """
    n = x.shape[0]
    if ptr is None or idx is None:
        ptr, idx = all_rows(n)
    out = np.zeros((8, n, 2))
    out[0] = attraction(x, v, slot, vslot, g[G_KP], g[G_KV])
    out[1] = separation(x, group, g[G_KSEP], g[G_RSEP], g[G_DFLOOR], False, ptr, idx)
    out[2] = centering(x, waypoint, g[G_KPATH])
    has_nn = nn >= 0
    q = np.empty((n, 2))
    for i in range(n):
        j = nn[i] if nn[i] >= 0 else i
        q[i, 0] = x[j, 0]
        q[i, 1] = x[j, 1]
    out[3] = spring(x, q, g[G_KINTRA], g[G_DTHR], has_nn)
    out[4] = separation(x, group, g[G_KIR], g[G_DIR], g[G_DFLOOR], True, ptr, idx)
    out[5] = spring(x, sl_pos, g[G_KL], g[G_D0], follower) + velocity_match(v, sl_vel, g[G_KVL], follower)
    all_true = np.ones(n, dtype=np.bool_)
    out[6] = spring(x, cent, g[G_KCOH], g[G_DC], all_true)
    out[7] = lidar_repulsion_each(ring, cos_t, sin_t, g[G_KREP], g[G_RT], g[G_KB], g[G_GAMMA], g[G_KE],
                                  dsafe, g[G_DFLOOR], g[G_KE_RATIO] > 0.5)
    for i in range(n):
        for c in range(2):
            out[0, i, c] *= sig[i, SIG_SLOT]
            out[3, i, c] *= sig[i, SIG_NN]
            out[5, i, c] *= sig[i, SIG_SL]
            out[6, i, c] *= sig[i, SIG_CENT]
            if not nav[i]:  # eq. (38): path and intra-repulsion only in navigate mode
                out[2, i, c] = 0.0
                out[4, i, c] = 0.0
    return out


@njit(cache=True)
def synthesize(x, v, group, sl_pos, sl_vel, follower, cent, waypoint, nav, slot, vslot, nn, sig,
               ring, cos_t, sin_t, g, dsafe, ptr=None, idx=None):
    """Eq. (38): ``a_cmd = sum of the eight terms`` (before saturation), (N, 2)."""
    t = force_terms(x, v, group, sl_pos, sl_vel, follower, cent, waypoint, nav, slot, vslot, nn, sig,
                    ring, cos_t, sin_t, g, dsafe, ptr, idx)
    return t.sum(axis=0)


@njit(cache=True)
def saturate(a, a_max):
    """Eq. (39): scale each row down to norm ``a_max`` [m/s^2] if it is longer."""
    n = a.shape[0]
    out = a.copy()
    for i in range(n):
        s = math.sqrt(a[i, 0] * a[i, 0] + a[i, 1] * a[i, 1])
        if s > a_max:
            out[i, 0] *= a_max / s
            out[i, 1] *= a_max / s
    return out
