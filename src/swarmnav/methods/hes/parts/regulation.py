"""The waypoint layers of our safety stack and the route-cost width penalty (ours; Section 5.3 names
"adaptive motion regulation layers" without a formula), called by ``navigate`` where the switches
say: ``leash`` and ``cruise`` when c_s is leashed (``HesParams.leashed``: with the safety stack, or
``ablation.keep_leash``), ``off_walls`` with the safety stack, ``width_penalty`` with ``width.on``.
Off, c_s is the corridor target itself and the route cost is the route length, as in the paper.
"""

from __future__ import annotations

import math

import numpy as np

from swarmnav.methods.hes.parts.barriers import push_clear


def leash(p, clearance: float, waypoint: np.ndarray, tx: float, ty: float, cent: np.ndarray) -> tuple[float, float]:
    """Waypoint regulation: c_s (``waypoint``) one step of the adaptive cruise speed toward the
    target ``(tx, ty)``, then held within ``core.lead`` of the centroid ``cent`` [m]."""
    # two-vectors as Python floats: the same IEEE operations as numpy's, without its per-call cost
    step_len = cruise(p, clearance) * p.paper.dt
    wx, wy = waypoint.tolist()
    dx, dy = tx - wx, ty - wy
    dn = math.hypot(dx, dy)
    if dn <= step_len:
        wx, wy = tx, ty
    else:
        f = step_len / dn
        wx, wy = wx + dx * f, wy + dy * f
    cx, cy = float(cent[0]), float(cent[1])
    ox, oy = wx - cx, wy - cy
    on = math.hypot(ox, oy)
    if on > p.core.lead:
        f = p.core.lead / on
        wx, wy = cx + ox * f, cy + oy * f
    return wx, wy


def off_walls(p, ring: np.ndarray, at: np.ndarray, w: float, wx: float, wy: float, cos_t: np.ndarray,
              sin_t: np.ndarray) -> tuple[float, float]:
    """c_s pushed ``safety.wp_clear`` (at most half the route's width ``w``) off the returns of the
    subleader's ring ``ring``, seen from its position ``at`` [m]."""
    clear = min(p.safety.wp_clear, 0.5 * w)
    return push_clear(wx, wy, ring, at[0], at[1], cos_t, sin_t, clear, p.paper.lidar_range, 3)


def cruise(p, clearance: float) -> float:
    """Cruise speed v_s of a sub-swarm [m/s]; with the safety stack on, scaled down linearly
    from v_s (clearance >= clr_slow) to v_min_frac v_s (clearance <= d_safe) by the nearest
    LiDAR return of its members (adaptive cruise, ours; it paces the leashed waypoint)."""
    if not p.leashed:
        return p.core.v_s
    f = _clip((clearance - p.paper.d_safe) / max(p.safety.clr_slow - p.paper.d_safe, 1e-9), 0.0, 1.0)
    return p.core.v_s * (p.safety.v_min_frac + (1.0 - p.safety.v_min_frac) * f)


def width_penalty(w: float, m: int, w0: float = 6.0) -> float:
    """Route-cost penalty [m] of a narrow corridor for a sub-swarm of m agents (ours): the
    extra queue length of funnelling m agents through it, 1 m per agent at w = 0, zero from
    ``w0`` (6 m: three abreast at 2 m) up."""
    if not math.isfinite(w):
        return 0.0
    return m * max(0.0, w0 - w) / w0


def _clip(v: float, lo: float, hi: float) -> float:
    """``float(np.clip(v, lo, hi))`` for one float, without the array call."""
    return min(max(float(v), lo), hi)
