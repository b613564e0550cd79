"""What the stages of one HES step pass each other, and the planner's memory of a sub-swarm.

:class:`Step` is the step context: created by perception with the step's positions,
velocities and LiDAR rings, filled stage by stage (reports and z(k), per-agent routing, slot
references, the control stage's couplings and safety distances) and read by the parts of ours
at their hooks. Nothing of one step is kept in hidden fields of the method: what outlives a step
is the planner's memory (:class:`SubSwarm`, the partition) or a part's own state.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numba import njit

from swarmnav.methods.hes.corridors import Corridor
from swarmnav.methods.hes.decision import NAVIGATE, DecisionState

NEVER = -(10**9)  # step of something that has not happened


@dataclass(slots=True)
class SubSwarm:
    """Planner memory of one sub-swarm (Sections 2-4): subleader, c_s(k), task mode, route, formation.

    The parts of ours keep their per-sub-swarm state themselves, keyed by ``sid``."""

    sid: int
    subleader: int
    waypoint: np.ndarray  # c_s(k) [m]
    mode: int = NAVIGATE
    route: Corridor | None = None  # corridor currently followed
    squeeze: float = 1.0  # lateral factor of the template in a narrow corridor (longitudinal: 1 / squeeze)
    heading: np.ndarray = field(default_factory=lambda: np.array([1.0, 0.0]))  # formation axis (unit)
    slot_members: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))  # agents (sorted) ...
    slot_index: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))  # ... and their r_i
    slot_step: int = NEVER  # step of the last slot assignment
    ring_offsets: np.ndarray | None = None  # encircle slots relative to the goal


@dataclass(frozen=True, slots=True)
class Partition:
    """The sub-swarms of a step as arrays: ``ids`` (sorted sub-swarm ids), ``col`` (N,) the column
    of each agent's sub-swarm in ``ids``, ``members`` the agents of each column (ascending),
    ``index`` {sid: column}. Built by :func:`partition` and reused while the labels stand."""

    ids: tuple
    col: np.ndarray
    members: tuple
    index: dict


def partition(labels: np.ndarray, sids) -> Partition:
    """The :class:`Partition` of ``labels`` over the sub-swarm ids ``sids``."""
    ids = tuple(sorted(sids))
    col = np.searchsorted(np.asarray(ids), labels)
    members = tuple(np.flatnonzero(col == j) for j in range(len(ids)))
    return Partition(ids, col, members, {s: j for j, s in enumerate(ids)})


@dataclass(slots=True)
class Step:
    """The context of one step, (N, ...) arrays over the agents unless noted.

    Perception: ``k``, ``x``, ``v`` (positions [m], velocities [m/s]), ``ring`` (N, R) fused
    LiDAR ranges [m] (eq. 8-9), ``ring_min`` (N,) each ring's nearest return [m]. Report and decision: ``reports`` {sid: Report}, ``z`` (eq. 18).
    Targets: ``own`` (N,) int, >= 0 for an agent a part routes on its own (passage mode's
    queues: the index of its throat; ``n_own`` how many), with ``own_target`` (N, 2) its point [m] and ``routed``
    (N,) bool the agents a part routes (trail following leaves them alone); ``slot`` (N, 2) p*_i
    and ``speed`` (N,) v_s of eq. (23). Control (eq. 38): ``rows`` the agents' neighbour rows
    within the pair terms' reach (``neighbours.neighbour_rows``), ``col`` column of each agent's
    sub-swarm, ``sl_idx`` its subleader, ``wp`` (N, 2) its centering target c_s, ``cent`` its
    cohesion centroid, ``nn`` nearest neighbour, ``follower``, ``nav``, ``sig`` (N, 4) occlusion
    factors of eq. (30) with ``blocked`` (N, 4) the segments that meet an obstacle, ``dsafe``
    (N,) the safety distance of eq. (36) [m], and ``exit_dir`` (N, 2) / ``exit_free`` (N,): a
    member's way out of a narrow place, along which the LiDAR repulsion does not push it back
    (0 / False: none). The arrays of a step are valid for that step: the couplings (``sl_idx``
    to ``sig``) are written into the run's workspace, which the next step rewrites.
    """

    k: int
    x: np.ndarray
    v: np.ndarray
    ring: np.ndarray
    ring_min: np.ndarray | None = None  # computed from ``ring`` when not given
    reports: dict = field(default_factory=dict)
    z: DecisionState | None = None
    own: np.ndarray | None = None
    own_target: np.ndarray | None = None
    routed: np.ndarray | None = None
    n_own: int = 0  # agents with own >= 0 (set with ``own`` by the part that routes them)
    slot: np.ndarray | None = None
    speed: np.ndarray | None = None
    rows: tuple | None = None
    col: np.ndarray | None = None
    sl_idx: np.ndarray | None = None
    wp: np.ndarray | None = None
    cent: np.ndarray | None = None
    nn: np.ndarray | None = None
    follower: np.ndarray | None = None
    nav: np.ndarray | None = None
    sig: np.ndarray | None = None
    blocked: np.ndarray | None = None
    dsafe: np.ndarray | None = None
    exit_dir: np.ndarray | None = None
    exit_free: np.ndarray | None = None

    def __post_init__(self):
        if self.ring_min is None:
            self.ring_min = row_min(self.ring)

    @property
    def n(self) -> int:
        return len(self.x)


@njit(cache=True)
def row_min(a):
    """``a.min(axis=1)`` of a 2-D array (NaN-free, at least one column), in one pass: four running
    minima per row (independent, so the loop pipelines), then the least of them."""
    n, nr = a.shape
    out = np.empty(n)
    for i in range(n):
        m0 = m1 = m2 = m3 = a[i, 0]
        j = 1
        while j + 3 < nr:
            m0 = min(m0, a[i, j])
            m1 = min(m1, a[i, j + 1])
            m2 = min(m2, a[i, j + 2])
            m3 = min(m3, a[i, j + 3])
            j += 4
        while j < nr:
            m0 = min(m0, a[i, j])
            j += 1
        out[i] = min(min(m0, m1), min(m2, m3))
    return out


def in_view(ring: np.ndarray, sx: float, sy: float, q: np.ndarray, rho: float, max_range: float) -> bool:
    """The point ``q`` is seen from the sensor at ``(sx, sy)``: the ray toward it reaches at least
    to within ``rho`` [m] of it (not occluded, not in an obstacle's shadow)."""
    dx, dy = q[0] - sx, q[1] - sy
    r = int(round(math.atan2(dy, dx) / (2.0 * math.pi) * len(ring))) % len(ring)
    return bool(ring[r] >= min(math.hypot(dx, dy) - rho, max_range))
