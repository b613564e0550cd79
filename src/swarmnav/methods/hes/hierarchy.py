"""The hierarchy of HES, Section 2.2: partition, centroids, report packets, split / merge
execution and dynamic follower reassignment (eq. 41). Pure functions of arrays.

A partition is held as ``labels`` (N,) int sub-swarm ids plus ``subleaders`` {id: agent};
every agent has exactly one label (eq. 1 holds by construction) and every subleader carries
its own sub-swarm's label (:func:`check_partition` asserts both).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from swarmnav.methods.hes.corridors import Corridor


def check_partition(labels: np.ndarray, subleaders: dict[int, int], n: int) -> None:
    """Raise AssertionError unless ``labels`` is a partition of ``{0..n-1}`` (eq. 1) whose blocks
    are exactly the keys of ``subleaders`` and every subleader is a member of its own block."""
    assert labels.shape == (n,), "every agent needs exactly one sub-swarm label"
    ids = set(np.unique(labels).tolist())
    assert ids == set(subleaders), f"sub-swarm ids {sorted(ids)} != subleader keys {sorted(subleaders)}"
    for s, a in subleaders.items():
        assert labels[a] == s, f"subleader {a} of sub-swarm {s} carries label {labels[a]}"


def centroids(x: np.ndarray, labels: np.ndarray, ids: list[int]) -> np.ndarray:
    """Eq. (2): ``pbar_s = mean of p_i over S_s`` for each id in ``ids``, (S, 2) [m]."""
    return np.array([x[labels == s].mean(axis=0) for s in ids]).reshape(-1, 2)


@dataclass(slots=True)  # not frozen: built for every sub-swarm every step (a frozen init costs twice as much)
class Pack:
    """The subleader report packet P_s(k) of eq. (3): ``{(j, p_j, v_j) | j in S_s(k)}``."""

    sid: int
    subleader: int
    members: np.ndarray  # (m,) agent indices j
    positions: np.ndarray  # (m, 2) p_j [m]
    velocities: np.ndarray  # (m, 2) v_j [m/s]
    centroid: np.ndarray  # (2,) pbar_s of eq. (2), computed by the subleader from the rows above
    sl_row: np.ndarray | None = None  # (2,) p_s, the subleader's row of ``positions`` (found if None)

    @property
    def subleader_position(self) -> np.ndarray:
        if self.sl_row is not None:
            return self.sl_row
        m = self.members
        i = int(np.searchsorted(m, self.subleader))  # members are ascending (make_pack's callers)
        if i >= len(m) or m[i] != self.subleader:
            i = int(np.flatnonzero(m == self.subleader)[0])
        return self.positions[i]


@dataclass(slots=True)  # not frozen, as Pack
class Report:
    """What a subleader sends the leader each step: its Pack and what its LiDAR ring shows.

    Attributes:
        pack: P_s(k).
        corridors: candidate corridors toward the goal from the subleader's ring, best first.
        clearance: nearest LiDAR return over the members' rings [m] (R_L if none).
    """

    pack: Pack
    corridors: tuple[Corridor, ...]
    clearance: float


def make_pack(sid: int, subleader: int, members: np.ndarray, x: np.ndarray, v: np.ndarray) -> Pack:
    """P_s(k) of sub-swarm ``sid``: its members' rows of ``x`` and ``v`` and their centroid."""
    pos, vel, cen, sl_row = _pack_rows(x, v, members, subleader)
    return Pack(sid, subleader, members, pos, vel, cen, sl_row)


@njit(cache=True)
def gather_rows(x, v, idx):
    """``x[idx]``, ``v[idx]`` of planar (N, 2) arrays, in one pass."""
    m = idx.shape[0]
    xs = np.empty((m, 2))
    vs = np.empty((m, 2))
    for k in range(m):
        j = idx[k]
        xs[k, 0], xs[k, 1] = x[j, 0], x[j, 1]
        vs[k, 0], vs[k, 1] = v[j, 0], v[j, 1]
    return xs, vs


@njit(cache=True)
def _pack_rows(x, v, members, subleader):
    """``x[members]``, ``v[members]``, their centroid (summed in row order and divided by the count,
    as ``pos.sum(axis=0) / len(pos)``: the same bits) and ``x[subleader]``, in one pass."""
    m = members.shape[0]
    pos, vel = gather_rows(x, v, members)
    cen = np.zeros(2)
    if m > 0:
        cen[0], cen[1] = pos[0, 0], pos[0, 1]
    for k in range(1, m):
        cen[0] += pos[k, 0]
        cen[1] += pos[k, 1]
    cen /= m
    sl_row = np.empty(2)
    sl_row[0], sl_row[1] = x[subleader, 0], x[subleader, 1]
    return pos, vel, cen, sl_row


# --------------------------------------------------------------------------- split and merge

def split_members(x: np.ndarray, members: np.ndarray, targets: list[np.ndarray], weights: list[float],
                  heading: np.ndarray, min_size: int) -> list[np.ndarray]:
    """Assign the members of one sub-swarm to the corridors of a split.

    Corridors and agents are both ordered by their lateral coordinate across ``heading`` (the
    bearing to the goal): agents on the left take the leftmost corridor, so no two groups
    cross. Group sizes are proportional to ``weights`` (the corridors' usable widths), at
    least ``min_size`` each (largest-remainder rounding).

    Returns:
        One member array per target, in the order of ``targets``.
    """
    m = len(members)
    k = len(targets)
    left = np.array([-heading[1], heading[0]])
    order_c = np.argsort([float(np.dot(t, left)) for t in targets])  # right to left
    w = np.asarray(weights, dtype=float)[order_c]
    share = w / w.sum() * m
    sizes = np.maximum(np.floor(share).astype(int), min_size)
    while sizes.sum() > m:  # min_size may overshoot: take back from the biggest groups
        sizes[np.argmax(sizes)] -= 1
    rem = share - np.floor(share)
    while sizes.sum() < m:
        j = int(np.argmax(rem))
        sizes[j] += 1
        rem[j] = -1.0
    order_a = members[np.argsort(x[members] @ left, kind="stable")]  # right to left
    out: list[np.ndarray] = [np.zeros(0, dtype=np.int64)] * k
    start = 0
    for j, c in enumerate(order_c):
        out[c] = np.sort(order_a[start:start + sizes[j]])
        start += sizes[j]
    return out


def choose_subleader(x: np.ndarray, members: np.ndarray, leader: int) -> int:
    """The leader if it is a member, else the member nearest the group's centroid."""
    if leader in members:
        return int(leader)
    c = x[members].mean(axis=0)
    return int(members[np.argmin(np.sum((x[members] - c) ** 2, axis=1))])


def merge_pair(cents: np.ndarray, ids: list[int], near: np.ndarray, d_merge: float) -> tuple[int, int]:
    """The pair of sub-swarms a merge joins: the closest pair closer than ``d_merge`` if any,
    else the closest pair among the near-goal sub-swarms (``near`` (S,) bool)."""
    S = len(ids)
    best, pair = np.inf, None
    best_near, pair_near = np.inf, None
    for a in range(S):
        for b in range(a + 1, S):
            d = float(np.hypot(*(cents[a] - cents[b])))
            if d < best:
                best, pair = d, (ids[a], ids[b])
            if near[a] and near[b] and d < best_near:
                best_near, pair_near = d, (ids[a], ids[b])
    if best < d_merge or pair_near is None:
        return pair
    return pair_near


# --------------------------------------------------------------------------- reassignment, eq. (41)

def reassign(x: np.ndarray, labels: np.ndarray, ids: list[int], sl_pos: np.ndarray, waypoints: np.ndarray,
             protected: np.ndarray, last_move: np.ndarray, k: int, cooldown_steps: int, w: float, w_c: float,
             delta_min: float, n_move_max: int) -> tuple[np.ndarray, np.ndarray]:
    """Dynamic follower reassignment, eq. (41).

    Cost of follower i in sub-swarm s: ``phi_s(i) = w ||p_i - p_s|| + w_c ||p_i - c_s||``.
    Follower i moves to ``s* = argmin phi`` if ``phi_cur - phi_s* >= Delta_min``, it is not
    protected (subleaders, the leader) and its last move is at least ``tau_ra`` ago; at most
    ``N_move^max`` moves per update, largest improvements first.

    Args:
        ids: sub-swarm ids, rows of ``sl_pos`` (S, 2) and ``waypoints`` (S, 2).
        protected: (N,) bool; last_move: (N,) step of each agent's last transfer (large
            negative if never).

    Returns:
        ``(new_labels, moved)``: a new label array and the indices of the moved followers.
    """
    if len(ids) < 2 or n_move_max <= 0:
        return labels, np.zeros(0, dtype=np.int64)
    col = np.searchsorted(np.asarray(ids), labels)
    best, gain = _best_moves(x, col, np.ascontiguousarray(sl_pos, dtype=np.float64),
                             np.ascontiguousarray(waypoints, dtype=np.float64), w, w_c)
    ok = (gain >= delta_min) & ~protected & (k - last_move >= cooldown_steps)
    cand = np.flatnonzero(ok)
    if len(cand) == 0:
        return labels, cand
    cand = cand[np.argsort(-gain[cand], kind="stable")][:n_move_max]
    out = labels.copy()
    out[cand] = np.asarray(ids)[best[cand]]
    return out, np.sort(cand)


@njit(cache=True)
def _best_moves(x, col, sl_pos, waypoints, w, w_c):
    """For each agent, the cheapest sub-swarm ``best`` (N,) under eq. (41)'s cost and the gain
    ``phi_cur - phi_best`` (N,) of moving there (``col``: its current column), with the same
    operations as the (N, S) numpy form: ``w |p - p_s| + w_c |p - c_s|``, first minimum."""
    n, S = x.shape[0], sl_pos.shape[0]
    best = np.empty(n, dtype=np.int64)
    gain = np.empty(n)
    for i in range(n):
        cur = 0.0
        b, pb = 0, np.inf
        for s in range(S):
            dx, dy = x[i, 0] - sl_pos[s, 0], x[i, 1] - sl_pos[s, 1]
            ex, ey = x[i, 0] - waypoints[s, 0], x[i, 1] - waypoints[s, 1]
            phi = w * math.sqrt(dx * dx + dy * dy) + w_c * math.sqrt(ex * ex + ey * ey)
            if s == col[i]:
                cur = phi
            if phi < pb or s == 0:
                b, pb = s, phi
        best[i] = b
        gain[i] = cur - pb
    return best, gain
