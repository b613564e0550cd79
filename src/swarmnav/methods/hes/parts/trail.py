"""Trail following (ours, beyond the paper; switch ``trail_follow``): a member cut off from its
sub-swarm retraces its teammates' trail instead of pulling at its slot through the wall.

Why: eqs. (24) and (32) pull a member straight at its slot and the waypoint c_s, through any wall
between them (eq. (30) attenuates the slot term, not the centering term, which grows with the
distance). A member left in a block's concave corner -- the wall between it and the swarm, the
way out pointing away from the swarm -- was held there by them against the LiDAR repulsion for
the rest of the run (dense_cross_blocks held-out seeds: one or two stragglers, R_unsafe
0.45-0.65 on those runs).

Parameters: ``trail_every``, ``trail_len``, ``trail_reach``, ``cut_time``, ``rho_vis``, ``d_c``.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from swarmnav.methods.hes.corridors import newest_visible
from swarmnav.methods.hes.forces import SIG_CENT, SIG_NN, SIG_SL, SIG_SLOT
from swarmnav.methods.hes.hooks import Part


class TrailFollow(Part):
    """Trail following (see the module docstring)."""

    name = "trail"
    needs_blocked = True  # cut off = the segments to slot, subleader and centroid all blocked

    def __init__(self, p):
        self.p = p

    def reset(self, hes, positions):
        n = len(positions)
        self.h = hes
        self.trail = np.zeros((self.p.trail.length, n, 2))  # members' positions every trail_every steps
        self.count = 0
        self.cut_steps = np.zeros(n, dtype=np.int64)  # consecutive steps cut off from the sub-swarm
        self.last_cut = np.zeros(n, dtype=np.bool_)  # members following the trail this step
        self.pictured = None  # on a network: (length, N, N, 2) each agent's trail of its pictures (NaN: not heard) ...
        self.n_pictured = 0  # ... and how many samples it holds

    def record(self, x: np.ndarray) -> None:
        """Append one sample of every agent's position (the oldest is dropped when full)."""
        if self.count == len(self.trail):
            self.trail[:-1] = self.trail[1:]
            self.count -= 1
        self.trail[self.count] = x
        self.count += 1

    def observe(self, step):
        if step.k % self.p.trail.every == 0:
            self.record(step.x)

    def observe_known(self, step, net):
        """On a network each agent keeps its own trail: its pictures of the others (``net.kx``,
        NaN where it has not heard them) every ``trail_every`` steps; its own row its own position."""
        if net.k % self.p.trail.every:
            return
        n = len(net.kx)
        if self.pictured is None:
            self.pictured = np.full((self.p.trail.length, n, n, 2), np.nan)
        if self.n_pictured == len(self.pictured):
            self.pictured[:-1] = self.pictured[1:]
            self.n_pictured -= 1
        self.pictured[self.n_pictured] = np.where(net.heard[:, :, None], net.kx, np.nan)
        self.n_pictured += 1

    def steer_known(self, step, net):
        """:meth:`steer` on a network: a member cut off retraces its own trail of its pictures of
        the mates of the plan it flies."""
        self._steer(step, net)

    def steer(self, step):
        self._steer(step, None)

    def _steer(self, step, net):
        """A member cut off from its sub-swarm -- the segments to its slot, its subleader and its
        centroid all blocked for ``cut_time``, farther than ``d_c`` from the centroid, not the
        subleader, not routed by another part -- takes as slot and corridor-centering target the
        newest point of its teammates' trail that it can reach in a straight line (no return of
        its own ring within ``rho_vis`` of the segment, at most ``trail_reach`` away). Once there, a
        newer point is in view: it retraces the way the others went. Its subleader, centroid and
        (if blocked) nearest-neighbour couplings are switched off meanwhile."""
        p, h = self.p, self.h
        b = step.blocked
        if not n_cut_off(b):  # the common case: nobody is cut off
            self.cut_steps[:] = 0
            self.last_cut = np.zeros(h.n, dtype=np.bool_)
            return
        cut = b[:, SIG_SLOT] & b[:, SIG_SL] & b[:, SIG_CENT]
        cut &= ~step.routed & (step.sl_idx != np.arange(h.n))  # a passage chain routes its own members
        cut &= np.hypot(*(step.x - step.cent).T) > p.core.d_c
        self.cut_steps = np.where(cut, self.cut_steps + 1, 0)
        cut &= self.cut_steps * p.paper.dt >= p.trail.cut_time
        self.last_cut = cut
        count = self.count if net is None else self.n_pictured
        if not cut.any() or count == 0:
            return
        x, sig = step.x, step.sig
        for i in np.flatnonzero(cut):
            if net is None:
                trail, mates = self.trail, np.flatnonzero((h.labels == h.labels[i]) & ~cut)
            else:  # its own trail, the mates of its own plan
                trail = np.ascontiguousarray(self.pictured[:count, i])
                mates = np.flatnonzero((net.lab[i] == net.lab[i, i]) & ~cut)
            t, j = newest_visible(step.ring[i], x[i, 0], x[i, 1], h.cos, h.sin, trail, count,
                                  mates, p.core.rho_vis, p.trail.reach, p.paper.lidar_range)
            if t >= 0:
                step.slot[i] = step.wp[i] = trail[t, j]
                sig[i, SIG_SLOT] = 1.0
                # the couplings it cannot see (subleader, centroid, nearest neighbour) no longer
                # pull it at the wall: attenuated by eq. (30) they still pinned it there
                sig[i, SIG_SL] = sig[i, SIG_CENT] = 0.0
                if b[i, SIG_NN]:
                    sig[i, SIG_NN] = 0.0


@njit(cache=True)
def n_cut_off(blocked):
    """How many agents have the segments to their slot, subleader and centroid all blocked
    (``blocked`` (N, 4), columns as ``forces.SIG_*``)."""
    k = 0
    for i in range(blocked.shape[0]):
        if blocked[i, SIG_SLOT] and blocked[i, SIG_SL] and blocked[i, SIG_CENT]:
            k += 1
    return k
