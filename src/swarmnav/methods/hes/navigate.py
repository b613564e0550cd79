"""Stage 4 of a HES step for one sub-swarm: task mode (eq. 12), corridor choice, waypoint c_s(k).

The reactive route choice of Section 3.2: the direct route when the goal is in clear view, else
the cheapest reported corridor, kept with a hysteresis while it is still seen. Parts of ours
plug in at the hooks ``encircle``, ``plan``, ``hold``, ``candidates``, ``end_route``, ``lost``,
``chosen``, ``target`` and ``restart`` (see ``hooks.py``). With the safety stack on, c_s advances
toward its target at the adaptive cruise speed on a leash around the centroid and is kept off the
walls, and the route cost may carry a width penalty: those layers of ours are in
``parts/regulation.py``.
"""

from __future__ import annotations

import math

import numpy as np

from swarmnav.methods.hes.corridors import Corridor, direct_corridor, segment_clear
from swarmnav.methods.hes.decision import ENCIRCLE, target_proximity, task_mode
from swarmnav.methods.hes.formation import hex_width
from swarmnav.methods.hes.hierarchy import Report
from swarmnav.methods.hes.parts.regulation import leash, off_walls, width_penalty
from swarmnav.methods.hes.step import NEVER, Step, SubSwarm


def navigate(h, step: Step, sub: SubSwarm, rep: Report) -> None:
    """Task mode (eq. 12), corridor choice and waypoint c_s(k) of one sub-swarm."""
    p = h.params
    x = step.x
    cent = rep.pack.centroid
    if step.n_own:
        head = rep.pack.members[step.own[rep.pack.members] < 0]
        if 0 < len(head) < len(rep.pack.members):  # members routed on their own: c_s leads the others
            cent = x[head].mean(axis=0)
    sl = x[sub.subleader]
    gx, gy = h.goal
    delta = target_proximity(math.hypot(cent[0] - gx, cent[1] - gy), math.hypot(sl[0] - gx, sl[1] - gy))
    mode = task_mode(sub.mode, delta, p.paper.r_in, p.paper.r_out)
    if mode != sub.mode:
        sub.slot_step = NEVER
        sub.ring_offsets = None
    sub.mode = mode
    if mode == ENCIRCLE:
        sub.waypoint = h.goal.copy()
        for part in h.at["encircle"]:
            part.encircle(step, sub, rep)
        return
    planned = None
    for part in h.at["plan"]:
        planned = part.plan(step, sub, rep, cent) or planned
    route = choose_route(h, step, sub, rep) if planned is None else planned[0]
    sub.route = route
    for part in h.at["chosen"]:
        part.chosen(step, sub, rep, route)
    if planned is not None:
        target = planned[1]
    elif route is None:
        target = h.goal
    elif route.direct:
        target = route.target
    else:  # `through` metres past the throat, or past the centroid once that is beyond the throat
        along = max(float(np.dot(cent - route.mid, route.normal)), 0.0)
        target = route.mid + (along + p.core.through) * route.normal
        for part in h.at["target"]:
            target = part.target(step, sub, route, target, cent, along)
    for part in h.at["restart"]:
        part.restart(step, sub, cent)
    regulate(h, step, sub, rep, route, target, cent)


def regulate(h, step: Step, sub: SubSwarm, rep: Report, route: Corridor | None, target: np.ndarray,
             cent: np.ndarray) -> None:
    """c_s toward ``target`` and the formation axis and squeeze along the motion of c_s.

    With the safety stack on (ours): c_s advances toward the target at the adaptive cruise speed
    (a virtual leader), on a leash of length ``lead`` around the centroid, kept ``wp_clear`` off
    the walls the subleader sees; off: c_s is the target itself."""
    p = h.params
    x = step.x
    # two-vectors as Python floats: the same IEEE operations as numpy's, without its per-call cost
    tx, ty = float(target[0]), float(target[1])
    if p.leashed:
        wx, wy = leash(p, rep.clearance, sub.waypoint, tx, ty, cent)
    else:
        wx, wy = tx, ty
    w = route.width if route is not None else math.inf
    if p.adaptive:
        a = sub.subleader
        wx, wy = off_walls(p, step.ring[a], x[a], w, wx, wy, h.cos, h.sin)
    sub.waypoint = np.array([wx, wy])
    # formation axis along the motion of c_s; squeeze across a corridor narrower than the formation
    dx, dy = tx - wx, ty - wy
    hn = math.hypot(dx, dy)
    if hn > 0.5:
        hx, hy = sub.heading.tolist()
        hx, hy = 0.8 * hx + 0.2 * dx / hn, 0.8 * hy + 0.2 * dy / hn
        hm = max(math.hypot(hx, hy), 1e-9)
        sub.heading = np.array([hx / hm, hy / hm])
    m = len(rep.pack.members)
    w_iso = hex_width(m) * p.core.spacing + p.core.spacing if m > 1 else p.core.spacing
    lam = _clip((w - 2 * p.core.lane_margin) / w_iso, 1 / math.sqrt(p.core.aspect_max), 1.0) if math.isfinite(w) else 1.0
    sub.squeeze += _clip(lam - sub.squeeze, -0.05, 0.05)


def choose_route(h, step: Step, sub: SubSwarm, rep: Report) -> Corridor | None:
    """The corridor this sub-swarm follows: the direct route if the goal is in clear view, else
    the cheapest candidate (route length plus the width penalty), kept (hysteresis
    ``switch_margin``) while it is still seen. Parts may keep the previous route (``hold``), drop
    candidates (``candidates``), send the sub-swarm to the goal (``end_route``)."""
    p = h.params
    a = sub.subleader
    sl = step.x[a]
    cands = list(rep.corridors)
    cent = rep.pack.centroid
    if segment_clear(step.ring[a], sl[0], sl[1], h.cos, h.sin, cent[0], cent[1], h.goal[0], h.goal[1],
                     p.paper.d_safe, p.paper.lidar_range):
        cands.insert(0, direct_corridor(cent, h.goal))
    prev = sub.route
    for part in h.at["hold"]:
        if part.hold(step, sub, rep, prev):
            return prev
    for part in h.at["candidates"]:
        cands = part.candidates(step, sub, rep, cands, cent)
    if not cands:
        if any(part.end_route(step, sub, prev) for part in h.at["end_route"]):
            return None
        return prev
    m = len(rep.pack.members)
    cost = [c.cost + (width_penalty(c.width, m, p.width.penalty_width) if p.width.on else 0.0) for c in cands]
    best = min(range(len(cost)), key=cost.__getitem__)  # the first cheapest, as np.argmin
    if prev is None:
        return cands[best]
    same = match(prev, cands)
    if same is None:
        for part in h.at["lost"]:
            part.lost(sub)
        return cands[best]
    if cost[best] >= cost[same] - p.core.switch_margin:
        return cands[same]
    return cands[best]


def match(prev: Corridor, cands: list[Corridor]) -> int | None:
    """Index of the candidate that is the same corridor as ``prev`` (None if lost)."""
    if prev.direct:
        for j, c in enumerate(cands):
            if c.direct:
                return j
    best, j_best = math.inf, None
    for j, c in enumerate(cands):
        if c.direct:
            continue
        d = math.hypot(*(c.mid - prev.mid))
        if d < best:
            best, j_best = d, j
    tol = max(3.0, 0.5 * min(prev.width, 20.0)) if math.isfinite(prev.width) else 3.0
    return j_best if best <= tol else None


def _clip(v: float, lo: float, hi: float) -> float:
    """``float(np.clip(v, lo, hi))`` for one float, without the array call."""
    return min(max(float(v), lo), hi)
