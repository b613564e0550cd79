"""The geometric post-update safety projection (``core.projection``; Section 5.3 names it, the paper
gives no formula, this is our reading).

Section 5.3 counts "the geometric post-update safety projection" in the risk-control mechanism,
beside the LiDAR repulsion and the occlusion attenuation. We read it as a projection of each
agent's next position onto the free space its own LiDAR ring shows: the step p_{k+1} - p_k =
dt (v_k + dt a_cmd) of the double integrator (eq. 5-7, semi-implicit Euler) is shortened, keeping
its direction, until it ends at least ``core.projection`` [m] short of every return ahead of it
(``s . u_r <= d_r - margin`` for every ray r; a ray without a return counts as one at the LiDAR
range), and the command is the one that makes that step. An agent can thus come close to a wall
but never cross one in a step, however fast it flies.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from swarmnav.methods.hes.hooks import Part


@njit(cache=True)
def project_step(a, x, v, ring, cos_t, sin_t, dt, margin, max_range):
    """The commands (N, 2) [m/s^2] whose step dt (v + dt a) is ``a``'s, scaled down (direction kept)
    until ``s . u_r <= max(d_r - margin, 0)`` for every ray r of ``ring`` (N, R) [m]; a ray without
    a return counts as one at ``max_range`` (nothing is known beyond it)."""
    n, nr = ring.shape
    out = a.copy()
    for i in range(n):
        sx = dt * (v[i, 0] + dt * a[i, 0])
        sy = dt * (v[i, 1] + dt * a[i, 1])
        lam = 1.0
        for r in range(nr):
            d = min(ring[i, r], max_range)  # no return: free up to the range, unknown beyond
            proj = sx * cos_t[r] + sy * sin_t[r]
            if proj <= 0.0:
                continue
            room = max(d - margin, 0.0)
            if lam * proj > room:
                lam = room / proj
        if lam < 1.0:
            out[i, 0] = (lam * sx / dt - v[i, 0]) / dt
            out[i, 1] = (lam * sy / dt - v[i, 1]) / dt
    return out


class PostProjection(Part):
    """``core.projection`` > 0: the post-update safety projection (module docstring), the last word on
    the command (after the clip of eq. (39) and the contact guard)."""

    name = "projection"

    def __init__(self, p):
        self.p = p

    def reset(self, hes, positions):
        self.h = hes

    def guard(self, step, a):
        p, h = self.p, self.h
        return project_step(np.ascontiguousarray(a), step.x, step.v, step.ring, h.cos, h.sin, p.paper.dt,
                            p.core.projection, p.paper.lidar_range)
