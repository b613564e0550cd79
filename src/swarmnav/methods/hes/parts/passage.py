"""Passage mode (ours, beyond the paper): the safety distance inside a throat the planner chose.

Eq. (36) adds ``k_e (d_safe - d + 1)^2 >= k_e = 48 m/s^2`` for every local minimum of the LiDAR
ring closer than d_safe. In a throat narrower than ``2 d_safe`` both sides are within d_safe and
the gate corner pushes an agent at the entrance backwards with tens of m/s^2 against
a_max = 2.6 m/s^2: the safety law forbids exactly the passage the planner committed to.

Passage mode keys the near-obstacle term on the geometry of that passage instead. A member of
a sub-swarm whose route is a detected throat of width w, while inside the throat's *tube*
(within ``half_len`` of the throat along its normal and within ``w/2 + reach`` of its centre
line across it), uses

    d_safe_eff = min(d_safe - relief, w/2 - margin)

so the centre line of the throat keeps ``margin`` of clearance beyond d_safe_eff (the
near-obstacle term stays off there and engages only for an agent more than ``margin`` off
centre), and the term never pushes a member out of a throat it fits through. Everywhere else,
and as soon as the member leaves the tube, d_safe applies unchanged. ``relief`` lowers d_safe a
little even where w/2 - margin >= d_safe, for throats that leave a narrow band without being
narrower than 2 (d_safe + margin) (which throats are passages at all: ``HesParams.passage_band``).

:class:`PassageMode` is the part (switch ``passage_mode``): it remembers the narrow throats a
sub-swarm is routed through (:meth:`PassageMode.remember`), queues the members still in front of
one for it (:meth:`PassageMode.queue`), lowers their safety distance in its tube
(:meth:`PassageMode.safe_distance`), drops the LiDAR push-back against the way out for queued
members lined up with the gap, and brakes queued members for the neighbour in front
(:meth:`PassageMode.queue_barrier`, switch ``agent_brake`` > 0). The parameters are the
``passage_*`` fields of :class:`HesParams` and ``gap_depth``, ``agent_brake``, ``agent_margin``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numba import njit

from swarmnav.methods.hes.parts.barriers import agent_barrier, brake_radius
from swarmnav.methods.hes.neighbours import neighbour_rows
from swarmnav.methods.hes.corridors import Corridor, segment_clear
from swarmnav.methods.hes.hooks import Part


def throat_dsafe(half_width, d_safe: float, margin: float, relief: float = 0.0):
    """d_safe_eff [m] in a throat of half-width ``half_width`` [m] (scalar or array):
    min(d_safe - relief, max(w/2 - margin, 0)). Passage mode's tubes and the stall planner's
    narrow places both use it."""
    return np.minimum(d_safe - relief, np.maximum(np.asarray(half_width, dtype=float) - margin, 0.0))


def passage_dsafe(x: np.ndarray, mid: np.ndarray, normal: np.ndarray, width: float, d_safe: float,
                  margin: float, half_len: float, reach: float, relief: float = 0.0) -> np.ndarray:
    """Per-agent safety distance [m] for agents at ``x`` (M, 2) following a throat.

    Args:
        x: (M, 2) positions [m] of the members of the sub-swarm whose route is the throat.
        mid, normal: (2,) throat midpoint [m] and unit exit direction.
        width: throat width w [m]; d_safe: the nominal safety distance [m] (Table A1).
        margin: clearance [m] kept between the throat's centre line and d_safe_eff.
        half_len: tube half-length [m] along ``normal``; reach: tube half-width beyond w/2 [m].
        relief: [m] d_safe_eff never exceeds d_safe - relief inside the tube.

    Returns:
        (M,) d_safe_eff = min(d_safe - relief, max(w/2 - margin, 0)) inside the tube, d_safe outside.
    """
    rel = np.asarray(x, dtype=float) - mid
    along = rel @ normal
    across = np.abs(rel @ np.array([-normal[1], normal[0]]))
    inside = (np.abs(along) <= half_len) & (across <= 0.5 * width + reach)
    return np.where(inside, throat_dsafe(0.5 * width, d_safe, margin, relief), d_safe)


@dataclass(slots=True)
class Passage:
    """A narrow throat a sub-swarm was routed through."""

    throat: Corridor  # the last detection of the throat while it was the route
    step: int  # last step it was the route
    crossed: np.ndarray  # (N,) bool: the agent has been beyond the throat (along its normal)


@dataclass(slots=True)
class Memory:
    """Passage mode's memory of one sub-swarm."""

    passages: list = field(default_factory=list)  # list[Passage], oldest first
    narrow_steps: int = 0  # consecutive steps the route was a narrow throat with no wider candidate
    chained: bool = False  # the sub-swarm has been routed through a passage


class PassageMode(Part):
    """Passage mode (ours; switch ``passage_mode``): see the module docstring."""

    name = "passage"

    def __init__(self, p, stall=None):
        self.p = p
        self.stall = stall  # the stall planner's engaged path is a committed route (or None)
        # a throat narrower than w_wide [m] is narrow for gap detection and the corridor filter
        # (w/2 - margin < d_safe); one narrower than w_passage can become a passage (the band the
        # paper's law leaves in it, w - 2 d_safe, is under passage_band)
        self.w_wide = 2.0 * (p.paper.d_safe + p.passage.margin)
        self.w_passage = 2.0 * p.paper.d_safe + max(p.passage.band, 2.0 * p.passage.margin)
        self.approach, self.approach_w = p.passage.length, self.w_wide
        # a narrow opening must be a seen passage, not a concave corner (``gap_depth``)
        self.seen_w, self.seen_depth = self.w_wide, p.passage.gap_depth

    def reset(self, hes, positions):
        self.h = hes
        self.n = len(positions)
        self.mem = {0: Memory()}
        self.q_idx = np.full(self.n, -1, dtype=np.int64)  # the last queue (see queue)
        self.q_tgt = np.zeros((self.n, 2))
        self.last_dsafe = None  # the safety distances of the last step [m]
        self.lowered = True  # some of them may be below d_safe (known exactly once push_back has run)
        self.n_queued = 0  # members queued in q_idx

    def passages(self, sid: int) -> list[Passage]:
        """The throats remembered for sub-swarm ``sid``, oldest first."""
        return self.mem[sid].passages

    def set_passages(self, sid: int, passages: list[Passage], chained: bool | None = None) -> None:
        """Replace the memory of sub-swarm ``sid`` (scenario set-ups, tests)."""
        self.mem[sid].passages = list(passages)
        if chained is not None:
            self.mem[sid].chained = chained

    # ------------------------------------------------------------ perception and reports
    def elect(self, step, col):
        """A subleader queued behind a throat cannot see the head's next corridor: the role goes
        to the head member nearest the head's centroid."""
        if not self.n_queued:  # nobody queued at the last step: no subleader to replace
            return
        x = step.x
        part = self.h.partition()
        for j, s in enumerate(part.ids):
            sub = self.h.subs[s]
            if self.q_idx[sub.subleader] < 0:
                continue
            members = part.members[j]
            head = members[self.q_idx[members] < 0]
            if len(head):
                hc = x[head].mean(axis=0)
                sub.subleader = int(head[np.argmin(np.sum((x[head] - hc) ** 2, axis=1))])

    def corridors(self, step, sub, cors):
        """A corridor behind a passage the subleader has crossed (a bay seen back through the gap)
        leads back along the chain, not toward the goal."""
        passages = self.mem[sub.sid].passages
        if not passages:
            return cors
        crossed = [q.throat for q in passages if q.crossed[sub.subleader]]
        return [c for c in cors if c.direct or not any(float(np.dot(c.mid - t.mid, t.normal)) < 0.0 for t in crossed)]

    def cruise_mask(self, members):
        """Members inside a passage's tube (or queued for one) do not slow the sub-swarm's cruise."""
        if self.last_dsafe is None or not (self.lowered or self.n_queued):
            return None  # every member counts
        return (self.last_dsafe[members] >= self.p.paper.d_safe) & (self.q_idx[members] < 0)

    # ------------------------------------------------------------ structure
    def split(self, old, new, k):
        gone = self.mem.pop(old)
        for sid in new:
            self.mem[sid] = Memory([Passage(q.throat, q.step, q.crossed.copy()) for q in gone.passages])

    def merge(self, keep, drop):
        """The merged sub-swarm keeps the passages of both parts (members in front of a throat
        stay queued for it)."""
        gone, kept = self.mem.pop(drop), self.mem[keep]
        kept.passages = sorted(gone.passages + kept.passages, key=lambda q: q.step)[-self.p.passage.count:]

    # ------------------------------------------------------------ route
    def encircle(self, step, sub, rep):
        for q in self.mem[sub.sid].passages:  # members still crossing keep their queue until through
            q.crossed |= (step.x - q.throat.mid) @ q.throat.normal > 0.0

    def candidates(self, step, sub, rep, cands, cent):
        """A route leads forward: a throat the centroid is already ``through`` m beyond, or a
        passage a member has crossed, is behind the head of the sub-swarm, not a candidate (the
        members still in front of it queue for it). Replaces the route hold for narrow throats."""
        behind = [q.throat for q in self.mem[sub.sid].passages if q.crossed[rep.pack.members].any()]
        return [c for c in cands if c.width >= self.w_wide or (
            float(np.dot(cent - c.mid, c.normal)) <= self.p.core.through
            and not any(math.hypot(*(c.mid - b.mid)) <= 0.5 * b.width for b in behind))]

    def end_route(self, step, sub, prev):
        """Through the last passage seen: head for the goal until the next throat shows."""
        return prev is not None and any(q.crossed[sub.subleader] and math.hypot(*(q.throat.mid - prev.mid))
                                        <= 0.5 * q.throat.width for q in self.mem[sub.sid].passages)

    def engaged(self, sid: int) -> bool:
        """The sub-swarm is in a chain of passages (its queues replace the route hold)."""
        return bool(self.mem[sid].passages)

    def chosen(self, step, sub, rep, route):
        self.remember(sub.sid, route, rep, step.x, step.k)

    def remember(self, sid: int, route: Corridor | None, rep, x: np.ndarray, k: int) -> None:
        """A narrow throat (w < w_passage) becomes a passage once it has been the sub-swarm's route,
        with no wider corridor in its report (``rep``), for ``passage_confirm`` s (the planner's
        committed choice, not a one-step flicker). Passages are kept for ``passage_memory`` s
        after they stopped being the route (and beyond, while members are still in front of them
        within ``passage_queue``: they keep their queue), with the agents that have crossed each."""
        p, mem = self.p, self.mem[sid]
        w_wide = self.w_passage
        narrow = route is not None and not route.direct and route.width < w_wide
        if not narrow and not mem.passages:  # the common case: nothing to remember, nothing kept
            mem.narrow_steps = 0
            return
        members = self.h.labels == sid
        keep = [q for q in mem.passages if (k - q.step) * p.paper.dt <= p.passage.memory or bool(np.any(
            members & ~q.crossed & (np.hypot(*(x - q.throat.mid).T) <= p.passage.queue)))]
        same = [q for q in keep if narrow and math.hypot(*(q.throat.mid - route.mid)) <= 0.5 * route.width]
        planned = self.stall is not None and self.stall.engaged(sid)
        # a narrow throat on the stall planner's path is its committed choice: confirmed at once
        only = narrow and (planned or all(c.width < w_wide for c in rep.corridors))
        mem.narrow_steps = mem.narrow_steps + 1 if only else 0
        # in a chain of narrow throats (a passage is remembered) the next narrow route is confirmed at once
        chain = narrow and only and bool(keep)
        if narrow and (same or chain or planned or mem.narrow_steps * p.paper.dt >= p.passage.confirm):
            keep = [q for q in keep if not any(q is r for r in same)]
            crossed = same[-1].crossed if same else np.zeros(self.n, dtype=bool)
            keep.append(Passage(route, k, crossed))
        for q in keep:
            q.crossed |= (x - q.throat.mid) @ q.throat.normal > 0.0
        mem.passages = keep[-p.passage.count:]

    def target(self, step, sub, route, target, cent, along):
        """A narrow throat the subleader does not see straight from the centroid is reached through
        its mouth (see ``corridors_toward``, approach)."""
        p, h, a, x = self.p, self.h, sub.subleader, step.x
        if route.width < self.w_wide and along <= 0.0 and not segment_clear(
                step.ring[a], x[a, 0], x[a, 1], h.cos, h.sin, cent[0], cent[1], route.mid[0], route.mid[1],
                p.core.rho_vis, p.paper.lidar_range):
            return route.mid - p.passage.length * route.normal
        return target

    def restart(self, step, sub, cent):
        """In a passage chain, a waypoint the subleader sees behind a wall (the head moved on through
        a gap) restarts from the head's centroid; once the chain's passages have lapsed, from the
        subleader (the centroid, with stragglers still in front of the last gate, can lie in the
        wall itself: pushed off the wall's far side it would hold the head there for good)."""
        mem, x, h = self.mem[sub.sid], step.x, self.h
        if self.p.adaptive and (mem.passages or mem.chained):
            a = sub.subleader
            start = cent if mem.passages else x[a]
            if not segment_clear(step.ring[a], x[a, 0], x[a, 1], h.cos, h.sin, start[0], start[1],
                                 sub.waypoint[0], sub.waypoint[1], 0.2, self.p.paper.lidar_range):
                sub.waypoint = start.copy()
        mem.chained = mem.chained or bool(mem.passages)

    # ------------------------------------------------------------ targets
    def targets(self, step, subs, labels, final):
        if not any(self.mem[s].passages for s in subs):  # the common case: no throat remembered,
            self.q_idx = step.own  # nobody queued (the core's own = -1, own_target = 0, routed = False)
            self.n_queued = 0
            if final:
                self.q_tgt = step.own_target
            return
        self.q_idx, q_tgt = self.queue(step.x, labels, subs)
        step.own = self.q_idx
        step.n_own = self.n_queued = int(np.count_nonzero(self.q_idx >= 0))
        if final:
            self.q_tgt = q_tgt
            step.own_target = q_tgt
            step.routed = (self.q_idx >= 0) | self.chained_agents(step)

    def queue(self, x: np.ndarray, labels: np.ndarray, subs: dict) -> tuple[np.ndarray, np.ndarray]:
        """Per-agent routing along the chain of remembered throats: a member that has not crossed a
        passage of its sub-swarm (within ``passage_queue`` of it) is queued for it and targets the
        point ``through`` m past that throat (the oldest uncrossed throat first) -- for an earlier
        throat than the route always, for the route's own throat once ``passage_head`` members
        have crossed it (they are the head, which follows c_s on to the next throat while the tail
        streams through; in encircle mode too). Returns (N,) int, the index of the agent's throat
        in its sub-swarm's passages (-1: not queued), and (N, 2) targets [m]."""
        p = self.p
        q_idx = np.empty(self.n, dtype=np.int64)
        q_idx.fill(-1)
        q_tgt = np.zeros((self.n, 2))
        if not any(self.mem[s].passages for s in subs):
            return q_idx, q_tgt
        for s, sub in subs.items():  # few sub-swarms x at most passage_count throats
            if self.stall is not None and self.stall.engaged(s):
                continue  # the stall planner: each member follows its own way down the planned field
            members = labels == s
            for j, q in enumerate(self.mem[s].passages):
                c = q.throat
                if (sub.route is not None and math.hypot(*(c.mid - sub.route.mid)) <= 0.5 * c.width
                        and np.count_nonzero(members & q.crossed) < p.passage.head):
                    continue  # the current route, not yet crossed by a head: its members follow c_s
                near = np.hypot(*(x - c.mid).T) <= p.passage.queue
                pend = members & ~q.crossed & near & (q_idx < 0)
                q_idx[pend] = j
                q_tgt[pend] = c.mid + p.core.through * c.normal
        return q_idx, q_tgt

    def any_passages(self) -> bool:
        """Some sub-swarm remembers a passage (else no agent is chained)."""
        for m in self.mem.values():
            if m.passages:
                return True
        return False

    def chained_agents(self, step) -> np.ndarray:
        """(N,) bool: the agent's sub-swarm remembers a passage (it is in a chain of throats)."""
        if not any(m.passages for m in self.mem.values()):
            return np.zeros(self.n, dtype=np.bool_)
        part = self.h.partition()
        chained = [bool(self.mem[s].passages) for s in part.ids]
        if not any(chained):
            return np.zeros(self.n, dtype=np.bool_)
        return np.array(chained)[part.col]

    # ------------------------------------------------------------ control
    def steer(self, step):
        step.dsafe = self.safe_distance(step.x, self.h.labels, step.dsafe, step.exit_dir)
        self.last_dsafe = step.dsafe
        self.lowered = True  # until push_back has seen the step's final safety distances

    def safe_distance(self, x: np.ndarray, labels: np.ndarray, out: np.ndarray, exit_dir: np.ndarray) -> np.ndarray:
        """Safety distance of eq. (36) per agent [m], in place on ``out``: lowered for the members of
        a sub-swarm inside the tube of a throat it is (or was recently) routed through
        (:func:`passage_dsafe`; the smallest value where tubes overlap). ``exit_dir`` gets the exit
        direction of the tube each member is in and lined up with (within w/2 - margin of its
        centre line)."""
        for s, mem in self.mem.items():  # a loop over (at most a few) sub-swarms and throats, not agents
            if not mem.passages:
                continue
            members = np.flatnonzero(labels == s)
            for q in mem.passages:
                self._lower(x, members, q.throat, out, exit_dir)
        return out

    def _lower(self, x, members, c, out, exit_dir) -> None:
        """:meth:`safe_distance` for the ``members`` (ascending indices) routed through throat ``c``."""
        p = self.p
        eff = passage_dsafe(x[members], c.mid, c.normal, c.width, p.paper.d_safe, p.passage.margin,
                            p.passage.length, p.passage.reach, p.passage.relief)
        inside = members[eff < out[members]]
        rel = x[inside] - c.mid
        lined = np.abs(rel @ np.array([-c.normal[1], c.normal[0]])) <= 0.5 * c.width - p.passage.margin
        exit_dir[inside] = np.where(lined[:, None], c.normal, 0.0)
        out[members] = np.minimum(out[members], eff)

    # ------------------------------------------------------------ on a network (docs/methods/hes-network.md)
    def throats(self) -> dict:
        """{sid: tuple of throats} of the sub-swarms routed through passages (the leader's plan
        carries them to the members)."""
        return {s: tuple(q.throat for q in mem.passages) for s, mem in self.mem.items() if mem.passages}

    def planned_dsafe(self, x: np.ndarray, labels: np.ndarray) -> None:
        """The leader's cruise mask on a network: its members' safety distances from its picture of
        them (``x``), in place of the ones the agents computed (which it does not receive)."""
        d = np.empty(len(x))
        d.fill(self.p.paper.d_safe)
        self.last_dsafe = self.safe_distance(x, labels, d, np.zeros((len(x), 2)))
        self.lowered = n_below(self.last_dsafe, self.p.paper.d_safe) > 0

    def steer_known(self, step, net):
        """:meth:`steer` on a network: each agent's safety distance from the throats of the plan it
        flies, at its own position."""
        from swarmnav.methods.hes.networked import by_plan

        for q, rows in by_plan(net.plans):
            if not q.throats:
                continue
            sid = q.labels[rows]
            for s, throats in q.throats.items():
                members = rows[sid == s]
                for c in throats:
                    self._lower(step.x, members, c, step.dsafe, step.exit_dir)
        # as steer (the ideal path's next cruise mask); on a network the leader replaces them
        # with its own picture's before it reads them (planned_dsafe)
        self.last_dsafe = step.dsafe
        self.lowered = True

    def chained_known(self, net) -> np.ndarray:
        """(N,) bool on a network: the plan the agent flies routes its sub-swarm through throats."""
        n = len(net.plans)
        out = np.zeros(n, dtype=np.bool_)
        for i, q in enumerate(net.plans):
            out[i] = q is not None and bool(q.throats) and int(q.labels[i]) in q.throats
        return out

    def queue_barrier_known(self, step, a: np.ndarray, active: np.ndarray, net) -> np.ndarray:
        """:meth:`queue_barrier` on a network: each active member brakes for its pictures of the others."""
        from swarmnav.methods.hes.networked import agent_barrier_known

        p = self.p
        return agent_barrier_known(np.ascontiguousarray(a), step.x, step.v, net.kx, net.kv, net.heard, active,
                                   p.paper.dt, p.passage.agent_brake, p.passage.agent_margin, p.a_bound)

    def push_back(self, step):
        self.lowered = n_below(step.dsafe, self.p.paper.d_safe) > 0
        return self.lowered

    def edit_terms(self, step, t):
        """For a queued member inside a throat's tube and lined up with the gap, the LiDAR
        repulsion keeps its lateral (centring) part but loses its part against the exit direction:
        the base term of eq. (36) from the gate corners ahead (~5 m/s^2 at 1.3 m) otherwise
        balances the slot attraction and holds the last member of a queue, with nobody behind to
        push, in front of the mouth for good; the braking barrier still stops it short of any
        return."""
        nrm = np.where(((step.own >= 0) | step.exit_free)[:, None], step.exit_dir, 0.0)
        back = np.minimum(np.sum(t[7] * nrm, axis=1), 0.0)
        t[7] -= back[:, None] * nrm

    def queue_barrier(self, step, a: np.ndarray, active: np.ndarray) -> np.ndarray:
        """The agents' braking barrier for the ``active`` members (``barriers.agent_barrier``)."""
        p = self.p
        ptr, idx = neighbour_rows(step.x, lambda: brake_radius(a, step.v, p.paper.dt, p.passage.agent_brake, p.passage.agent_margin))
        return agent_barrier(a, step.x, step.v, active, p.paper.dt, p.passage.agent_brake, p.passage.agent_margin, p.a_bound, ptr, idx)


@njit(cache=True)
def n_below(a, bound):
    """How many entries of ``a`` are below ``bound``."""
    k = 0
    for i in range(a.shape[0]):
        if a[i] < bound:
            k += 1
    return k
