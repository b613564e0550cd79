"""``hes``: the Hierarchical Embodied Swarm method (Wu & Wei, Drones 2026), wired from pure parts.

Per step (paper Section 4.4, "At each discrete step"):

1. sense: every agent's fused LiDAR ring (eq. 8-9);
2. report: each subleader sends its Pack P_s(k) (eq. 3) and the corridors its ring shows
   (Section 3.2); the leader's planner reads only these reports;
3. decide: z(k) (eq. 18) -> decision source -> Pi_feas (eq. 22) -> execute split / merge / keep;
4. modes (eq. 12), waypoints c_s(k) along the chosen corridor, formation references (eq. 23),
   dynamic follower reassignment (eq. 41);
5. control: the eight force terms (eq. 38), safety stack, saturation (eq. 39).

The class holds the planner's memory (partition, waypoints, modes, cooldowns) and calls the
pure functions of ``forces``, ``corridors``, ``decision``, ``hierarchy`` and ``formation``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from swarmnav.dynamics import DampedDoubleIntegrator
from swarmnav.llm import decision_source
from swarmnav.methods.base import Observation
from swarmnav.methods.hes import forces as F
from swarmnav.methods.hes.corridors import (
    GAP_W,
    Corridor,
    corridors_toward,
    detect_gaps,
    direct_corridor,
    free_points,
    newest_visible,
    segment_clear,
    seen_passages,
)
from swarmnav.methods.hes.decision import (
    ENCIRCLE,
    NAVIGATE,
    DecisionSource,
    DecisionState,
    Proposal,
    RulePolicy,
    merge_feasible,
    project,
    split_feasible,
    target_proximity,
    task_mode,
)
from swarmnav.methods.hes.formation import assign_slots, hex_template, ring_slots
from swarmnav.methods.hes.hierarchy import (
    Report,
    check_partition,
    choose_subleader,
    make_pack,
    merge_pair,
    reassign,
    split_members,
)
from swarmnav.methods.hes.params import HesParams
from swarmnav.methods.hes.passage import passage_dsafe, throat_dsafe
from swarmnav.methods.hes.plan import clearance, cost_to_go, descend, lookahead, mark_hits, nearest_reachable
from swarmnav.params import build
from swarmnav.sensing import PreparedGeometry
from swarmnav.sensing import ray_table as _ray_table
from swarmnav.world.scenario import Scenario

_NEVER = -(10**9)
_RING_ANGLES = np.linspace(0.0, 2 * math.pi, 72, endpoint=False)  # encircle slot candidates (5 deg)
_SLOT_REFRESH = 10  # steps between re-solving the slot assignment (ours: 1 s)
_RHO_VIS = 0.4  # [m] half-width of the straight line from the centroid to a throat that must be free (ours)
_COMMIT_S = 20.0  # [s] a split's corridor assignment lapses after this long if the throat is not passed (ours)
_HOLD_S = 15.0  # [s] longest a sub-swarm waits at a throat for its last members (ours)
_PASSAGES = 3  # passage mode: throats remembered per sub-swarm (ours; the current one and the two before)
_STRAY = 4.0  # [m] a subleader farther than this from its sub-swarm's centroid hands over its role (ours)
_TRAIL_EVERY = 10  # steps between two samples of the members' trail (ours: 1 s)
_TRAIL_LEN = 200  # trail samples kept (ours: 200 s, longer than a run)
_TRAIL_REACH = 10.0  # [m] a cut-off member looks for trail points this close (ours: half R_L)
_CUT_S = 2.0  # [s] a member cut off from its sub-swarm this long follows the trail (ours: not a member briefly behind a corner)
_MAP_EVERY = 5  # stall planner: steps between two updates of the map of returns (ours: 0.5 s; every step while engaged)
_MAP_MARGIN = 20.0  # [m] stall planner: the map covers the box of the start and the goal plus R_L (ours)


@dataclass(slots=True)
class Passage:
    """Passage mode (ours): a narrow throat a sub-swarm was routed through."""

    throat: Corridor  # the last detection of the throat while it was the route
    step: int  # last step it was the route
    crossed: np.ndarray  # (N,) bool: the agent has been beyond the throat (along its normal)


@dataclass(slots=True)
class SubSwarm:
    """Planner memory of one sub-swarm (mutable; owned by :class:`Hes`)."""

    sid: int
    subleader: int
    waypoint: np.ndarray  # c_s(k) [m]
    mode: int = NAVIGATE
    route: Corridor | None = None  # corridor currently followed
    committed: bool = False  # assigned by a split: follow it until its throat is passed
    commit_step: int = 0  # step of the split that assigned the corridor
    hold_step: int | None = None  # step since which the route is held for members still in front of its throat
    squeeze: float = 1.0  # lateral factor of the template in a narrow corridor (longitudinal: 1 / squeeze)
    heading: np.ndarray = field(default_factory=lambda: np.array([1.0, 0.0]))  # formation axis (unit)
    slot_members: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))  # agents (sorted) ...
    slot_index: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))  # ... and their r_i
    slot_step: int = _NEVER  # step of the last slot assignment
    ring_offsets: np.ndarray | None = None  # encircle slots relative to the goal
    passages: list = field(default_factory=list)  # passage mode: list[Passage], oldest first
    narrow_steps: int = 0  # passage mode: consecutive steps the route was a narrow throat with no wider candidate
    chained: bool = False  # passage mode: the sub-swarm has been routed through a passage
    prog_d: float = math.inf  # stall planner: closest approach of any member to the goal so far [m] ...
    prog_step: int | None = None  # ... and the step it last improved by plan_progress
    planned: bool = False  # stall planner: engaged (the route follows the planned path)
    path: np.ndarray | None = None  # stall planner: (K, 2) planned path [m] ...
    path_clr: np.ndarray | None = None  # ... its clearance from the returns seen [m] ...
    path_arc: np.ndarray | None = None  # ... and its arc length from its start [m]
    path_step: int = _NEVER  # stall planner: step of the last plan
    tail_d: float = math.inf  # stall planner, encircle mode: farthest member's goal distance [m] ...
    tail_step: int | None = None  # ... and the step it last improved by plan_progress


class Hes:
    """The HES method (see module docstring); parameters: :class:`HesParams`."""

    name = "hes"
    dims = (2,)  # planar, as its paper: a 3-D scene is flown in its horizontal slice at z_fly

    def __init__(self, **overrides: Any):
        self.params = build(HesParams, overrides, context="hes")
        self.dt = self.params.dt
        self.dynamics = DampedDoubleIntegrator()  # eq. (5)-(7): m = 5 kg, c_d = 0.5, inverse model
        self._gains = F.gain_vector(self.params)
        self._cos, self._sin = _ray_table(self.params.n_rays)
        self._source_override: DecisionSource | None = None
        # passage mode: a throat narrower than _w_wide [m] is narrow for gap detection and the corridor
        # filter (w/2 - margin < d_safe); one narrower than _w_passage can become a passage (the band
        # the paper's law leaves in it, w - 2 d_safe, is under passage_band)
        self._w_wide = 2.0 * (self.params.d_safe + self.params.passage_margin)
        self._w_passage = 2.0 * self.params.d_safe + max(self.params.passage_band, 2.0 * self.params.passage_margin)

    def use_source(self, source: DecisionSource) -> Hes:
        """Decide structure with ``source`` instead of the rule policy (from the next reset)."""
        self._source_override = source
        return self

    # ------------------------------------------------------------------ lifecycle
    def reset(self, scenario: Scenario, positions: np.ndarray, velocities: np.ndarray,
              rng: np.random.Generator) -> None:
        p = self.params
        self.scenario = scenario
        self.goal = scenario.goal_array.astype(float)
        self.geom = scenario.geometry
        self._obstacles = PreparedGeometry(self.geom)  # the per-step LiDAR and line-of-sight queries
        n = len(positions)
        self.n = n
        self.source: DecisionSource = self._source_override or decision_source(p, RulePolicy(p.d_merge, p.t_cd), project)
        c = positions.mean(axis=0)
        self.leader = int(np.argmin(np.sum((positions - c) ** 2, axis=1)))  # one leader, eq. (1) roles
        self.labels = np.zeros(n, dtype=np.int64)
        self.subs: dict[int, SubSwarm] = {0: SubSwarm(0, self.leader, c.copy())}
        self._next_id = 1
        self.k_last: int | None = None
        self.last_move = np.full(n, _NEVER, dtype=np.int64)
        self._cd_steps = int(round(p.t_cd / p.dt))
        self._ra_steps = int(round(p.tau_ra / p.dt))
        self.stats = {"splits": 0, "merges": 0, "reassigned": 0, "projected_to_keep": 0, "plan_engaged": 0}
        self.last_z: DecisionState | None = None
        self.last_reports: dict[int, Report] = {}
        self._qidx = np.full(n, -1, dtype=np.int64)  # passage mode: queued members (see _queue)
        self._qtgt = np.zeros((n, 2))
        self._trail = np.zeros((_TRAIL_LEN, n, 2))  # members' positions every _TRAIL_EVERY steps (trail_follow)
        self._trail_n = 0
        self._blocked = np.zeros((n, 4), dtype=np.bool_)  # segment to slot / nn / subleader / centroid blocked
        self.last_cut = np.zeros(n, dtype=np.bool_)  # trail_follow: members following the trail this step
        self._cut_steps = np.zeros(n, dtype=np.int64)  # trail_follow: consecutive steps cut off from the sub-swarm
        if p.stall_plan:  # stall planner: map of the returns every ring has seen, over start/goal box + margin
            lo = np.minimum(positions.min(axis=0), self.goal) - _MAP_MARGIN
            hi = np.maximum(positions.max(axis=0), self.goal) + _MAP_MARGIN
            shape = np.ceil((hi - lo) / p.plan_cell).astype(int)
            self._map0 = lo
            self._occ = np.zeros((int(shape[1]), int(shape[0])), dtype=np.bool_)
            self._ctg_step = _NEVER
            # the field is read at the agents' cells (and descended from there) until its next update:
            # Dijkstra stops once it is exact for every cell an agent can reach before then, plus the
            # look-ahead and the start search of a blocked centroid (d_safe), at the dearest cost per metre
            c_max = 1.0 + p.plan_weight * max(p.d_safe - p.plan_clear, 0.0) / p.plan_clear
            self._slack = c_max * (p.v_cap_frac * p.v_s * p.plan_every + p.plan_look + p.d_safe)

    def summary(self) -> dict[str, float]:
        out = {"llm_calls": 0.0, "llm_fallback_used": 0.0}
        out.update({f"hes_{k}": float(v) for k, v in self.stats.items()})
        if hasattr(self.source, "summary"):
            out.update({k: float(v) for k, v in self.source.summary().items()})
        return out

    def artifacts(self) -> dict[str, str]:
        """Extra run files: ``llm_transcript.jsonl`` when an LLM decides (docs/llm.md)."""
        return self.source.artifacts() if hasattr(self.source, "artifacts") else {}

    # ------------------------------------------------------------------ one step
    def act(self, obs: Observation, rng: np.random.Generator) -> tuple[np.ndarray, dict]:
        p = self.params
        k = obs.step
        x = np.ascontiguousarray(obs.positions, dtype=np.float64)
        v = np.ascontiguousarray(obs.velocities, dtype=np.float64)
        ring = self._sense(x)
        self._k = k
        if p.trail_follow and k % _TRAIL_EVERY == 0:
            if self._trail_n == _TRAIL_LEN:
                self._trail[:-1] = self._trail[1:]
                self._trail_n -= 1
            self._trail[self._trail_n] = x
            self._trail_n += 1
        events: list[dict] = []
        if p.stall_plan and (k % _MAP_EVERY == 0 or any(sub.planned for sub in self.subs.values())):
            mark_hits(self._occ, ring, x, self._cos, self._sin, p.lidar_range, self._map0[0], self._map0[1],
                      p.plan_cell)

        self._reelect(x)
        # 2. reports from subleaders, 3. decision through Pi_feas
        reports = {s: self._report(s, x, v, ring) for s in sorted(self.subs)}
        z = self.decision_state(k, reports)
        prop = self.source.propose(z, k)
        action = project(prop.action, z)
        if action != prop.action:
            self.stats["projected_to_keep"] += 1
        if action == "split":
            events.append(self._split(x, reports, prop))
        elif action == "merge":
            events.append(self._merge(x, reports, prop))
        if action != "keep":
            self.k_last = k
            reports = {s: self._report(s, x, v, ring) for s in sorted(self.subs)}
        self.last_z, self.last_reports = z, reports

        # 4. modes, waypoints, reassignment, references
        self._qidx, _ = self._queue(x)
        for s, sub in self.subs.items():
            self._navigate(sub, reports[s], x, k)
        self._reassign(x, k)
        self._qidx, self._qtgt = self._queue(x)
        slot, speed = self._references(x, k)

        # 5. control
        a = self._control(x, v, ring, slot, speed)
        return a, {"labels": self.labels.copy(), "events": events}

    # ------------------------------------------------------------------ perception and reports
    def _sense(self, x: np.ndarray) -> np.ndarray:
        p = self.params
        if self.geom.is_empty:
            ring = np.full((len(x), p.n_rays), p.lidar_range)
        else:  # = swarmnav.sensing.lidar_ring(geom, x, n_rays, R_L)
            ring = self._obstacles.lidar_into(x, self._cos, self._sin, p.lidar_range, np.empty((len(x), p.n_rays)))
        self._ring = ring  # read by the corridor choice and the encircle slots of this step
        return ring

    def _reelect(self, x: np.ndarray) -> None:
        """Hand a sub-swarm's subleader role to the member nearest its centroid when the current
        subleader has strayed (farther than ``_STRAY`` from the centroid, or cut off from it by an
        obstacle): the subleader's ring is the sub-swarm's view of the corridors (ours; the
        paper fixes no rule for who leads a sub-swarm)."""
        ids = sorted(self.subs)
        col = np.searchsorted(np.asarray(ids), self.labels)
        cents = F.group_centroids(x, col, len(ids))
        sl = np.array([self.subs[s].subleader for s in ids])
        far = np.hypot(*(x[sl] - cents).T) > _STRAY
        if not self.geom.is_empty:
            far |= self._obstacles.blocked_into(np.ascontiguousarray(x[sl]), cents, np.empty(len(ids), dtype=np.bool_))
        for j in np.flatnonzero(far):
            members = np.flatnonzero(col == j)
            self.subs[ids[j]].subleader = int(members[np.argmin(np.sum((x[members] - cents[j]) ** 2, axis=1))])
        if self.params.passage_mode:
            # a subleader queued behind a throat cannot see the head's next corridor: hand the role
            # to the head member nearest the head's centroid
            for j, s in enumerate(ids):
                sub = self.subs[s]
                members = np.flatnonzero(col == j)
                head = members[self._qidx[members] < 0]
                if self._qidx[sub.subleader] >= 0 and len(head):
                    hc = x[head].mean(axis=0)
                    sub.subleader = int(head[np.argmin(np.sum((x[head] - hc) ** 2, axis=1))])

    def _report(self, s: int, x: np.ndarray, v: np.ndarray, ring: np.ndarray) -> Report:
        """Subleader s's report: its Pack and the corridors toward the goal its ring shows."""
        p = self.params
        sub = self.subs[s]
        members = np.flatnonzero(self.labels == s)
        pack = make_pack(s, sub.subleader, members, x, v)
        a = sub.subleader
        ra, sx, sy = ring[a], x[a, 0], x[a, 1]
        gaps = detect_gaps(ra, sx, sy, self._cos, self._sin, p.lidar_range, p.h_open)
        narrow = gaps[:, GAP_W] < self._w_wide
        if p.passage_mode and narrow.any():  # a narrow opening must be a seen passage, not a concave corner
            keep = ~narrow
            keep[narrow] = seen_passages(gaps[narrow], ra, sx, sy, self._cos, self._sin, p.gap_depth, p.lidar_range)
            gaps = gaps[keep]
        # candidates toward the goal whose throat is reachable straight from the centroid
        cors = corridors_toward(gaps, x[a], self.goal, w_pass=p.w_pass, toward_deg=p.toward_deg, through=p.through,
                                ring=ra, sensor=x[a], origin=pack.centroid, rho_vis=_RHO_VIS, max_range=p.lidar_range,
                                rays=(self._cos, self._sin), approach=p.passage_len if p.passage_mode else 0.0,
                                approach_w=self._w_wide)
        if p.passage_mode and sub.passages:
            # a corridor behind a passage the subleader has crossed (a bay seen back through the gap)
            # leads back along the chain, not toward the goal
            crossed = [q.throat for q in sub.passages if q.crossed[a]]
            cors = [c for c in cors if c.direct or not any(
                float(np.dot(c.mid - t.mid, t.normal)) < 0.0 for t in crossed)]
        clr = ring[members].min(axis=1)
        if p.passage_mode and hasattr(self, "last_dsafe"):
            # members inside a passage's tube (or queued for one) do not slow the sub-swarm's cruise
            free = (self.last_dsafe[members] >= p.d_safe) & (self._qidx[members] < 0)
            clr = clr[free] if free.any() else clr
        return Report(pack, tuple(cors), float(clr.min()))

    def decision_state(self, k: int, reports: dict[int, Report]) -> DecisionState:
        """z(k) of eq. (18) from the reports alone."""
        p = self.params
        ids = sorted(reports)
        cents = np.array([reports[s].pack.centroid for s in ids])
        S = len(ids)
        d_goal = np.hypot(*(cents - self.goal).T)
        widths = [c.width for s in ids for c in reports[s].corridors]
        n_c = max(len(self._split_paths(reports[s])) for s in ids)
        n_near = int(np.sum(d_goal < p.r_merge))  # eq. (15)
        d_swarm_min = math.inf
        if S >= 2:  # eq. (14)
            diff = cents[:, None, :] - cents[None, :, :]
            dd = np.hypot(diff[..., 0], diff[..., 1])
            d_swarm_min = float(dd[np.triu_indices(S, 1)].min())
        n_all = sum(len(reports[s].pack.members) for s in ids)
        gbar = sum(reports[s].pack.positions.sum(axis=0) for s in ids) / n_all  # global centroid, eq. (2)
        can_split = split_feasible(S, n_c, k, self.k_last, self._cd_steps, float(np.hypot(*(gbar - self.goal))),
                                   p.r_merge)
        can_merge = merge_feasible(S, n_near, d_swarm_min, p.d_merge)
        return DecisionState(
            k=int(k), dt=p.dt, S=S, n_c=int(n_c), w_max=float(max(widths)) if widths else 0.0,
            w_min=float(min(widths)) if widths else 0.0, d_goal_avg=float(d_goal.mean()), n_near=n_near,
            d_swarm_min=d_swarm_min, can_split=bool(can_split), can_merge=bool(can_merge),
        )

    # ------------------------------------------------------------------ structural actions
    def _split_paths(self, rep: Report) -> list[Corridor]:
        """The split paths n_c counts (eq. 13): reported corridors at least ``w_split`` wide whose
        mouth is no farther from the goal than the sub-swarm's centroid. A wider gap seen behind
        the swarm -- the bay it has just crossed, seen back through the gate it is threading --
        does not lead to the target, and a sub-swarm sent there turned back through the gate
        (alternating 4.5 / 5 m gates: Y 0.3 / 0.7 with such splits, 1 / 1 with none)."""
        p = self.params
        d0 = float(np.hypot(*(rep.pack.centroid - self.goal)))
        sx, sy = rep.pack.subleader_position
        ring = self._ring[rep.pack.subleader]
        return [c for c in rep.corridors
                if c.width >= p.w_split and float(np.hypot(*(c.mid - self.goal))) <= d0
                and (c.direct or self._in_view(ring, sx, sy, c.target))]

    def _in_view(self, ring: np.ndarray, sx: float, sy: float, q: np.ndarray) -> bool:
        """The point ``q`` is seen from the sensor at ``(sx, sy)``: the ray toward it reaches at least
        to within ``_RHO_VIS`` of it (not occluded, not in an obstacle's shadow)."""
        dx, dy = q[0] - sx, q[1] - sy
        r = int(round(math.atan2(dy, dx) / (2.0 * math.pi) * len(ring))) % len(ring)
        return bool(ring[r] >= min(math.hypot(dx, dy) - _RHO_VIS, self.params.lidar_range))

    def _split(self, x: np.ndarray, reports: dict[int, Report], prop: Proposal) -> dict:
        """Split the single sub-swarm into one sub-swarm per split path (at most max_subswarms,
        each of at least min_size agents): corridors ranked by route cost, agents assigned by
        lateral order, the leader keeps its sub-swarm, new subleaders nearest their centroids."""
        p = self.params
        (s0,) = self.subs
        rep = reports[s0]
        members = rep.pack.members
        cors = self._split_paths(rep)
        m = max(2, min(len(cors), p.max_subswarms, len(members) // max(p.min_size, 1)))
        cors = cors[:m]
        cent = rep.pack.centroid
        heading = self.goal - cent
        heading = heading / max(np.hypot(*heading), 1e-9)
        groups = split_members(x, members, [c.mid - cent for c in cors], [min(c.width, 10.0) for c in cors],
                               heading, p.min_size)
        old = self.subs.pop(s0)
        for c, g in zip(cors, groups):
            if len(g) == 0:
                continue
            sid = s0 if self.leader in g else self._new_id()
            sl = choose_subleader(x, g, self.leader)
            self.labels[g] = sid
            wp = old.waypoint.copy() if sid == s0 else x[g].mean(axis=0)
            self.subs[sid] = SubSwarm(sid, sl, wp, mode=old.mode, route=c, committed=True, commit_step=self._k,
                                      squeeze=old.squeeze, heading=old.heading.copy(),
                                      passages=[Passage(q.throat, q.step, q.crossed.copy()) for q in old.passages])
        if s0 not in self.subs:  # leader-less split cannot happen, but keep ids consistent
            pass
        self.stats["splits"] += 1
        return {"action": "split", "source": prop.source, "reason": prop.reason,
                "agents": [int(i) for i in members], "into": len(self.subs)}

    def _merge(self, x: np.ndarray, reports: dict[int, Report], prop: Proposal) -> dict:
        """Merge the pair chosen by :func:`merge_pair`; the merged sub-swarm keeps the id and
        subleader of the leader's (else the larger) part."""
        p = self.params
        ids = sorted(self.subs)
        cents = np.array([reports[s].pack.centroid for s in ids])
        near = np.hypot(*(cents - self.goal).T) < p.r_merge
        a, b = merge_pair(cents, ids, near, p.d_merge)
        size = {s: int(np.count_nonzero(self.labels == s)) for s in (a, b)}
        keep, drop = (a, b)
        if self.subs[b].subleader == self.leader or (self.subs[a].subleader != self.leader and size[b] > size[a]):
            keep, drop = b, a
        agents = np.flatnonzero((self.labels == a) | (self.labels == b))
        self.labels[self.labels == drop] = keep
        gone = self.subs.pop(drop)
        kept = self.subs[keep]
        kept.waypoint = (size[keep] * kept.waypoint + size[drop] * gone.waypoint) / (size[a] + size[b])
        kept.committed = False
        kept.slot_step = _NEVER
        # passage mode: the merged sub-swarm keeps the passages of both parts (members in front of
        # a throat stay queued for it)
        kept.passages = sorted(gone.passages + kept.passages, key=lambda q: q.step)[-_PASSAGES:]
        kept.mode = min(kept.mode, gone.mode) if kept.mode != gone.mode else kept.mode
        self.stats["merges"] += 1
        return {"action": "merge", "source": prop.source, "reason": prop.reason,
                "agents": [int(i) for i in agents], "into": len(self.subs)}

    def _new_id(self) -> int:
        self._next_id += 1
        return self._next_id - 1

    # ------------------------------------------------------------------ navigation
    def _navigate(self, sub: SubSwarm, rep: Report, x: np.ndarray, k: int) -> None:
        """Task mode (eq. 12), corridor choice and waypoint c_s(k) of one sub-swarm."""
        p = self.params
        cent = rep.pack.centroid
        head = rep.pack.members[self._qidx[rep.pack.members] < 0]
        if 0 < len(head) < len(rep.pack.members):  # passage mode: the waypoint leads the members past the queue
            cent = x[head].mean(axis=0)
        sl = x[sub.subleader]
        delta = target_proximity(float(np.hypot(*(cent - self.goal))), float(np.hypot(*(sl - self.goal))))
        mode = task_mode(sub.mode, delta, p.r_in, p.r_out)
        if mode != sub.mode:
            sub.slot_step = _NEVER
            sub.ring_offsets = None
        sub.mode = mode
        if mode == ENCIRCLE:
            sub.waypoint = self.goal.copy()
            sub.prog_step = None  # stall planner: the head's progress is counted in navigate mode only ...
            if p.stall_plan:  # ... in encircle mode, the tail's
                self._tail_stall(sub, rep, x, k)
            for q in sub.passages:  # passage mode: members still crossing keep their queue until through
                q.crossed |= (x - q.throat.mid) @ q.throat.normal > 0.0
            return
        sub.tail_step = None  # stall planner: the tail's progress is counted in encircle mode only
        planned = self._planned(sub, rep, x, k, cent) if p.stall_plan else None
        route = self._choose_route(sub, rep, x, k) if planned is None else planned[0]
        sub.route = route
        if p.passage_mode:
            self._remember_passage(sub, route, rep, x, k)
        if planned is not None:
            target = planned[1]
        elif route is None:
            target = self.goal
        elif route.direct:
            target = route.target
        else:  # `through` metres past the throat, or past the centroid once that is beyond the throat
            along = max(float(np.dot(cent - route.mid, route.normal)), 0.0)
            target = route.mid + (along + p.through) * route.normal
            a = sub.subleader
            if p.passage_mode and route.width < self._w_wide and along <= 0.0 and not segment_clear(
                    self._ring[a], x[a, 0], x[a, 1], self._cos, self._sin, cent[0], cent[1], route.mid[0],
                    route.mid[1], _RHO_VIS, p.lidar_range):
                # the throat is reached through its mouth (see corridors_toward, approach)
                target = route.mid - p.passage_len * route.normal
        if p.adaptive and p.passage_mode and (sub.passages or sub.chained):
            # passage chain: a waypoint the subleader sees behind a wall (the head moved on through a
            # gap) restarts from the head's centroid; once the chain's passages have lapsed, from the
            # subleader (the centroid, with stragglers still in front of the last gate, can lie in
            # the wall itself: pushed off the wall's far side it would hold the head there for good)
            a = sub.subleader
            start = cent if sub.passages else x[a]
            if not segment_clear(self._ring[a], x[a, 0], x[a, 1], self._cos, self._sin, start[0], start[1],
                                 sub.waypoint[0], sub.waypoint[1], 0.2, p.lidar_range):
                sub.waypoint = start.copy()
        sub.chained = sub.chained or bool(sub.passages)
        if p.adaptive:
            # virtual leader: advance toward the target at the (adaptive) cruise speed ...
            step = self._cruise(rep) * p.dt
            d = target - sub.waypoint
            dn = math.hypot(d[0], d[1])
            sub.waypoint = target.copy() if dn <= step else sub.waypoint + d * (step / dn)
            # ... on a leash of length `lead` around the sub-swarm centroid
            off = sub.waypoint - cent
            on = math.hypot(off[0], off[1])
            if on > p.lead:
                sub.waypoint = cent + off * (p.lead / on)
        else:  # safety stack off: no regulation of the reference, c_s is the corridor target itself
            sub.waypoint = np.asarray(target, dtype=float).copy()
        w = route.width if route is not None else math.inf
        if p.adaptive:  # keep the waypoint off the walls the subleader sees
            a = sub.subleader
            clear = min(p.wp_clear, 0.5 * w)
            sub.waypoint = np.array(F.push_clear(sub.waypoint[0], sub.waypoint[1], self._ring[a], x[a, 0], x[a, 1],
                                                 self._cos, self._sin, clear, p.lidar_range, 3))
        # formation axis along the motion of c_s; squeeze across a corridor narrower than the formation
        h = target - sub.waypoint
        hn = math.hypot(h[0], h[1])
        if hn > 0.5:
            h = 0.8 * sub.heading + 0.2 * h / hn
            sub.heading = h / max(math.hypot(h[0], h[1]), 1e-9)
        m = len(rep.pack.members)
        w_iso = float(np.ptp(hex_template(m)[:, 1])) * p.spacing + p.spacing if m > 1 else p.spacing
        lam = float(np.clip((w - 2 * p.lane_margin) / w_iso, 1 / math.sqrt(p.aspect_max), 1.0)) if math.isfinite(w) else 1.0
        sub.squeeze += float(np.clip(lam - sub.squeeze, -0.05, 0.05))

    def _planned(self, sub: SubSwarm, rep: Report, x: np.ndarray, k: int,
                 cent: np.ndarray) -> tuple[Corridor, np.ndarray] | None:
        """Stall planner (ours, ``stall_plan``): the route and corridor target from the path planned
        on the map of returns, or None while the sub-swarm makes progress (the reactive choice).

        Progress: the member nearest the goal comes ``plan_progress`` closer than ever before. With
        none for ``plan_stall`` s the planner engages for good (for this sub-swarm; a split makes
        new ones). The path (``plan.cost_to_go`` from the goal, descended from the cell of
        ``cent``) is replanned every ``plan_every`` s; the target is the path point ``plan_look``
        past the path point nearest ``cent`` (at least ``through`` past the narrow place below, if
        narrow); the route is the narrowest place of the next ``lead + plan_look`` m of path as a
        throat (mid, exit direction = path direction, width = twice its clearance), so a narrow
        one becomes a passage (passage mode) at once and its tube applies as at a gate."""
        p = self.params
        dmin = float(np.min(np.hypot(*(x[rep.pack.members] - self.goal).T)))
        if sub.prog_step is None or dmin < sub.prog_d - p.plan_progress:
            sub.prog_d, sub.prog_step = min(dmin, sub.prog_d), k
        if not sub.planned:
            if (k - sub.prog_step) * p.dt < p.plan_stall:
                return None
            sub.planned = True
            self.stats["plan_engaged"] += 1
        if sub.path is None or (k - sub.path_step) * p.dt >= p.plan_every - 1e-9:
            self._replan(sub, k, x, cent)
        if sub.path is None or len(sub.path) < 2:
            return None
        path, clr, arc = sub.path, sub.path_clr, sub.path_arc
        i0 = int(np.argmin(np.sum((path - cent) ** 2, axis=1)))
        ie = min(int(np.searchsorted(arc, arc[i0] + p.plan_look + p.lead)), len(path) - 1)
        ib = i0 + int(np.argmin(clr[i0:ie + 1]))
        d = path[min(ib + 2, len(path) - 1)] - path[max(ib - 2, 0)]
        nrm = d / max(math.hypot(d[0], d[1]), 1e-9)
        w = 2.0 * float(clr[ib])
        # the target leads `through` past a narrow place ahead, as the reactive target leads past a throat
        look = max(arc[i0] + p.plan_look, arc[ib] + p.through if w < self._w_passage else 0.0)
        it = min(int(np.searchsorted(arc, look)), len(path) - 1)
        route = Corridor(mid=path[ib].copy(), normal=nrm, width=w, target=path[ib] + p.through * nrm,
                         cost=float(arc[-1] - arc[i0]))
        return route, path[it].copy()

    def _tail_stall(self, sub: SubSwarm, rep: Report, x: np.ndarray, k: int) -> None:
        """Stall planner in encircle mode: the head is at the goal, but a member farther than
        ``r_out`` from it has not come ``plan_progress`` closer for ``plan_stall`` s (a tail left
        behind a gap): engage, so that the members cut off from their ring slots follow the
        planned field (``_follow_path``)."""
        p = self.params
        dmax = float(np.max(np.hypot(*(x[rep.pack.members] - self.goal).T)))
        if sub.tail_step is None or dmax <= p.r_out or dmax < sub.tail_d - p.plan_progress:
            sub.tail_d, sub.tail_step = dmax, k
        if not sub.planned and (k - sub.tail_step) * p.dt >= p.plan_stall:
            sub.planned = True
            self.stats["plan_engaged"] += 1
        if sub.planned:
            self._field(k, x)

    def _field(self, k: int, x: np.ndarray, now: bool = False) -> None:
        """Stall planner: the clearance and cost-to-go fields of the map, recomputed at most once a
        step, and otherwise every ``plan_every`` s (or at once with ``now``); exact wherever the
        agents at ``x`` can read it before the next update (``self._slack``)."""
        p = self.params
        if self._ctg_step == k or (not now and (k - self._ctg_step) * p.dt < p.plan_every - 1e-9):
            return
        self._clr = clearance(self._occ, p.plan_cell)
        g = np.floor((self.goal - self._map0) / p.plan_cell).astype(int)
        need = np.floor((x - self._map0) / p.plan_cell).astype(np.int64)[:, ::-1].copy()
        self._ctg = cost_to_go(self._clr, int(g[1]), int(g[0]), p.plan_cell, p.plan_clear, p.d_safe,
                               p.plan_weight, need, self._slack)
        self._ctg_step = k

    def _replan(self, sub: SubSwarm, k: int, x: np.ndarray, start: np.ndarray) -> None:
        """Stall planner: the path from ``start`` to the goal on the map of returns (plan.py), its
        clearance and arc length; the cost-to-go field is computed once per step for all sub-swarms."""
        p = self.params
        self._field(k, x, now=True)
        sub.path_step = k
        ny, nx = self._ctg.shape
        c = np.floor((start - self._map0) / p.plan_cell).astype(int)
        si, sj = int(np.clip(c[1], 0, ny - 1)), int(np.clip(c[0], 0, nx - 1))
        if not np.isfinite(self._ctg[si, sj]):
            near = nearest_reachable(self._ctg, si, sj, int(round(p.d_safe / p.plan_cell)), p.plan_cell)
            if near is None:
                sub.path = sub.path_clr = None
                return
            si, sj = near
        cells = descend(self._ctg, si, sj, nx * ny)
        sub.path = self._map0 + (cells[:, ::-1] + 0.5) * p.plan_cell
        sub.path_clr = self._clr[cells[:, 0], cells[:, 1]]
        sub.path_arc = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(sub.path, axis=0).T))])

    def _choose_route(self, sub: SubSwarm, rep: Report, x: np.ndarray, k: int) -> Corridor | None:
        """The corridor this sub-swarm follows: the direct route if the goal is in clear view,
        else the cheapest candidate, kept (hysteresis ``switch_margin``) while it is still seen,
        and kept unconditionally while a split's commitment lasts."""
        p = self.params
        a = sub.subleader
        sl = x[a]
        cands = list(rep.corridors)
        ring_a = self._ring[a]
        cent = rep.pack.centroid
        if segment_clear(ring_a, sl[0], sl[1], self._cos, self._sin, cent[0], cent[1], self.goal[0], self.goal[1],
                         p.d_safe, p.lidar_range):
            cands.insert(0, direct_corridor(cent, self.goal))
        prev = sub.route
        if sub.committed and prev is not None:
            # a split's assignment holds (even when the subleader's view of the throat changes)
            # until the centroid has passed the throat or the commitment has lapsed
            if float(np.dot(cent - prev.mid, prev.normal)) > 0.0 or (k - sub.commit_step) * p.dt > _COMMIT_S:
                sub.committed = False
            else:
                return prev
        m = len(rep.pack.members)
        # passage mode: in a chain of passages the queues replace the hold (a wide bay corridor held
        # for the tail would keep the head behind the last gate)
        engaged = p.passage_mode and bool(sub.passages)
        if prev is not None and not prev.direct and not engaged:
            # Hold a throat until the whole sub-swarm is through (at most _HOLD_S after the first
            # member passed): the next corridor's target would pull the members still in front
            # of this gap away from it, along the wall. Only members in line with the gap count as
            # in front of it: a member stuck beside it (beyond its side wall, e.g. in a block's
            # concave corner) held the route for 15 s while the target ran on along the old exit
            # direction and led the rest into a closed pocket (dense_cross_blocks seeds 16, 26).
            rel = rep.pack.positions - prev.mid
            along = rel @ prev.normal
            across = np.abs(rel @ np.array([-prev.normal[1], prev.normal[0]]))
            band = across < 0.5 * prev.width + 2.0  # in line with the gap
            through = int(np.count_nonzero((along > 0.0) & band))  # passed the gap
            before = int(np.count_nonzero((along <= 0.0) & band))  # still in front of it
            seen = segment_clear(ring_a, sl[0], sl[1], self._cos, self._sin, cent[0], cent[1], prev.mid[0],
                                 prev.mid[1], _RHO_VIS, p.lidar_range)
            if through > 0 and before > 0 and seen:
                if sub.hold_step is None:
                    sub.hold_step = k
                if (k - sub.hold_step) * p.dt <= _HOLD_S:
                    return prev
            else:
                sub.hold_step = None
        if p.passage_mode:
            # A route leads forward: a throat the centroid is already `through` m beyond, or a
            # passage a member has crossed, is behind the head of the sub-swarm, not a candidate
            # (the members still in front of it queue for it, see _queue). Replaces the hold above
            # for narrow throats: the head moves on while the queue streams through.
            behind = [q.throat for q in sub.passages if q.crossed[rep.pack.members].any()]
            w_wide = self._w_wide
            cands = [c for c in cands if c.width >= w_wide or (
                float(np.dot(cent - c.mid, c.normal)) <= p.through
                and not any(math.hypot(*(c.mid - b.mid)) <= 0.5 * b.width for b in behind))]

        if not cands:
            if (p.passage_mode and prev is not None
                    and any(q.crossed[a] and math.hypot(*(q.throat.mid - prev.mid)) <= 0.5 * q.throat.width
                            for q in sub.passages)):
                return None  # through the last passage seen: head for the goal until the next throat shows
            return prev
        cost = [c.cost + self._width_penalty(c.width, m) for c in cands]
        best = int(np.argmin(cost))
        if prev is None:
            return cands[best]
        same = self._match(prev, cands)
        if same is None:
            sub.committed = False
            return cands[best]
        if cost[best] >= cost[same] - p.switch_margin:
            return cands[same]
        return cands[best]

    @staticmethod
    def _width_penalty(w: float, m: int) -> float:
        """Route-cost penalty [m] of a narrow corridor for a sub-swarm of m agents (ours): the
        extra queue length of funnelling m agents through it, 1 m per agent at w = 0, zero from
        6 m (three abreast at 2 m) up."""
        if not math.isfinite(w):
            return 0.0
        return m * max(0.0, 6.0 - w) / 6.0

    @staticmethod
    def _match(prev: Corridor, cands: list[Corridor]) -> int | None:
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

    def _cruise(self, rep: Report) -> float:
        """Cruise speed v_s of a sub-swarm [m/s]; with the safety stack on, scaled down linearly
        from v_s (clearance >= clr_slow) to v_min_frac v_s (clearance <= d_safe) by the nearest
        LiDAR return of its members (adaptive cruise, ours)."""
        p = self.params
        if not p.adaptive:
            return p.v_s
        f = np.clip((rep.clearance - p.d_safe) / max(p.clr_slow - p.d_safe, 1e-9), 0.0, 1.0)
        return p.v_s * (p.v_min_frac + (1.0 - p.v_min_frac) * float(f))

    # ------------------------------------------------------------------ reassignment, eq. (41)
    def _reassign(self, x: np.ndarray, k: int) -> None:
        p = self.params
        if len(self.subs) < 2:
            return
        ids = sorted(self.subs)
        sl_pos = x[[self.subs[s].subleader for s in ids]]
        wps = np.array([self.subs[s].waypoint for s in ids])
        protected = np.zeros(self.n, dtype=bool)
        protected[[self.subs[s].subleader for s in ids]] = True
        protected[self.leader] = True
        new, moved = reassign(x, self.labels, ids, sl_pos, wps, protected, self.last_move, k, self._ra_steps,
                              p.w_sl, p.w_c, p.delta_min, p.n_move_max)
        if len(moved):
            for s in set(self.labels[moved].tolist()) | set(new[moved].tolist()):
                self.subs[s].slot_step = _NEVER
            self.labels = new
            self.last_move[moved] = k
            self.stats["reassigned"] += len(moved)

    # ------------------------------------------------------------------ references, eq. (23)
    def _references(self, x: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
        """Slots p*_i (N, 2) and each agent's cruise speed (N,)."""
        p = self.params
        slot = np.empty_like(x)
        speed = np.empty(self.n)
        queued = self._qidx >= 0
        slot[queued] = self._qtgt[queued]  # passage mode: queued members head for their throat
        speed[queued] = p.v_s
        for s, sub in self.subs.items():
            members = np.flatnonzero((self.labels == s) & ~queued)
            m = len(members)
            if m == 0:
                continue
            if sub.mode == ENCIRCLE:
                if sub.ring_offsets is None or len(sub.ring_offsets) != m or k - sub.slot_step >= _SLOT_REFRESH:
                    a = sub.subleader
                    pts = self.goal[None, :] + p.r_enc * np.column_stack([np.cos(_RING_ANGLES), np.sin(_RING_ANGLES)])
                    free = free_points(self._ring[a], x[a, 0], x[a, 1], self._cos, self._sin, pts,
                                       p.enc_clear, p.lidar_range)
                    ring = ring_slots(self.goal, p.r_enc, m, free, _RING_ANGLES)
                    r_i = assign_slots(x[members], ring)
                    sub.ring_offsets = ring[r_i] - self.goal
                    sub.slot_step = k
                slot[members] = self.goal + sub.ring_offsets
                speed[members] = p.v_s
                continue
            tmpl = self._template(m, sub)
            if k - sub.slot_step >= _SLOT_REFRESH or not np.array_equal(sub.slot_members, members):
                sub.slot_members = members
                sub.slot_index = assign_slots(x[members], sub.waypoint + tmpl)
                sub.slot_step = k
            slot[members] = sub.waypoint + tmpl[sub.slot_index]
            speed[members] = p.v_s
        return slot, speed

    def _template(self, m: int, sub: SubSwarm) -> np.ndarray:
        """alpha_s R(psi_s) Delta_f of eq. (23) for a sub-swarm of m agents, (m, 2) [m].

        Delta_f: the unit hex template, squeezed across the formation axis by ``squeeze`` and
        stretched along it by ``1 / squeeze``; alpha_s = spacing (k_p + k_path) / k_p, so that
        where the slot attraction (eq. 24) balances the corridor centering toward c_s (eq. 32) the
        agents sit ``spacing`` apart."""
        p = self.params
        alpha = p.spacing * (p.k_p + p.k_path) / p.k_p
        t = hex_template(m)
        hx, hy = sub.heading
        u = t[:, 0] / sub.squeeze
        w = t[:, 1] * sub.squeeze
        return alpha * np.column_stack([hx * u - hy * w, hy * u + hx * w])

    # ------------------------------------------------------------------ control, eq. (38)-(39)
    def _control(self, x: np.ndarray, v: np.ndarray, ring: np.ndarray, slot: np.ndarray,
                 speed: np.ndarray) -> np.ndarray:
        p = self.params
        n = self.n
        ids = sorted(self.subs)
        col = np.searchsorted(np.asarray(ids), self.labels)
        sl_idx = np.array([self.subs[s].subleader for s in ids])[col]
        wp = np.array([self.subs[s].waypoint for s in ids])[col]
        nav = np.array([self.subs[s].mode == NAVIGATE for s in ids])[col]
        chained = np.array([bool(self.subs[s].passages) for s in ids])[col]  # passage mode: in a throat chain
        follower = sl_idx != np.arange(n)
        # passage mode: the members queued at one throat are their own cohesion group (centroid,
        # nearest neighbour), head for the throat (c_s = its target) and are not coupled to a
        # subleader on the far side of the wall
        queued = self._qidx >= 0
        if queued.any():
            cgrp = col * (_PASSAGES + 1) + self._qidx + 1
            uniq, cgrp = np.unique(cgrp, return_inverse=True)
            cent = F.group_centroids(x, cgrp, len(uniq))[cgrp]
            wp[queued] = self._qtgt[queued]
            follower &= ~queued
            nn = F.nearest_in_group(x, cgrp)
        else:
            cent = F.group_centroids(x, col, len(ids))[col]
            nn = F.nearest_in_group(x, self.labels)
        sig = self._occlusion(x, slot, nn, sl_idx, cent)
        if p.trail_follow:
            self._follow_trail(x, slot, wp, sig, cent, sl_idx, queued | chained)
        dsafe = self._dsafe(x)
        if p.stall_plan:
            self._follow_path(x, slot, wp, sig, dsafe)
        vslot = F.slot_velocity(x, slot, speed, p.eps_v)
        args = (x, v, self.labels, x[sl_idx], v[sl_idx], follower, cent, wp, nav, slot, vslot, nn, sig, ring,
                self._cos, self._sin, self._gains, dsafe)
        if p.passage_mode and (dsafe < p.d_safe).any():
            # passage mode: for a queued member inside a throat's tube and lined up with the gap,
            # the LiDAR repulsion keeps its lateral (centring) part but loses its part against the
            # throat's exit direction: the base term of eq. (36) from the gate corners ahead
            # (~5 m/s^2 at 1.3 m) otherwise balances the slot attraction and holds the last member
            # of a queue, with nobody behind to push, in front of the mouth for good; the braking
            # barrier still stops it short of any return. (For every tube member, not only queued
            # ones, the gates' R_unsafe falls further but random-forest contacts rise: docs.)
            t = F.force_terms(*args)
            nrm = np.where(((self._qidx >= 0) | self._pushfree)[:, None], self._tube_normal, 0.0)
            back = np.minimum(np.sum(t[7] * nrm, axis=1), 0.0)
            t[7] -= back[:, None] * nrm
            a = t.sum(axis=0)
        else:
            a = F.synthesize(*args)
        if p.adaptive:
            # passage mode: members of a sub-swarm in a chain of narrow throats queue at the gate
            # mouths and brake for the neighbour in front (agent braking barrier), before and again
            # after the wall barrier, which may turn a member toward its neighbour
            brake = p.passage_mode and p.agent_brake > 0.0 and bool(chained.any())
            if brake:
                a = F.agent_barrier(a, x, v, chained, p.dt, p.agent_brake, p.agent_margin, p.a_bound)
            wall = (ring, self._cos, self._sin, p.dt, p.v_cap_frac * p.v_s, p.a_brake, p.brake_margin, p.lidar_range)
            a = F.safety_filter(a, v, *wall)
            if brake:  # the queue barrier may turn a member toward a wall: the wall barrier has the last word
                a = F.safety_filter(F.agent_barrier(a, x, v, chained, p.dt, p.agent_brake, p.agent_margin, p.a_bound),
                                    v, *wall)
        a = F.saturate(a, p.a_bound)
        if p.adaptive and p.agent_guard:
            # contact guard: every agent brakes for its neighbours, with priority over the clip
            a = F.agent_guard(a, x, v, p.dt, p.guard_brake, p.guard_margin, p.a_bound)
        return a

    def _remember_passage(self, sub: SubSwarm, route: Corridor | None, rep: Report, x: np.ndarray, k: int) -> None:
        """Passage mode: a narrow throat (w < 2 (d_safe + passage_margin)) becomes a passage once it
        has been the sub-swarm's route, with no wider corridor in its report, for
        ``passage_confirm`` seconds (the planner's committed choice, not a one-step flicker).
        Passages are kept for ``passage_memory`` seconds after they stopped being the route (and
        beyond, while members are still in front of them within ``passage_queue``), with
        the agents that have crossed each, so that members still in front of a throat keep its
        passage (and queue for it) when the route has moved on to the next corridor."""
        p = self.params
        w_wide = self._w_passage
        # a passage is kept while it was the route within passage_memory, or while members of the
        # sub-swarm are still in front of it within passage_queue (they keep their queue: a lapsed
        # passage left them in the head, whose centroid and leash then fell at the wall)
        members = self.labels == sub.sid
        keep = [q for q in sub.passages if (k - q.step) * p.dt <= p.passage_memory or bool(np.any(
            members & ~q.crossed & (np.hypot(*(x - q.throat.mid).T) <= p.passage_queue)))]
        narrow = route is not None and not route.direct and route.width < w_wide
        same = [q for q in keep if narrow and math.hypot(*(q.throat.mid - route.mid)) <= 0.5 * route.width]
        # a narrow throat on the stall planner's path is its committed choice: confirmed at once
        only = narrow and (sub.planned or all(c.width < w_wide for c in rep.corridors))
        sub.narrow_steps = sub.narrow_steps + 1 if only else 0
        # in a chain of narrow throats (a passage is remembered) the next narrow route is confirmed at once
        chain = narrow and only and bool(keep)
        if narrow and (same or chain or sub.planned or sub.narrow_steps * p.dt >= p.passage_confirm):
            keep = [q for q in keep if not any(q is r for r in same)]
            crossed = same[-1].crossed if same else np.zeros(self.n, dtype=bool)
            keep.append(Passage(route, k, crossed))
        for q in keep:
            q.crossed |= (x - q.throat.mid) @ q.throat.normal > 0.0
        sub.passages = keep[-_PASSAGES:]

    def _queue(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Passage mode, per-agent routing along the chain of remembered throats: a member that has
        not crossed a passage of its sub-swarm (within ``passage_queue`` of it) is queued for it and
        targets the point 'through' m past that throat (the oldest uncrossed throat first) -- for
        an earlier throat than the route always, for the route's own throat once ``passage_head``
        members have crossed it (they are the head, which follows the waypoint on to the next
        throat while the tail streams through; in encircle mode too). Returns (N,) int, the index of the agent's throat in its
        sub-swarm's passages (-1: not queued) and (N, 2) targets."""
        p = self.params
        q_idx = np.full(self.n, -1, dtype=np.int64)
        q_tgt = np.zeros((self.n, 2))
        if not p.passage_mode or not any(sub.passages for sub in self.subs.values()):
            return q_idx, q_tgt
        for s, sub in self.subs.items():  # few sub-swarms x at most _PASSAGES throats
            if sub.planned:
                continue  # stall planner: each member follows its own way down the planned field (_follow_path)
            members = self.labels == s
            for j, q in enumerate(sub.passages):
                c = q.throat
                if (sub.route is not None and math.hypot(*(c.mid - sub.route.mid)) <= 0.5 * c.width
                        and np.count_nonzero(members & q.crossed) < p.passage_head):
                    continue  # the current route, not yet crossed by a head: its members follow the waypoint
                near = np.hypot(*(x - c.mid).T) <= p.passage_queue
                pend = members & ~q.crossed & near & (q_idx < 0)
                q_idx[pend] = j
                q_tgt[pend] = c.mid + p.through * c.normal
        return q_idx, q_tgt

    def _dsafe(self, x: np.ndarray) -> np.ndarray:
        """Safety distance of eq. (36) per agent [m]: d_safe, except in passage mode for the members
        of a sub-swarm (navigating, or encircling with members still crossing) inside the tube of a
        throat it is (or was recently) routed through (:func:`passage.passage_dsafe`; the smallest
        value where tubes overlap)."""
        p = self.params
        out = np.full(self.n, p.d_safe)
        self.last_dsafe = out
        # exit direction of the tube each member is in and lined up with (0: none)
        self._tube_normal = np.zeros((self.n, 2))
        self._pushfree = np.zeros(self.n, dtype=np.bool_)  # stall planner: members threading a narrow place
        if not p.passage_mode or not any(sub.passages for sub in self.subs.values()):
            return out
        for s, sub in self.subs.items():  # a loop over (at most a few) sub-swarms and throats, not agents
            if not sub.passages:
                continue
            members = np.flatnonzero(self.labels == s)
            for q in sub.passages:
                c = q.throat
                eff = passage_dsafe(x[members], c.mid, c.normal, c.width, p.d_safe, p.passage_margin,
                                    p.passage_len, p.passage_reach, p.passage_relief)
                inside = members[eff < out[members]]
                # lined up with the gap (within w/2 - margin of its centre line): item 6 applies
                rel = x[inside] - c.mid
                lined = np.abs(rel @ np.array([-c.normal[1], c.normal[0]])) <= 0.5 * c.width - p.passage_margin
                self._tube_normal[inside] = np.where(lined[:, None], c.normal, 0.0)
                out[members] = np.minimum(out[members], eff)
        self.last_dsafe = out
        return out

    def _follow_path(self, x, slot, wp, sig, dsafe) -> None:
        """Stall planner, per member (ours, ``stall_plan``): a member of an engaged sub-swarm whose
        slot is out of sight (segment blocked) or which is in or entering a narrow place of its own
        way down the planned cost-to-go field (half-width below w_passage / 2 within
        ``passage_len``) takes as slot and centering target the point ``plan_look`` down that
        field, with its blocked couplings off; in a narrow place it uses the passage-mode safety
        distance min(d_safe - passage_relief, half-width - passage_margin) of eq. (36). Modifies
        ``slot``, ``wp``, ``sig`` and ``dsafe`` (the array ``last_dsafe`` holds) in place.

        Why: a formation slot, the subleader and the centroid pull a member straight at them,
        through the discs between; in a forest the members that had not followed the head
        through the first gap stayed in pockets (density 0.25, seed 2)."""
        p = self.params
        act = np.zeros(self.n, dtype=np.bool_)
        for s, sub in self.subs.items():
            if sub.planned and self._ctg_step > _NEVER:
                act |= self.labels == s
        if not act.any():
            return
        idx = np.flatnonzero(act)
        pt, half = lookahead(self._ctg, self._clr, np.ascontiguousarray(x[idx]), self._map0[0], self._map0[1],
                             p.plan_cell, p.plan_look, p.passage_len)
        narrow = 2.0 * half < self._w_passage
        b = self._blocked[idx]
        use = (b[:, F.SIG_SLOT] | narrow) & np.isfinite(half)
        i = idx[use]
        slot[i] = wp[i] = pt[use]
        sig[i, F.SIG_SLOT] = 1.0
        sig[i, F.SIG_SL] = np.where(b[use, F.SIG_SL], 0.0, sig[i, F.SIG_SL])
        sig[i, F.SIG_CENT] = np.where(b[use, F.SIG_CENT], 0.0, sig[i, F.SIG_CENT])
        if p.passage_mode:
            j = idx[use & narrow]
            dsafe[j] = np.minimum(dsafe[j], throat_dsafe(half[use & narrow], p.d_safe, p.passage_margin,
                                                         p.passage_relief))
            # and, like a queued member lined up with a gate (passage mode item 6), no push back
            # against its way: the LiDAR repulsion keeps its part across the way (wall barrier intact)
            u = pt[use & narrow] - x[j]
            un = np.hypot(*u.T)
            ok = un > 1e-6
            self._tube_normal[j[ok]] = u[ok] / un[ok, None]
            self._pushfree[j[ok]] = True

    def _follow_trail(self, x, slot, wp, sig, cent, sl_idx, routed) -> None:
        """Trail following (ours, ``trail_follow``): a member cut off from its sub-swarm -- the
        segments to its slot, its subleader and its centroid all blocked for ``_CUT_S`` (2 s),
        farther than ``d_c`` from the centroid, not the subleader, not in a sub-swarm with a
        passage chain (queues and tubes route those members) -- takes as slot and corridor-centering
        target the newest point of its teammates' trail (their positions, sampled every second)
        that it can reach in a straight line (no return of its own ring within 0.4 m of the
        segment, at most ``_TRAIL_REACH`` away). Once there, a newer point is in view: it
        retraces the way the others went. Its subleader, centroid and (if blocked) nearest
        neighbour couplings are switched off meanwhile. Modifies ``slot``, ``wp`` and ``sig`` in place.
        ``routed``: (N,) bool, the members passage mode routes (queued, or in a throat chain).

        Why: eqs. (24) and (32) pull a member straight at its slot and the waypoint c_s, through
        any wall between them (eq. (30) attenuates the slot term, not the centering term, which
        grows with the distance). A member left in a block's concave corner -- the wall between
        it and the swarm, the way out pointing away from the swarm -- was held there by them
        against the LiDAR repulsion for the rest of the run (dense_cross_blocks held-out seeds:
        one or two stragglers, R_unsafe 0.45-0.65 on those runs)."""
        p = self.params
        b = self._blocked
        cut = b[:, F.SIG_SLOT] & b[:, F.SIG_SL] & b[:, F.SIG_CENT]
        if not cut.any():  # the common case: nobody is cut off
            self._cut_steps[:] = 0
            self.last_cut = cut
            return
        cut &= ~routed & (sl_idx != np.arange(self.n))  # a passage chain routes its own members
        cut &= np.hypot(*(x - cent).T) > p.d_c
        self._cut_steps = np.where(cut, self._cut_steps + 1, 0)
        cut &= self._cut_steps * p.dt >= _CUT_S
        self.last_cut = cut
        if not cut.any() or self._trail_n == 0:
            return
        for i in np.flatnonzero(cut):
            mates = np.flatnonzero((self.labels == self.labels[i]) & ~cut)
            t, j = newest_visible(self._ring[i], x[i, 0], x[i, 1], self._cos, self._sin, self._trail, self._trail_n,
                                  mates, _RHO_VIS, _TRAIL_REACH, p.lidar_range)
            if t >= 0:
                slot[i] = wp[i] = self._trail[t, j]
                sig[i, F.SIG_SLOT] = 1.0
                # the couplings it cannot see (subleader, centroid, nearest neighbour) no longer
                # pull it at the wall: attenuated by eq. (30) they still pinned it there
                sig[i, F.SIG_SL] = sig[i, F.SIG_CENT] = 0.0
                if b[i, F.SIG_NN]:
                    sig[i, F.SIG_NN] = 0.0

    def _occlusion(self, x, slot, nn, sl_idx, cent) -> np.ndarray:
        """Eq. (30): sigma_occ where the segment to the slot / nearest neighbour / subleader /
        centroid meets an obstacle, 1 otherwise; (N, 4). The blocked flags are kept in
        ``self._blocked`` (trail following reads them, also with sigma_occ = 1)."""
        p = self.params
        n = self.n
        self._blocked = np.zeros((n, 4), dtype=np.bool_)
        if self.geom.is_empty or (p.sigma == 1.0 and not p.trail_follow):
            return np.ones((n, 4))
        q_nn = x[np.where(nn >= 0, nn, np.arange(n))]
        P = np.concatenate([x, x, x, x])
        Q = np.concatenate([slot, q_nn, x[sl_idx], cent])
        blocked = self._obstacles.blocked_into(P, Q, np.empty(4 * n, dtype=np.bool_)).reshape(4, n).T
        self._blocked = blocked
        return np.where(blocked, p.sigma, 1.0)
