"""Stages 1-2 of a HES step: perception, the subleaders' reports and the planner's state z(k).

Perception is the fused LiDAR ring of every agent (eq. 8-9). Each subleader reports its Pack
P_s(k) (eq. 3) and the corridors toward the goal that its own ring shows (Section 3.2); the
leader's planner reads only these reports, and z(k) of eq. (18) is computed from them alone.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from swarmnav.methods.hes import forces as F
from swarmnav.methods.hes.corridors import GAP_W, Corridor, _filter_gaps, detect_gaps, seen_passages
from swarmnav.methods.hes.decision import DecisionState, merge_feasible, split_feasible
from swarmnav.methods.hes.hierarchy import Pack, Report, _pack_rows, make_pack
from swarmnav.methods.hes.step import Step, in_view
from swarmnav.sensing import segments_blocked_kernel


def sense(h, x: np.ndarray) -> np.ndarray:
    """Every agent's LiDAR ring (N, R) [m] (= ``swarmnav.sensing.lidar_ring``)."""
    p = h.params
    if h.no_obstacles:
        return np.full((len(x), p.paper.n_rays), p.paper.lidar_range)
    return h.obstacles.lidar_into(x, h.cos, h.sin, p.paper.lidar_range, np.empty((len(x), p.paper.n_rays)))


def reelect(h, step: Step) -> None:
    """Hand a sub-swarm's subleader role to the member nearest its centroid when the current
    subleader has strayed (farther than ``stray`` from the centroid, or cut off from it by an
    obstacle): the subleader's ring is the sub-swarm's view of the corridors (ours; the paper
    fixes no rule for who leads a sub-swarm). Parts may then change subleaders (hook ``elect``)."""
    x = step.x
    part = h.partition()
    ids = part.ids
    sl = np.array([h.subs[s].subleader for s in ids])
    if handed_over(x, part.col, sl, h.params.core.stray, not h.no_obstacles, *h.obstacles.planar_arrays):
        for s, a in zip(ids, sl.tolist()):
            h.subs[s].subleader = a
    for q in h.at["elect"]:
        q.elect(step, part.col)


@njit(cache=True)
def strayed(x, col, sl, stray, check, seg_a, seg_b, poly_offsets, circ_c, circ_r, bbox_lo, bbox_hi):
    """Whether each subleader ``sl`` (S,) has strayed -- farther than ``stray`` [m] from its
    sub-swarm's centroid or (``check``) cut off from it by an obstacle (the geometry's planar
    arrays) -- and each sub-swarm's member nearest its centroid (the lowest index among equals)."""
    S = sl.shape[0]
    cents = F.group_centroids(x, col, S)
    far = np.empty(S, dtype=np.bool_)
    for j in range(S):
        far[j] = math.hypot(x[sl[j], 0] - cents[j, 0], x[sl[j], 1] - cents[j, 1]) > stray
    if check:
        ends = np.empty((S, 2))
        for j in range(S):
            ends[j, 0], ends[j, 1] = x[sl[j], 0], x[sl[j], 1]
        cut = np.empty(S, dtype=np.bool_)
        segments_blocked_kernel(seg_a, seg_b, poly_offsets, circ_c, circ_r, bbox_lo, bbox_hi, ends, cents, cut)
        for j in range(S):
            far[j] = far[j] or cut[j]
    nearest = np.full(S, -1, dtype=np.int64)
    best = np.full(S, np.inf)
    for i in range(x.shape[0]):
        j = col[i]
        dx = x[i, 0] - cents[j, 0]
        dy = x[i, 1] - cents[j, 1]
        d2 = dx * dx + dy * dy
        if d2 < best[j] or nearest[j] < 0:
            best[j], nearest[j] = d2, i
    return far, nearest


@njit(cache=True)
def handed_over(x, col, sl, stray, check, seg_a, seg_b, poly_offsets, circ_c, circ_r, bbox_lo, bbox_hi):
    """:func:`strayed`, with each strayed subleader in ``sl`` replaced in place by its sub-swarm's
    member nearest the centroid; returns how many were replaced (nothing is returned as an array)."""
    far, nearest = strayed(x, col, sl, stray, check, seg_a, seg_b, poly_offsets, circ_c, circ_r, bbox_lo, bbox_hi)
    k = 0
    for j in range(sl.shape[0]):
        if far[j]:
            sl[j] = nearest[j]
            k += 1
    return k


def report(h, step: Step, s: int, members: np.ndarray | None = None, subleader: int | None = None,
           planner_hooks: bool = True) -> Report:
    """Subleader s's report: its Pack and the corridors toward the goal its ring shows (those
    whose throat is reachable straight from the centroid), and its members' nearest return.
    ``members``: the members it reports (ascending; default: every member of the partition);
    ``subleader``: the agent reporting (default: the planner's subleader of s; on a network the
    agent whose plan makes it s's subleader, which the planner may have relieved since);
    ``planner_hooks``: False leaves out the hooks that read the planner's memory (``corridors``,
    ``cruise_mask``), which on a network the leader applies to the report it receives."""
    p = h.params
    x = step.x
    sub = h.subs.get(s)
    if members is None:
        part = h.partition()
        members = part.members[part.index[s]]
    a = sub.subleader if subleader is None else subleader
    if h.at["gaps"]:  # a part edits the openings: the stages one by one
        pack = make_pack(s, a, members, x, step.v)
        gaps = detect_gaps(step.ring[a], x[a, 0], x[a, 1], h.cos, h.sin, p.paper.lidar_range, p.core.h_open)
        for q in h.at["gaps"]:
            gaps = q.gaps(step, sub, gaps)
        rows = _filter_gaps(gaps, x[a, 0], x[a, 1], *h.report_consts[:4], step.ring[a], x[a, 0], x[a, 1], h.cos,
                            h.sin, pack.centroid[0], pack.centroid[1], *h.report_consts[4:])
        clear = float(step.ring_min[members].min())
    else:
        m = len(members)
        buf, rows = np.empty((2 * m + 2, 2)), np.empty((len(h.cos), 8))  # (fewer openings than rays)
        k, clear = report_rows(x, step.v, members, a, step.ring, step.ring_min, h.cos, h.sin, h.report_c, buf, rows)
        pack = Pack(s, a, members, buf[:m], buf[m:2 * m], buf[2 * m], buf[2 * m + 1])
        rows = rows[:k]
    widths, costs = rows[:, 4].tolist(), rows[:, 7].tolist()
    cors = [Corridor(rows[j, 0:2], rows[j, 2:4], widths[j], rows[j, 5:7], costs[j])
            for j in sorted(range(len(costs)), key=costs.__getitem__)]  # by cost, stable
    for q in (h.at["corridors"] if planner_hooks else ()):
        cors = q.corridors(step, sub, cors)
    clr = None  # the members' returns a part's cruise mask keeps (None: every member's, as `clear`)
    for q in (h.at["cruise_mask"] if planner_hooks else ()):
        free = q.cruise_mask(members)
        if free is not None:
            clr = step.ring_min[members] if clr is None else clr
            clr = clr[free] if np.count_nonzero(free) else clr
    if clr is not None:
        clear = min(clr.tolist())
    return Report(pack, tuple(cors), clear)


def report_constants(h) -> tuple[tuple, tuple]:
    """The report's scalars, read once per run: gap detection's (R_L, h_open, and a part's
    ``seen_w``, ``seen_depth``) and the corridor filter's (goal, w_pass, cos of toward_deg, rho_vis,
    R_L, the approach to narrow throats, through); :func:`report_rows` takes them as one float
    array, ``np.array(gaps + consts, dtype=float)``."""
    p = h.params
    seen = next(((q.seen_w, q.seen_depth) for q in reversed(h.parts) if q.seen_w > 0.0), (0.0, 0.0))
    approach, approach_w = h.approach
    return ((p.paper.lidar_range, p.core.h_open, *seen),
            (float(h.goal[0]), float(h.goal[1]), p.core.w_pass, math.cos(math.radians(p.core.toward_deg)),
             p.core.rho_vis, p.paper.lidar_range, True, float(approach), float(approach_w), float(p.core.through)))


@njit(cache=True)
def report_rows(x, v, members, a, ring, ring_min, cos_t, sin_t, c, pack, rows_out):
    """One report's arrays in one pass: the Pack's rows (``hierarchy._pack_rows``), the openings of
    subleader ``a``'s ring (:func:`detect_gaps`; one narrower than ``seen_w`` kept only if
    ``seen_passages`` at ``seen_depth``), the candidate corridors among them (rows of
    ``corridors._filter_gaps``) and the members' nearest return [m].

    ``c``: the report's scalars (:func:`report_constants`, gap detection's then the filter's, as
    floats). Written into ``pack`` (2m + 2, 2): the members' positions, their velocities, the
    centroid and the subleader's row, and into ``rows_out`` (at least one row per ray): the K
    corridor rows. Returns ``(K, nearest return)`` (arrays written in place are cheaper to hand
    back than returned ones)."""
    max_range, h_open, seen_w, seen_depth = c[0], c[1], c[2], c[3]
    pos, vel, cen, sl_row = _pack_rows(x, v, members, a)
    m = members.shape[0]
    for i in range(m):
        pack[i, 0], pack[i, 1] = pos[i, 0], pos[i, 1]
        pack[m + i, 0], pack[m + i, 1] = vel[i, 0], vel[i, 1]
    pack[2 * m, 0], pack[2 * m, 1] = cen[0], cen[1]
    pack[2 * m + 1, 0], pack[2 * m + 1, 1] = sl_row[0], sl_row[1]
    sx, sy = x[a, 0], x[a, 1]
    gaps = detect_gaps(ring[a], sx, sy, cos_t, sin_t, max_range, h_open)
    if seen_w > 0.0:
        keep = np.ones(gaps.shape[0], dtype=np.bool_)
        seen = seen_passages(gaps, ring[a], sx, sy, cos_t, sin_t, seen_depth, max_range)
        k = 0
        for j in range(gaps.shape[0]):
            keep[j] = gaps[j, GAP_W] >= seen_w or seen[j]
            k += keep[j]
        if k < gaps.shape[0]:
            kept = np.empty((k, gaps.shape[1]))
            k = 0
            for j in range(gaps.shape[0]):
                if keep[j]:
                    kept[k] = gaps[j]
                    k += 1
            gaps = kept
    rows = _filter_gaps(gaps, sx, sy, c[4], c[5], c[6], c[7], ring[a], sx, sy, cos_t, sin_t, cen[0], cen[1],
                        c[8], c[9], c[10] > 0.5, c[11], c[12], c[13])
    for j in range(rows.shape[0]):
        for q in range(8):
            rows_out[j, q] = rows[j, q]
    clear = np.inf
    for j in members:
        clear = min(clear, ring_min[j])
    return rows.shape[0], clear


def split_paths(rep: Report, goal: np.ndarray, ring: np.ndarray, w_split: float, rho_vis: float,
                max_range: float) -> list[Corridor]:
    """The split paths n_c counts (eq. 13): reported corridors at least ``w_split`` wide whose
    mouth is no farther from the goal than the sub-swarm's centroid and whose exit is in view of
    the subleader's ``ring``. A wider gap seen behind the swarm -- the bay it has just crossed,
    seen back through the gate it is threading -- does not lead to the target, and a sub-swarm
    sent there turned back through the gate (alternating 4.5 / 5 m gates: Y 0.3 / 0.7 with such
    splits, 1 / 1 with none)."""
    gx, gy = float(goal[0]), float(goal[1])
    cx, cy = rep.pack.centroid.tolist()
    d0 = math.hypot(cx - gx, cy - gy)
    sx, sy = rep.pack.subleader_position.tolist()
    return [c for c in rep.corridors if _leads_on(c, gx, gy, d0, ring, sx, sy, w_split, rho_vis, max_range)]


def _leads_on(c: Corridor, gx: float, gy: float, d0: float, ring: np.ndarray, sx: float, sy: float,
              w_split: float, rho_vis: float, max_range: float) -> bool:
    """:func:`split_paths`' test of one corridor: at least ``w_split`` wide, its mouth no farther
    from the goal (gx, gy) than the centroid (``d0``), its exit in view of the subleader at (sx, sy)."""
    if c.width < w_split:
        return False
    mx, my = c.mid.tolist()
    return math.hypot(mx - gx, my - gy) <= d0 and (c.direct or in_view(ring, sx, sy, c.target, rho_vis, max_range))


def decision_state(h, step: Step) -> DecisionState:
    """z(k) of eq. (18) from the reports alone (n_c: :func:`split_paths`, counted in one pass per
    report with the centroid's goal distance of eq. (19) computed once)."""
    p = h.params
    k, reports = step.k, step.reports
    ids = sorted(reports)
    gx, gy = float(h.goal[0]), float(h.goal[1])
    w_split, rho_vis, max_range = p.core.w_split, p.core.rho_vis, p.paper.lidar_range
    cents, d_goal, widths, n_c = [], [], [], 0
    for s in ids:
        rep = reports[s]
        cx, cy = rep.pack.centroid.tolist()
        d0 = math.hypot(cx - gx, cy - gy)
        cents.append((cx, cy))
        d_goal.append(d0)
        sx, sy = rep.pack.subleader_position.tolist()
        ring = step.ring[rep.pack.subleader]
        n = 0
        for c in rep.corridors:
            widths.append(c.width)
            n += _leads_on(c, gx, gy, d0, ring, sx, sy, w_split, rho_vis, max_range)
        n_c = max(n_c, n)
    S = len(ids)
    n_near = sum(d < p.paper.r_merge for d in d_goal)  # eq. (15)
    d_swarm_min = math.inf
    for a in range(S):  # eq. (14)
        for b in range(a + 1, S):
            d_swarm_min = min(d_swarm_min, math.hypot(cents[a][0] - cents[b][0], cents[a][1] - cents[b][1]))
    # eq. (13) reads the global centroid's distance to the goal only when S = 1, where the global
    # centroid of eq. (2) is the one sub-swarm's (split_feasible is False for S > 1 whatever it is)
    d_all = math.hypot(cents[0][0] - gx, cents[0][1] - gy) if S == 1 else math.inf
    can_split = split_feasible(S, n_c, k, h.k_last, h.cd_steps, d_all, p.paper.r_merge)
    can_merge = merge_feasible(S, n_near, d_swarm_min, p.paper.d_merge)
    return DecisionState(
        k=int(k), dt=p.paper.dt, S=S, n_c=int(n_c), w_max=float(max(widths)) if widths else 0.0,
        w_min=float(min(widths)) if widths else 0.0, d_goal_avg=sum(d_goal) / S, n_near=n_near,
        d_swarm_min=d_swarm_min, can_split=bool(can_split), can_merge=bool(can_merge),
    )
