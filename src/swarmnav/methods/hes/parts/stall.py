"""Stall planner (ours, beyond the paper; switch ``stall_plan``): when a sub-swarm stops making
progress, its route follows a path planned on the map of the returns its rings have seen.

The paper's planner is reactive: each step it picks one of the corridors the subleader's ring
shows. Where those corridors are pockets (a row of discs whose visible gaps close behind) and the
way through is a chain of 1-2 m gaps, that choice never commits and the swarm mills in front of
the first row. :class:`StallPlanner` keeps a map of the returns (``plan.mark_hits``); a sub-swarm
whose most advanced member has not come ``plan_progress`` closer to the goal for ``plan_stall`` s
(in encircle mode: whose farthest member has not) engages it for good, and then

- its route and corridor target come from the path down the cost-to-go field of the map
  (hook ``plan``), a narrow place on it being a throat (a passage at once, with passage mode);
- each member whose slot is out of sight, or which is in or entering a narrow place of its own
  way down the field, takes the point ``plan_look`` down that field as slot and c_s (hook
  ``steer``), with the passage-mode safety distance there when passage mode is on.

Parameters: the ``plan_*`` fields of :class:`HesParams`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from swarmnav.methods.base import check_map_bytes, format_extent
from swarmnav.methods.hes.corridors import Corridor
from swarmnav.methods.hes.forces import SIG_CENT, SIG_SL, SIG_SLOT
from swarmnav.methods.hes.hooks import Part
from swarmnav.methods.hes.parts.passage import throat_dsafe
from swarmnav.methods.hes.parts.plan import clearance, cost_to_go, descend, lookahead, mark_hits, nearest_reachable
from swarmnav.methods.hes.step import NEVER


#: Bytes a cell of the map takes while the planner is engaged: the map (1), its clearance (8) and
#: the distance transform computing it (feature indices 8, mask 1, distances 8), the cell costs
#: (8), the cost-to-go and the previous one (8 + 8), Dijkstra's flags (2) and its heap (8 entries
#: of 16 B a cell, allocated whole by plan.cost_to_go)
BYTES_PER_CELL = 1 + 8 + 17 + 8 + 16 + 2 + 128


def map_bytes(lo: np.ndarray, hi: np.ndarray, cell: float) -> float:
    """Memory [B] the stall planner's map of the box ``lo``-``hi`` [m] takes at ``cell`` [m]."""
    return float(np.prod(np.ceil((np.asarray(hi) - lo) / cell))) * BYTES_PER_CELL


@dataclass(slots=True)
class Progress:
    """The stall planner's memory of one sub-swarm."""

    prog_d: float = math.inf  # closest approach of any member to the goal so far [m] ...
    prog_step: int | None = None  # ... and the step it last improved by plan_progress
    planned: bool = False  # engaged (the route follows the planned path)
    path: np.ndarray | None = None  # (K, 2) planned path [m] ...
    path_clr: np.ndarray | None = None  # ... its clearance from the returns seen [m] ...
    path_arc: np.ndarray | None = None  # ... and its arc length from its start [m]
    path_step: int = NEVER  # step of the last plan
    tail_d: float = math.inf  # encircle mode: farthest member's goal distance [m] ...
    tail_step: int | None = None  # ... and the step it last improved by plan_progress


class StallPlanner(Part):
    """The stall planner (see the module docstring)."""

    name = "stall"

    def __init__(self, p, narrow_relief: bool):
        self.p = p
        self.narrow_relief = narrow_relief  # passage mode is on: narrow places get its safety distance
        self.w_passage = 2.0 * p.paper.d_safe + max(p.passage.band, 2.0 * p.passage.margin)

    def reset(self, hes, positions):
        p = self.p
        self.h = hes
        self.mem = {0: Progress()}
        goal = hes.goal
        # the map of the returns every ring has seen, over the start/goal box + margin
        lo = np.minimum(positions.min(axis=0), goal) - p.stall.margin
        hi = np.maximum(positions.max(axis=0), goal) + p.stall.margin
        check_map_bytes("hes", f"the stall planner's map of the {format_extent(lo, hi)} box round start and goal "
                        f"at {p.stall.cell:g} m cells", map_bytes(lo, hi, p.stall.cell), p.stall.max_map_bytes,
                        "stall.max_map_bytes", "use a coarser stall.cell, a nearer goal or stall.on=false")
        shape = np.ceil((hi - lo) / p.stall.cell).astype(int)
        self.map0 = lo
        self.occ = np.zeros((int(shape[1]), int(shape[0])), dtype=np.bool_)
        self.ctg_step = NEVER
        # the field is read at the agents' cells (and descended from there) until its next update:
        # Dijkstra stops once it is exact for every cell an agent can reach before then, plus the
        # look-ahead and the start search of a blocked centroid (d_safe), at the dearest cost per metre
        c_max = 1.0 + p.stall.weight * max(p.paper.d_safe - p.stall.clear, 0.0) / p.stall.clear
        self.slack = c_max * (p.safety.v_cap_frac * p.core.v_s * p.stall.every + p.stall.look + p.paper.d_safe)

    def engaged(self, sid: int) -> bool:
        """The planner is engaged for sub-swarm ``sid``."""
        return self.mem[sid].planned

    def observe(self, step):
        p = self.p
        if step.k % p.stall.map_every == 0 or any(m.planned for m in self.mem.values()):
            mark_hits(self.occ, step.ring, step.x, self.h.cos, self.h.sin, p.paper.lidar_range, self.map0[0],
                      self.map0[1], p.stall.cell)

    def split(self, old, new, k):
        del self.mem[old]
        for sid in new:
            self.mem[sid] = Progress()

    def merge(self, keep, drop):
        del self.mem[drop]

    # ------------------------------------------------------------ route
    def encircle(self, step, sub, rep):
        """In encircle mode the head is at the goal, but a member farther than ``r_out`` from it
        that has not come ``plan_progress`` closer for ``plan_stall`` s (a tail left behind a gap)
        engages the planner, so that the members cut off from their ring slots follow the field."""
        p, mem, k = self.p, self.mem[sub.sid], step.k
        mem.prog_step = None  # the head's progress is counted in navigate mode only
        dmax = goal_range(rep.pack.positions, self.h.goal)[1]
        if mem.tail_step is None or dmax <= p.paper.r_out or dmax < mem.tail_d - p.stall.progress:
            mem.tail_d, mem.tail_step = dmax, k
        if not mem.planned and (k - mem.tail_step) * p.paper.dt >= p.stall.time:
            mem.planned = True
            self.h.stats["plan_engaged"] += 1
        if mem.planned:
            self.field(k, step.x)

    def plan(self, step, sub, rep, cent):
        """The route and corridor target from the planned path, or None while the sub-swarm makes
        progress. The path (``plan.cost_to_go`` from the goal, descended from the cell of
        ``cent``) is replanned every ``plan_every`` s; the target is the path point ``plan_look``
        past the path point nearest ``cent`` (at least ``through`` past the narrow place below, if
        narrow); the route is the narrowest place of the next ``lead + plan_look`` m of path as a
        throat (mid, exit direction = path direction, width = twice its clearance)."""
        p, mem, k = self.p, self.mem[sub.sid], step.k
        mem.tail_step = None  # the tail's progress is counted in encircle mode only
        dmin = goal_range(rep.pack.positions, self.h.goal)[0]
        if mem.prog_step is None or dmin < mem.prog_d - p.stall.progress:
            mem.prog_d, mem.prog_step = min(dmin, mem.prog_d), k
        if not mem.planned:
            if (k - mem.prog_step) * p.paper.dt < p.stall.time:
                return None
            mem.planned = True
            self.h.stats["plan_engaged"] += 1
        if mem.path is None or (k - mem.path_step) * p.paper.dt >= p.stall.every - 1e-9:
            self.replan(mem, k, step.x, cent)
        if mem.path is None or len(mem.path) < 2:
            return None
        path, clr, arc = mem.path, mem.path_clr, mem.path_arc
        i0 = int(np.argmin(np.sum((path - cent) ** 2, axis=1)))
        ie = min(int(np.searchsorted(arc, arc[i0] + p.stall.look + p.core.lead)), len(path) - 1)
        ib = i0 + int(np.argmin(clr[i0:ie + 1]))
        d = path[min(ib + 2, len(path) - 1)] - path[max(ib - 2, 0)]
        nrm = d / max(math.hypot(d[0], d[1]), 1e-9)
        w = 2.0 * float(clr[ib])
        # the target leads `through` past a narrow place ahead, as the reactive target leads past a throat
        look = max(arc[i0] + p.stall.look, arc[ib] + p.core.through if w < self.w_passage else 0.0)
        it = min(int(np.searchsorted(arc, look)), len(path) - 1)
        route = Corridor(mid=path[ib].copy(), normal=nrm, width=w, target=path[ib] + p.core.through * nrm,
                         cost=float(arc[-1] - arc[i0]))
        return route, path[it].copy()

    def field(self, k: int, x: np.ndarray, now: bool = False) -> None:
        """The clearance and cost-to-go fields of the map, recomputed at most once a step, and
        otherwise every ``plan_every`` s (or at once with ``now``); exact wherever the agents at
        ``x`` can read it before the next update (``slack``)."""
        p = self.p
        if self.ctg_step == k or (not now and (k - self.ctg_step) * p.paper.dt < p.stall.every - 1e-9):
            return
        self.clr = clearance(self.occ, p.stall.cell)
        g = np.floor((self.h.goal - self.map0) / p.stall.cell).astype(int)
        need = np.floor((x - self.map0) / p.stall.cell).astype(np.int64)[:, ::-1].copy()
        self.ctg = cost_to_go(self.clr, int(g[1]), int(g[0]), p.stall.cell, p.stall.clear, p.paper.d_safe,
                              p.stall.weight, need, self.slack)
        self.ctg_step = k

    def replan(self, mem: Progress, k: int, x: np.ndarray, start: np.ndarray) -> None:
        """The path from ``start`` to the goal on the map of returns, its clearance and arc length."""
        p = self.p
        self.field(k, x, now=True)
        mem.path_step = k
        ny, nx = self.ctg.shape
        c = np.floor((start - self.map0) / p.stall.cell).astype(int)
        si, sj = int(np.clip(c[1], 0, ny - 1)), int(np.clip(c[0], 0, nx - 1))
        if not np.isfinite(self.ctg[si, sj]):
            near = nearest_reachable(self.ctg, si, sj, int(round(p.paper.d_safe / p.stall.cell)), p.stall.cell)
            if near is None:
                mem.path = mem.path_clr = None
                return
            si, sj = near
        cells = descend(self.ctg, si, sj, nx * ny)
        mem.path = self.map0 + (cells[:, ::-1] + 0.5) * p.stall.cell
        mem.path_clr = self.clr[cells[:, 0], cells[:, 1]]
        mem.path_arc = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(mem.path, axis=0).T))])

    # ------------------------------------------------------------ control
    def steer(self, step):
        """Per member of an engaged sub-swarm: a member whose slot is out of sight (segment
        blocked) or which is in or entering a narrow place of its own way down the field
        (half-width below w_passage / 2 within ``passage_len``) takes as slot and centering target
        the point ``plan_look`` down that field, with its blocked couplings off; in a narrow place
        (passage mode on) the safety distance min(d_safe - passage_relief, half-width -
        passage_margin) of eq. (36), and no push back against its way.

        Why: a formation slot, the subleader and the centroid pull a member straight at them,
        through the discs between; in a forest the members that had not followed the head
        through the first gap stayed in pockets (density 0.25, seed 2)."""
        p, h, x = self.p, self.h, step.x
        if self.ctg_step == NEVER or not any(mem.planned for mem in self.mem.values()):
            return  # the common case: the planner is not engaged
        act = np.zeros(h.n, dtype=np.bool_)
        for s, mem in self.mem.items():
            if mem.planned:
                act |= h.labels == s
        if not np.count_nonzero(act):
            return
        idx = np.flatnonzero(act)
        pt, half = lookahead(self.ctg, self.clr, np.ascontiguousarray(x[idx]), self.map0[0], self.map0[1],
                             p.stall.cell, p.stall.look, p.passage.length)
        self._follow(step, idx, pt, half)

    def _follow(self, step, idx, pt, half) -> None:
        """:meth:`steer` for the members ``idx`` (ascending) of engaged sub-swarms, with their
        look-ahead points ``pt`` (M, 2) [m] and narrow half-widths ``half`` (M,) [m]."""
        p, x = self.p, step.x
        narrow = 2.0 * half < self.w_passage
        b = step.blocked[idx]
        use = (b[:, SIG_SLOT] | narrow) & np.isfinite(half)
        i = idx[use]
        step.slot[i] = step.wp[i] = pt[use]
        sig = step.sig
        sig[i, SIG_SLOT] = 1.0
        sig[i, SIG_SL] = np.where(b[use, SIG_SL], 0.0, sig[i, SIG_SL])
        sig[i, SIG_CENT] = np.where(b[use, SIG_CENT], 0.0, sig[i, SIG_CENT])
        if self.narrow_relief:
            j = idx[use & narrow]
            step.dsafe[j] = np.minimum(step.dsafe[j], throat_dsafe(half[use & narrow], p.paper.d_safe, p.passage.margin,
                                                                   p.passage.relief))
            u = pt[use & narrow] - x[j]
            un = np.hypot(*u.T)
            ok = un > 1e-6
            step.exit_dir[j[ok]] = u[ok] / un[ok, None]
            step.exit_free[j[ok]] = True


    # ------------------------------------------------------------ on a network (docs/methods/hes-network.md)
    def field_rows(self, x: np.ndarray, labels: np.ndarray):
        """What the leader's plan carries of the field: for each member of an engaged sub-swarm
        (``labels``) the look-ahead point (N, 2) [m] and narrow half-width (N,) [m] of
        :meth:`steer`, from the leader's picture ``x`` of it (NaN for the others); None while the
        planner is engaged for no sub-swarm."""
        p = self.p
        if self.ctg_step == NEVER or not any(mem.planned for mem in self.mem.values()):
            return None
        act = np.zeros(len(x), dtype=np.bool_)
        for s, mem in self.mem.items():
            if mem.planned:
                act |= labels == s
        idx = np.flatnonzero(act)
        pt, half = np.full((len(x), 2), np.nan), np.full(len(x), np.nan)
        pt[idx], half[idx] = lookahead(self.ctg, self.clr, np.ascontiguousarray(x[idx]), self.map0[0],
                                       self.map0[1], p.stall.cell, p.stall.look, p.passage.length)
        return pt, half

    def steer_known(self, step, net):
        """:meth:`steer` on a network: a member of an engaged sub-swarm follows the look-ahead its
        plan carries (the leader's field read at its picture of the member); the narrow place's
        safety distance and way out are taken from its own position."""
        from swarmnav.methods.hes.networked import by_plan

        for q, rows in by_plan(net.plans):
            if q.field_half is None:
                continue
            r = rows[~np.isnan(q.field_half[rows])]
            if len(r):
                self._follow(step, r, q.field_pt[r], q.field_half[r])


@njit(cache=True)
def goal_range(pos, goal):
    """The nearest and farthest distance [m] of the rows of ``pos`` (m >= 1, 2) from ``goal``,
    ``np.hypot`` row by row."""
    lo, hi = np.inf, -np.inf
    for i in range(pos.shape[0]):
        d = np.hypot(pos[i, 0] - goal[0], pos[i, 1] - goal[1])
        lo = min(lo, d)
        hi = max(hi, d)
    return lo, hi
