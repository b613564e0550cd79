"""The safety stack's barriers (ours; Section 5.3 layers around eq. (38)-(39)), pure numba kernels.

- :func:`safety_filter`: speed cap and the wall braking barrier over the LiDAR rays (the
  ``WallBarrier`` part);
- :func:`agent_barrier`: the agents' car-following braking barrier (passage mode's queues);
- :func:`agent_guard`: the contact guard with priority over the clip of eq. (39)
  (the ``ContactGuard`` part);
- :func:`push_clear`: keeps a waypoint off the walls (waypoint regulation).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from swarmnav.methods.hes.neighbours import all_rows

@njit(cache=True)
def safety_filter(a, v, ring, cos_t, sin_t, dt, v_cap, a_brake, margin, max_range, passes=3, ring_min=None):
    """Adaptive motion regulation (ours; the safety stack's layers around eq. (38), Section 5.3).

    Projects each agent's commanded next velocity ``w = v + a dt`` onto

    1. the speed cap ``||w|| <= v_cap`` (scaled down if longer), then
    2. the braking barrier: for every LiDAR ray r (range d_r < R_L, direction u_r) the closing
       speed ``w . u_r`` may not exceed ``c_r = sqrt(2 a_brake max(d_r - margin, 0))``, the speed
       a deceleration ``a_brake`` can stop within the remaining distance. Up to ``passes`` sweeps
       over the rays remove an excess along u_r (cyclic projection onto the half-planes); one
       sweep is not enough between two obstacles, where removing the excess toward one ray adds
       closing speed toward another already visited (an agent slid into a tree that way). What
       is left after the sweeps is removed by scaling w toward 0, which meets every bound
       (c_r >= 0): the barrier always holds,

    and returns the acceleration ``(w - v) / dt`` that realises it. Saturation (eq. 39)
    is applied afterwards by the caller. ``ring_min`` (N,), each ring's nearest return [m], if
    given, lets an agent slower than the bound of its nearest return skip the sweeps (no ray can
    bind it: the result is the same).
    """
    n = ring.shape[0]
    out = np.empty((n, 2))
    for i in range(n):
        wx = v[i, 0] + dt * a[i, 0]
        wy = v[i, 1] + dt * a[i, 1]
        s = math.sqrt(wx * wx + wy * wy)
        if s > v_cap:
            wx *= v_cap / s
            wy *= v_cap / s
        if ring_min is not None:
            # every bound c_r is at least the nearest return's; a closing speed w . u_r is at most
            # |w| (1e-9 m/s covers the rounding): no ray can bind, nothing moves
            if math.sqrt(wx * wx + wy * wy) + 1e-9 < math.sqrt(2.0 * a_brake * max(ring_min[i] - margin, 0.0)):
                out[i, 0] = (wx - v[i, 0]) / dt
                out[i, 1] = (wy - v[i, 1]) / dt
                continue
        moved = True
        for _ in range(passes):  # usually one sweep: nothing to remove, nothing moved
            wx, wy, moved, _s = _wall_sweep(wx, wy, ring[i], cos_t, sin_t, a_brake, margin, max_range, True)
            if not moved:
                break
        scale = 1.0
        if moved:  # the sweeps did not settle: scale toward 0 until every bound holds
            scale = _wall_sweep(wx, wy, ring[i], cos_t, sin_t, a_brake, margin, max_range, False)[3]
        out[i, 0] = (scale * wx - v[i, 0]) / dt
        out[i, 1] = (scale * wy - v[i, 1]) / dt
    return out


@njit(cache=True)
def _wall_sweep(wx, wy, row, cos_t, sin_t, a_brake, margin, max_range, project):
    """One sweep of :func:`safety_filter` over the rays of one agent's ring. ``project``: remove
    each excess of the closing speed ``w . u_r`` over its bound along u_r, in ray order, and
    report whether w moved; otherwise leave w and return (4th value) the largest s <= 1 with
    s w within every bound."""
    moved = False
    scale = 1.0
    tol = 1e-12 if project else 0.0
    for r in range(row.shape[0]):
        d = row[r]
        if d >= max_range:
            continue
        c = wx * cos_t[r] + wy * sin_t[r]
        if c <= 0.0:
            continue
        c_max = math.sqrt(2.0 * a_brake * max(d - margin, 0.0))
        if c > c_max + tol:
            if project:
                wx -= (c - c_max) * cos_t[r]
                wy -= (c - c_max) * sin_t[r]
                moved = True
            else:
                scale = min(scale, c_max / c)
    return wx, wy, moved, scale


@njit(cache=True)
def _brake_toward_neighbours(w, x, v, i, a_brake, margin, a_lead, tol, ptr, idx, reach2=np.inf):
    """One pass of agent i's braking bounds, in place on its next velocity ``w[i]``: for every
    other agent j at distance d (``u = (p_j - p_i) / d``, ``s_j = v_j . u``) an excess of
    ``w_i . u`` over ``c_max`` (+ ``tol``) is removed along u. i only brakes: a neighbour closing
    on it never pushes it away (that one's own bound brakes it). Returns whether w_i changed.

    ``a_lead > 0``: the car-following bound of :func:`agent_barrier`,
    ``c_max = sqrt(2 a_brake (max(d - margin, 0) + max(s_j, 0)^2 / (2 a_lead)))``;
    ``a_lead <= 0``: the two-sided bound of :func:`agent_guard`,
    ``c_max = sqrt(max(2 a_brake (d - margin) + s_j |s_j|, 0))``. Neighbours farther than
    ``sqrt(reach2)`` [m] are skipped (a radius beyond which no bound can bind, :func:`brake_reach2`).
    """
    moved = False
    for t in range(ptr[i], ptr[i + 1]):
        j = idx[t]
        if j == i:
            continue
        if brake_pair(w, i, x[i, 0], x[i, 1], x[j, 0], x[j, 1], v[j, 0], v[j, 1], a_brake, margin, a_lead, tol,
                      reach2):
            moved = True
    return moved


def brake_radius(a: np.ndarray, v: np.ndarray, dt: float, a_brake: float, margin: float) -> float:
    """Distance [m] beyond which no braking bound of :func:`agent_barrier` or :func:`agent_guard`
    can bind: a bound ``c_max >= sqrt(max(2 a_brake (d - margin) - max|v|^2, 0))`` exceeds every
    closing speed ``w_i . u <= max|v + a dt|`` there (projections never lengthen w_i); 1 m of slack."""
    w2 = float(np.max(np.sum((v + dt * a) ** 2, axis=1), initial=0.0))
    v2 = float(np.max(np.sum(v * v, axis=1), initial=0.0))
    return margin + (w2 + v2) / (2.0 * a_brake) + 1.0


@njit(cache=True)
def agent_barrier(a, x, v, active, dt, a_brake, margin, a_lead, ptr=None, idx=None):
    """Braking barrier between agents (ours; passage mode's queues, beside :func:`safety_filter`).

    For every ``active`` agent i and every other agent j at distance d, with unit direction
    ``u = (p_j - p_i) / d`` and j's speed away from i ``s_j = max(v_j . u, 0)``, agent i's
    commanded next velocity ``w_i = v_i + a_i dt`` may approach j no faster than it can stop
    (deceleration ``a_brake``) short of ``margin`` from where j would stop if it braked at
    ``a_lead`` (the car-following safe speed of Gipps):

        w_i . u  <=  sqrt(2 a_brake (max(d - margin, 0) + s_j^2 / (2 a_lead))),

    an excess is removed along u (pairs in index order, a greedy projection). i only brakes: a
    neighbour closing on it does not push it away (that one's own barrier brakes it). Returns
    the acceleration ``(w - v) / dt``.

    Why: the repulsions of eq. (25)/(31) are ~k/d (<= 7 m/s^2 at the 0.4 m contact distance) and
    act on positions only; members converging on a gate mouth at 1-2 m/s were not stopped by them
    (narrow_alternating_gates: 146 contacts per run, median closing speed 1.4 m/s at contact).

    ``ptr, idx``: neighbour rows (``neighbours.neighbour_rows``) covering :func:`brake_radius`, or
    every pair if not given (the same result).
    """
    n = x.shape[0]
    if ptr is None or idx is None:
        ptr, idx = all_rows(n)
    w = v + dt * a
    for i in range(n):
        if active[i]:
            _brake_toward_neighbours(w, x, v, i, a_brake, margin, a_lead, 0.0, ptr, idx)
    return (w - v) / dt


@njit(cache=True, inline="always")
def brake_pair(w, i, xi, yi, xj, yj, vxj, vyj, a_brake, margin, a_lead, tol, reach2):
    """One neighbour's bound of :func:`_brake_toward_neighbours` on agent i's next velocity ``w[i]``
    (in place), the neighbour at ``(xj, yj)`` moving at ``(vxj, vyj)``; whether it braked. Shared by
    the ideal guard and the network's (each agent's picture of the others)."""
    ux = xj - xi
    uy = yj - yi
    if ux * ux + uy * uy > reach2:
        return False
    d = math.sqrt(ux * ux + uy * uy)
    if d <= 0.0:
        return False
    ux /= d
    uy /= d
    c = w[i, 0] * ux + w[i, 1] * uy
    if c <= 0.0:
        return False
    sj = vxj * ux + vyj * uy
    if a_lead > 0.0:
        vj = max(sj, 0.0)
        c_max = math.sqrt(2.0 * a_brake * (max(d - margin, 0.0) + vj * vj / (2.0 * a_lead)))
    else:
        c_max = math.sqrt(max(2.0 * a_brake * (d - margin) + sj * abs(sj), 0.0))
    if c > c_max + tol:
        w[i, 0] -= (c - c_max) * ux
        w[i, 1] -= (c - c_max) * uy
        return True
    return False


@njit(cache=True)
def brake_reach2(w2, v2, a_brake, margin):
    """Squared distance [m^2] beyond which the two-sided bound of :func:`agent_guard` cannot bind
    an agent whose next velocity has squared norm ``w2`` (its projections never lengthen it) among
    neighbours of squared speed at most ``v2``: there ``c_max >= sqrt(2 a_brake (d - margin) - v2)``
    exceeds ``sqrt(w2) >= w . u``; 1 m of slack (as :func:`brake_radius`)."""
    r = margin + (w2 + v2) / (2.0 * a_brake) + 1.0
    return r * r


@njit(cache=True)
def agent_guard(a, x, v, dt, a_brake, margin, a_max, passes=4, ptr=None, idx=None):
    """Contact guard between agents (ours): a braking bound with priority over the clip of eq. (39).

    ``a`` is the already saturated command (norm <= ``a_max``). For every agent i and every other
    agent j at distance d, ``u = (p_j - p_i) / d``, agent i's next velocity ``w_i = v_i + a_i dt``
    may approach j no faster than lets both stop ``margin`` apart if each brakes at ``a_brake``
    (the sum of the two stopping distances fits in the gap):

        w_i . u  <=  sqrt(max(2 a_brake (d - margin) + s_j |s_j|, 0)),   s_j = v_j . u,

    (s_j > 0: j moves away and its own stopping distance adds room; s_j < 0: j closes in and
    its stopping distance is taken off; two agents closing head-on each need only ``a_brake``
    to stay on the bound). An excess is removed along u; the projections onto i's half-planes
    are cycled up to ``passes`` times (each contains w = 0, so the cycle heads for a point that
    satisfies all of them: one pass leaves a member squeezed between neighbours over the bound
    of the first); i only brakes, it is never pushed away from j.

    The braking correction ``b_i`` is then kept whole (up to ``a_max``) and the rest of the
    command scaled down to make room: the result is ``b_i + lam a_i`` with the largest
    ``lam`` in [0, 1] that keeps the norm <= ``a_max`` (``a_max b_i / ||b_i||`` if ``b_i`` alone
    exceeds it). Why: the 1/d repulsions of eqs. (25)/(31) (<= 7 m/s^2 at contact) act on
    positions, not on the closing speed (1-4 m/s at contact), and eq. (39) scales them down
    with the far larger LiDAR repulsion near obstacles. Returns the new (N, 2) command.
    ``ptr, idx``: neighbour rows covering :func:`brake_radius`, or every pair if not given.
    """
    n = x.shape[0]
    if ptr is None or idx is None:
        ptr, idx = all_rows(n)
    w = v + dt * a
    v2 = 0.0
    for j in range(n):
        v2 = max(v2, v[j, 0] * v[j, 0] + v[j, 1] * v[j, 1])
    for i in range(n):
        reach2 = brake_reach2(w[i, 0] * w[i, 0] + w[i, 1] * w[i, 1], v2, a_brake, margin)
        for _ in range(passes):
            if not _brake_toward_neighbours(w, x, v, i, a_brake, margin, 0.0, 1e-12, ptr, idx, reach2):
                break
    return keep_braking(a, v, w, dt, a_max)


@njit(cache=True)
def keep_braking(a, v, w, dt, a_max):
    """The contact guard's last stage: each agent's braking correction ``b = (w - v) / dt - a`` kept
    whole (up to ``a_max``) and the rest of the command scaled, ``b + lam a`` with the largest
    ``lam`` in [0, 1] that keeps the norm <= ``a_max`` (:func:`agent_guard`). (N, 2) [m/s^2]."""
    n = a.shape[0]
    out = np.empty((n, 2))
    for i in range(n):
        bx = (w[i, 0] - v[i, 0]) / dt - a[i, 0]
        by = (w[i, 1] - v[i, 1]) / dt - a[i, 1]
        if bx == 0.0 and by == 0.0:
            out[i, 0] = a[i, 0]
            out[i, 1] = a[i, 1]
            continue
        ax, ay = a[i, 0], a[i, 1]
        tx, ty = ax + bx, ay + by
        if tx * tx + ty * ty <= a_max * a_max:
            out[i, 0], out[i, 1] = tx, ty
            continue
        bb = bx * bx + by * by
        if bb >= a_max * a_max:
            s = a_max / math.sqrt(bb)
            out[i, 0], out[i, 1] = s * bx, s * by
            continue
        # largest lam in [0, 1] with ||b + lam a|| = a_max (||b|| < a_max < ||b + a||)
        aa = ax * ax + ay * ay
        ab = ax * bx + ay * by
        lam = (-ab + math.sqrt(max(ab * ab - aa * (bb - a_max * a_max), 0.0))) / aa
        lam = min(max(lam, 0.0), 1.0)
        out[i, 0], out[i, 1] = bx + lam * ax, by + lam * ay
    return out


@njit(cache=True)
def push_clear(px, py, ring, sx, sy, cos_t, sin_t, clear, max_range, iters):
    """Move point ``(px, py)`` away from the returns of the ring sensed at ``(sx, sy)`` until it is
    ``clear`` [m] from the nearest one, or midway across a passage narrower than ``2 clear``
    (the nearest return on the opposite side, within 60 deg of the push direction, bounds the
    push); at most ``iters`` pushes. Keeps a waypoint off walls without closing narrow gaps."""
    n = ring.shape[0]
    for _ in range(iters):
        best = np.inf
        qx = qy = 0.0
        for r in range(n):
            d = ring[r]
            if d >= max_range:
                continue
            hx = sx + d * cos_t[r]
            hy = sy + d * sin_t[r]
            e2 = (px - hx) ** 2 + (py - hy) ** 2
            if e2 < best:
                best = e2
                qx, qy = hx, hy
        d1 = math.sqrt(best)
        if not d1 < clear or d1 == 0.0:
            break
        ux = (px - qx) / d1
        uy = (py - qy) / d1
        d2 = np.inf  # nearest return across, in the push direction
        for r in range(n):
            d = ring[r]
            if d >= max_range:
                continue
            hx = sx + d * cos_t[r] - px
            hy = sy + d * sin_t[r] - py
            e = math.sqrt(hx * hx + hy * hy)
            if e < d2 and hx * ux + hy * uy > 0.5 * e:
                d2 = e
        c = min(clear, 0.5 * (d1 + d2))
        if d1 >= c - 1e-9:
            break
        px += (c - d1) * ux
        py += (c - d1) * uy
    return px, py
