"""A plain dense transcription of the HWVEM paper's heading update, for oracle tests only.

Every matrix of Section 2.2 is built as an N x N array exactly as written: adjacency A (eq. 11),
dominance B (eq. 12), contribution C = w_abs * w_rel * w_nei (eq. 13-17), H = A * B * C (eq. 10),
and the genuine direction of eq. (18) with the avoidance state O. Layers (eq. 5) are floats with
``inf`` for an agent the layer information has not reached yet. Nothing here is fast; it is the
reading of the paper the sparse kernels must agree with.
"""

from __future__ import annotations

import math

import numpy as np

VEM, VEM_A, IVEM, IVEM_A, WVEM, HWVEM = "vem", "vem-a", "ivem", "ivem-a", "wvem", "hwvem"


def wrap(a):
    return (np.asarray(a) + np.pi) % (2 * np.pi) - np.pi


def offsets(pos, box):
    """x_i - x_j for every pair (minimum image in a periodic box) and the distances."""
    d = pos[:, None, :] - pos[None, :, :]
    if box is not None:
        d -= box * np.round(d / box)
    return d, np.hypot(d[..., 0], d[..., 1])


def adjacency(pos, r, box):
    """Eq. (11): a_ij = 1 iff 0 < |x_i - x_j| <= r."""
    _, dist = offsets(pos, box)
    return (dist > 0) & (dist <= r)


def next_layers(A, layers, iu):
    """Eq. (5): l_i(k) = min_j {l_j(k-1) + 1 | j in N_i(k-1)}; the information UAV is layer 1."""
    L = np.where(A, layers[None, :], np.inf).min(axis=1) + 1.0
    if iu is not None:
        L[iu] = 1.0
    return L


def hwvem_matrix(A, layers, iu, p1, p2, use_nei=True):
    """H = A * B * C of eq. (10)-(17) (float layers, inf = not reached)."""
    N = A.shape[0]
    B = np.ones((N, N))
    np.fill_diagonal(B, 0.0)
    B[iu, :] = 0.0  # eq. (12): the information UAV listens to nobody
    with np.errstate(divide="ignore", over="ignore"):
        w_abs = 1.0 / layers + p1  # eq. (14)
        w_rel = np.power(float(p2), -layers)  # eq. (15); p2^-inf = 0
    n_nb = A.sum(axis=1)
    same = (layers[:, None] == layers[None, :])  # l_n == l_j
    cnt = A.astype(float) @ same.astype(float)  # cnt[i, j] = |{n in N_i : l_n = l_j}|
    with np.errstate(divide="ignore", invalid="ignore"):
        d = np.where(cnt > 0, n_nb[:, None] / cnt, 0.0)  # eq. (16)
    w_nei = np.where(d > math.e, np.log(np.where(d > 0, d, 1.0)), 1.0) if use_nei else np.ones_like(d)  # eq. (17)
    C = w_abs[None, :] * w_rel[None, :] * w_nei
    return A * B * C


def weight_matrix(model, A, layers, iu, *, p1=0.1, p2=5.0, use_nei=True, k_alpha=30.0, k_beta=18.0,
                  k_gamma=1.0, info_weight=100.0):
    """Neighbour weights h_ij of the weighted-average models (IVEM-A: rows next to the IU only)."""
    N = A.shape[0]
    B = np.ones((N, N))
    np.fill_diagonal(B, 0.0)
    if iu is not None:
        B[iu, :] = 0.0
    if model in (VEM, VEM_A, IVEM):
        return A * B
    if model == WVEM:
        w = np.where(A[iu], k_beta, k_gamma)  # type of j: neighbour of the IU or not
        w[iu] = k_alpha
        return A * B * w[None, :]
    if model == IVEM_A:
        w = np.ones(N)
        w[iu] = info_weight
        return A * B * w[None, :]
    if model == HWVEM:
        return hwvem_matrix(A, layers, iu, p1, p2, use_nei)
    raise ValueError(model)


def genuine_heading(model, A, theta, theta_g, layers, avoiding, iu, theta_d, ivem_unsigned=False, ivem_self=False,
                    keys=None, **kw):
    """Eq. (18) without noise: the new genuine direction of every agent.

    Weighted models: atan2(sum h o sin, sum h o cos); all weights zero but contributing
    neighbours present (only unreached layers among them) -> plain average over them;
    no contributing neighbour -> keep theta_g. IVEM / IVEM-A away from the IU: eq. (30)-(31),
    the headings compared as numbers in [-pi, pi), or in [0, 2 pi) (``ivem_unsigned``), the
    agent's own heading among the neighbours' min and max if ``ivem_self``. With ``keys`` (the
    unwrapped numbers of ``ivem_range = raw``) eq. (30)-(31) compare those, and the function
    returns the new headings and the new numbers (eq. 30's sum, the arc tangent, theta_d).
    """
    N = len(theta)
    o = (~avoiding).astype(float)
    H = weight_matrix(model, A, layers, iu, **kw) * o[None, :]
    plain = (A * o[None, :]).astype(float)
    np.fill_diagonal(plain, 0.0)
    if iu is not None:
        plain[iu, :] = 0.0
    out = np.array(theta_g, dtype=float)
    # an agent that keeps theta_g turns its number with its heading
    new_keys = None if keys is None else np.asarray(keys, dtype=float) + wrap(np.asarray(theta_g) - theta)
    for i in range(N):
        if iu is not None and i == iu:
            out[i] = theta_d
            if keys is not None:
                new_keys[i] = theta_d
            continue
        ivem_row = model == IVEM or (model == IVEM_A and not A[i, iu])
        if ivem_row:
            nb = np.nonzero(plain[i] > 0)[0]
            if len(nb) == 0:
                continue
            if keys is not None:
                num = np.asarray(keys, dtype=float)
            else:
                num = np.mod(theta, 2 * np.pi) if ivem_unsigned else theta  # the headings as numbers
            group = np.append(nb, i) if ivem_self else nb
            lo, hi = num[group].min(), num[group].max()
            lam = 1.0 if num[i] <= lo else (-1.0 if num[i] >= hi else 0.0)
            out[i] = wrap(theta[i] + lam * (hi - lo) / 2.0)
            if keys is not None:
                new_keys[i] = num[i] + lam * (hi - lo) / 2.0
            continue
        h = H[i]
        if h.sum() <= 0.0:
            h = plain[i]
            if h.sum() <= 0.0:
                continue
        out[i] = math.atan2(np.sum(h * np.sin(theta)), np.sum(h * np.cos(theta)))
        if keys is not None:
            new_keys[i] = out[i]
    return out if keys is None else (out, new_keys)


def att_rep(pos, box, r_rep, r_att):
    """Eq. (23)-(24): attraction and repulsion sums over x_ij = x_i - x_j."""
    d, dist = offsets(pos, box)
    with np.errstate(divide="ignore", invalid="ignore"):
        unit = np.where(dist[..., None] > 0, d / dist[..., None], 0.0)
    rep_m = (dist > 0) & (dist <= r_rep)
    att_m = (dist > r_rep) & (dist <= r_att)
    rep = np.sum(np.where(rep_m, (r_rep - dist) / r_rep, 0.0)[..., None] * unit, axis=1)
    att = np.sum(np.where(att_m, (r_rep - dist) / (r_att - r_rep), 0.0)[..., None] * unit, axis=1)
    return att, rep


def deg_con(theta, ref):
    """Eq. (28) with the L1 norm: 1 - mean |wrap(theta_i - ref)| / pi."""
    return 1.0 - float(np.mean(np.abs(wrap(theta - ref)))) / np.pi
