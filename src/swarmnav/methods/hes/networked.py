"""HES's control law (eq. 26-31, 38) on each agent's own picture of the others (docs/network.md).

Under the ideal network the control stage reads every agent's true position and velocity: the
centroid of a sub-swarm, an agent's nearest group mate, its subleader's state and the pairs of the
separation terms. On a network agent i knows agent j only as its last message carried it
(``Observation.known``: positions ``kx`` (N, N, 2) [m], velocities ``kv`` (N, N, 2) [m/s], row i
agent i's picture, column i its own true state, and ``heard`` (N, N) bool), and its sub-swarm only
as the plan it flies says: ``lab`` (N, N) int, row i the sub-swarm label agent i's plan gives each
agent, and ``sl_idx`` (N,) the subleader that plan gives agent i.

The kernels here compute agent i's couplings and terms from row i alone:

- its cohesion centroid (eq. 29) is the mean of its own position and its pictures of the heard
  agents its plan puts in its sub-swarm;
- its nearest neighbour (eq. 26) is the nearest of those by its pictures;
- its subleader's position and velocity (eq. 27) are its picture of the subleader; a follower that
  has never heard its subleader is not coupled to it;
- the separation terms (eq. 25, 31) are summed over its own *directed* pairs: agent i pushed away
  from its picture of each heard agent, whatever j's picture of i is.

Fed every agent's true state (``obs.known()`` under the ideal network) and one plan for all,
they give the ideal path's couplings and commands bit for bit: each sum runs over the partners in
ascending index, as the ideal kernels' (tests/methods/hes/test_networked.py). They are not yet
wired into :class:`~swarmnav.methods.hes.method.Hes`: the hierarchy's stages (re-election,
reports, the planner, the slot references and the parts of ours) still read the true states, so
HES flies the ideal network only.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from swarmnav.methods.hes import forces as F


@njit(cache=True)
def couple_known(x, v, kx, kv, heard, lab, sl_idx):
    """Each agent's couplings from its own picture: its cohesion centroid ``cent`` (N, 2) [m], its
    nearest group mate ``nn`` (N,) (-1: none heard) and that mate's pictured position ``nn_pos``
    (N, 2) (its own position if none), its subleader's pictured position ``sl_pos`` and velocity
    ``sl_vel`` (N, 2), and ``follower`` (N,) bool: its plan's subleader is another agent and it
    has heard that agent.

    Args:
        x, v: (N, 2) own positions [m] and velocities [m/s].
        kx, kv: (N, N, 2) agent i's picture of agent j (``Observation.known``).
        heard: (N, N) bool, agent i has received a message of agent j.
        lab: (N, N) int, the sub-swarm label of agent j in the plan agent i flies.
        sl_idx: (N,) int, agent i's subleader in that plan (i itself: not a follower).
    """
    n = x.shape[0]
    cent = np.empty((n, 2))
    nn = np.full(n, -1, dtype=np.int64)
    nn_pos = np.empty((n, 2))
    sl_pos = np.empty((n, 2))
    sl_vel = np.empty((n, 2))
    follower = np.zeros(n, dtype=np.bool_)
    for i in range(n):
        g = lab[i, i]
        sx = 0.0
        sy = 0.0
        cnt = 0.0
        best = np.inf
        for j in range(n):
            if lab[i, j] != g:
                continue
            if j == i:
                px, py = x[i, 0], x[i, 1]
            elif heard[i, j]:
                px, py = kx[i, j, 0], kx[i, j, 1]
            else:
                continue
            sx += px
            sy += py
            cnt += 1.0
            if j != i:
                dx = x[i, 0] - px
                dy = x[i, 1] - py
                d2 = dx * dx + dy * dy
                if d2 < best:
                    best = d2
                    nn[i] = j
        cent[i, 0] = sx / cnt
        cent[i, 1] = sy / cnt
        j = nn[i]
        if j >= 0:
            nn_pos[i, 0], nn_pos[i, 1] = kx[i, j, 0], kx[i, j, 1]
        else:
            nn_pos[i, 0], nn_pos[i, 1] = x[i, 0], x[i, 1]
        s = sl_idx[i]
        follower[i] = s != i and heard[i, s]
        if follower[i]:
            sl_pos[i, 0], sl_pos[i, 1] = kx[i, s, 0], kx[i, s, 1]
            sl_vel[i, 0], sl_vel[i, 1] = kv[i, s, 0], kv[i, s, 1]
        else:
            sl_pos[i, 0], sl_pos[i, 1] = x[i, 0], x[i, 1]
            sl_vel[i, 0], sl_vel[i, 1] = v[i, 0], v[i, 1]
    return cent, nn, nn_pos, sl_pos, sl_vel, follower


@njit(cache=True)
def separation_known(x, kx, heard, lab, k, radius, d_floor, same_group):
    """``forces.separation`` over each agent's directed pairs: agent i pushed by ``k (p_i - q_ij) /
    max(d, d_floor)^2`` from its picture ``q_ij`` of every heard agent j within ``radius`` [m] (of
    its own sub-swarm by its plan when ``same_group``: eq. 31; else every one: eq. 25), summed in
    ascending j. (N, 2) [m/s^2]."""
    n = x.shape[0]
    out = np.zeros((n, 2))
    r2 = radius * radius
    f2 = d_floor * d_floor
    for i in range(n):
        g = lab[i, i]
        for j in range(n):
            if j == i or not heard[i, j]:
                continue
            if same_group and lab[i, j] != g:
                continue
            dx = x[i, 0] - kx[i, j, 0]
            dy = x[i, 1] - kx[i, j, 1]
            d2 = dx * dx + dy * dy
            if d2 >= r2:
                continue
            s = k / max(d2, f2)
            out[i, 0] += s * dx
            out[i, 1] += s * dy
    return out


@njit(cache=True)
def occlusion_segments_known(x, slot, nn_pos, sl_pos, cent, P, Q):
    """``control.occlusion_segments`` from the pictured partners: the 4N segments of eq. (30) into
    ``P`` (starts) and ``Q`` (ends), (4N, 2) each: agent i to its slot (row i), its nearest group
    mate (N + i), its subleader (2N + i) and its centroid (3N + i)."""
    n = x.shape[0]
    for i in range(n):
        for c in range(2):
            P[i, c] = P[n + i, c] = P[2 * n + i, c] = P[3 * n + i, c] = x[i, c]
            Q[i, c] = slot[i, c]
            Q[n + i, c] = nn_pos[i, c]
            Q[2 * n + i, c] = sl_pos[i, c]
            Q[3 * n + i, c] = cent[i, c]


@njit(cache=True)
def eq38_known(x, v, kx, heard, lab, sl_pos, sl_vel, follower, cent, nn, nn_pos, wp, nav, slot, speed, eps_v, sig,
               ring, cos_t, sin_t, g, dsafe):
    """Eq. (38) (as ``control.eq38``) with every other agent read from the receiving agent's
    picture: the couplings of :func:`couple_known`, the separation terms of
    :func:`separation_known`, the agent's own slot, c_s, mode, ring and safety distance. (N, 2)
    [m/s^2], before saturation."""
    n = x.shape[0]
    sep = separation_known(x, kx, heard, lab, g[F.G_KSEP], g[F.G_RSEP], g[F.G_DFLOOR], False)
    ir = separation_known(x, kx, heard, lab, g[F.G_KIR], g[F.G_DIR], g[F.G_DFLOOR], True)
    obs = F.lidar_repulsion_each(ring, cos_t, sin_t, g[F.G_KREP], g[F.G_RT], g[F.G_KB], g[F.G_GAMMA], g[F.G_KE],
                                 dsafe, g[F.G_DFLOOR], g[F.G_KE_RATIO] > 0.5)
    k_p, k_v, k_path, k_vl = g[F.G_KP], g[F.G_KV], g[F.G_KPATH], g[F.G_KVL]
    out = np.empty((n, 2))
    for i in range(n):
        ex = slot[i, 0] - x[i, 0]  # eq. (23)'s v*
        ey = slot[i, 1] - x[i, 1]
        s = speed[i] / (math.sqrt(ex * ex + ey * ey) + eps_v)
        vs = (s * ex, s * ey)
        intra = _spring(x, i, nn_pos[i, 0], nn_pos[i, 1], g[F.G_KINTRA], g[F.G_DTHR], nn[i] >= 0)
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
