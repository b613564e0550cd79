"""Encircle slots that give way to obstacles (``core.enc_yield``, ours; the paper gives no slots).

The circulating encircle ring (``core.enc_orbit``) turns through every direction around the goal.
Where an obstacle comes near the goal (default_corridor: the central separator ends 7 m from it,
1 m outside the 6 m ring), every lap brings a member within d_safe of it. With ``enc_yield`` > 0,
each encircling member's slot moves in along its ray toward the goal until it lies ``enc_yield``
from every return of the member's own LiDAR ring, so the ring bends inward around the obstacle
and keeps turning. Only perception enters: the member's ring, not the map.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from swarmnav.methods.hes.hooks import Part

YIELD_STEP = 0.25  # [m] radial resolution of the search (a fraction of the 1.4 m formation spacing)


@njit(cache=True)
def yield_slots(x, slot, ring, cos_t, sin_t, goal, active, clear, max_range, dr):
    """In place: for each agent i with ``active[i]``, move ``slot[i]`` toward ``goal`` in steps of
    ``dr`` [m] until no return of ``ring[i]`` (ranges [m] from ``x[i]``; ``max_range``: no return)
    lies within ``clear`` [m] of it; the goal itself if no point of the ray is clear."""
    n, nr = ring.shape
    c2 = clear * clear
    for i in range(n):
        if not active[i]:
            continue
        ox, oy = slot[i, 0] - goal[0], slot[i, 1] - goal[1]
        r = math.sqrt(ox * ox + oy * oy)
        if r <= 0.0:
            continue
        ux, uy = ox / r, oy / r
        rr = r
        while True:
            qx, qy = goal[0] + rr * ux, goal[1] + rr * uy
            ok = True
            for t in range(nr):
                d = ring[i, t]
                if d >= max_range:
                    continue
                hx = x[i, 0] + d * cos_t[t] - qx
                hy = x[i, 1] + d * sin_t[t] - qy
                if hx * hx + hy * hy < c2:
                    ok = False
                    break
            if ok or rr <= 0.0:
                break
            rr = max(rr - dr, 0.0)
        slot[i, 0], slot[i, 1] = goal[0] + rr * ux, goal[1] + rr * uy


class RingYield(Part):
    """``core.enc_yield``: encircling members' slots give way to the returns they see (module docstring).

    Acts at the ``steer`` hook, so the slot-segment occlusion factor of eq. (30) is the one of the
    slot before it gave way (the slot moves toward the goal, which the member sees)."""

    name = "ring_yield"

    def __init__(self, p):
        self.p = p

    def reset(self, hes, positions):
        self.h = hes

    def steer(self, step):
        active = ~step.nav & (step.own < 0)  # encircling members the core routes
        if np.count_nonzero(active):
            h, p = self.h, self.p
            yield_slots(step.x, step.slot, step.ring, h.cos, h.sin, h.goal, active, p.core.enc_yield,
                        p.paper.lidar_range, YIELD_STEP)
