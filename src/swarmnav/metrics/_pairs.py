"""Close pairs over a whole trajectory in one compiled pass, on the shared cell-list neighbour
lists of :mod:`swarmnav.sensing.cells` (never N x N); below ``PAIRS_ALL_BELOW`` agents in an open
world, every pair each step (:func:`all_pairs_run`, the same values)."""

from __future__ import annotations

import numpy as np
from numba import njit

from swarmnav.sensing.cells import neighbour_csr


@njit(cache=True)
def _neighbours(P, r, box, periodic, idx, d2):
    """:func:`neighbour_csr` within ``r`` (coincident agents included, rows hold self), into
    ``idx`` / ``d2``, grown to twice the need when they are too short; returns them with the CSR."""
    order, start, end, total = neighbour_csr(P, r, box, periodic, idx, d2, -1.0)
    if total > idx.shape[0]:
        idx = np.empty(2 * total, np.int64)
        d2 = np.empty(2 * total)
        order, start, end, total = neighbour_csr(P, r, box, periodic, idx, d2, -1.0)
    return order, start, end, idx, d2


@njit(cache=True)
def close_pairs_run(positions, box, contact):
    """(smallest distance between two agents over the run if some pair ever came within
    ``contact``, else inf; number of contact episodes: a pair closer than ``contact`` counts once
    per run of consecutive steps).

    Args:
        positions: (K + 1, N, 2) [m].
        box: periodic cell side [m] (minimum-image distances), or 0 for an open world.
        contact: contact distance [m].
    """
    K1, N, _ = positions.shape
    periodic = box > 0.0
    c2 = contact * contact
    idx = np.empty(8 * N, np.int64)
    d2 = np.empty(8 * N)
    keys = np.empty(8 * N, np.int64)
    prev = np.empty(0, np.int64)
    best2 = np.inf
    hits = 0
    for k in range(K1):
        P = positions[k] - box * np.floor(positions[k] / box) if periodic else positions[k]
        # coincident agents are neighbours: a contact at distance 0
        order, start, end, idx, d2 = _neighbours(P, contact, box, periodic, idx, d2)
        if keys.shape[0] < idx.shape[0]:
            keys = np.empty(idx.shape[0], np.int64)
        n = 0
        for i in range(N):
            for e in range(start[i], end[i]):
                j = idx[e]
                if j > i:  # each pair once, never the agent itself
                    best2 = min(best2, d2[e])
                    if d2[e] < c2:
                        keys[n] = i * N + j
                        n += 1
        cur = np.sort(keys[:n])
        p = 0
        for t in range(n):  # keys in cur but not in prev are new contact episodes
            while p < prev.shape[0] and prev[p] < cur[t]:
                p += 1
            if p >= prev.shape[0] or prev[p] != cur[t]:
                hits += 1
        prev = cur
    return np.sqrt(best2), hits


@njit(cache=True)
def min_pair_run(positions, box, r0):
    """Smallest distance between two agents over the run [m] (minimum image when ``box > 0``).
    Until a pair is found the cell-list radius starts at ``r0`` each step and doubles until some
    pair lies within it; after that each step needs one search within the best distance so far
    (a farther pair cannot lower it). Needs N >= 2."""
    K1, N, _ = positions.shape
    periodic = box > 0.0
    idx = np.empty(8 * N, np.int64)
    d2 = np.empty(8 * N)
    best2 = np.inf
    for k in range(K1):
        P = positions[k] - box * np.floor(positions[k] / box) if periodic else positions[k]
        r = r0 if best2 == np.inf else np.sqrt(best2)
        while True:
            order, start, end, idx, d2 = _neighbours(P, r, box, periodic, idx, d2)
            found = False
            for i in range(N):
                for e in range(start[i], end[i]):
                    if idx[e] > i:  # each pair once, never the agent itself
                        found = True
                        best2 = min(best2, d2[e])
            if found or best2 < np.inf:
                break
            r *= 2.0
    return np.sqrt(best2)


@njit(cache=True)
def all_pairs_run(positions, contact):
    """:func:`close_pairs_run` and :func:`min_pair_run` of an open world in one pass over every
    pair (a few agents: cheaper than a cell list per step): (smallest distance between two agents
    over the run [m], number of contact episodes). Each squared distance is computed as the cell
    list computes it, so the minimum is the same, bit for bit. Needs N >= 2."""
    K1, N, D = positions.shape
    c2 = contact * contact
    was = np.zeros((N, N), dtype=np.bool_)  # the pair was closer than contact at the last step
    best2 = np.inf
    hits = 0
    for k in range(K1):
        P = positions[k]
        for i in range(N):
            for j in range(i + 1, N):
                d2 = 0.0
                for c in range(D):
                    dc = P[j, c] - P[i, c]
                    d2 += dc * dc
                best2 = min(best2, d2)
                now = d2 < c2
                if now and not was[i, j]:
                    hits += 1
                was[i, j] = now
    return np.sqrt(best2), hits


#: agents: below this, an open world's pairs are all visited each step (a cell list does not pay)
PAIRS_ALL_BELOW = 64


def inter_agent(positions: np.ndarray, contact: float, box: float | None) -> tuple[float, int]:
    """Minimum inter-agent distance over the run [m] and the number of agent-agent contacts
    (a pair closer than ``contact`` counts once per continuous episode)."""
    if positions.shape[1] < 2:
        return float("inf"), 0
    P = np.ascontiguousarray(positions, dtype=np.float64)
    if not box and P.shape[1] < PAIRS_ALL_BELOW:
        best, hits = all_pairs_run(P, contact)
        return float(best), int(hits)
    best, hits = close_pairs_run(P, float(box or 0.0), contact)
    if not np.isfinite(best):  # no pair ever came within contact: the minimum needs a wider search
        best = min_pair_run(P, float(box or 0.0), contact)
    return float(best), int(hits)
