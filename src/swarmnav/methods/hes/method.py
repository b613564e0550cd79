"""``hes``: the Hierarchical Embodied Swarm method (Wu & Wei, Drones 2026), wired from pure parts.

One step (paper Section 4.4, "At each discrete step"), :meth:`Hes.act`:

1. perceive: every agent's fused LiDAR ring (eq. 8-9) (``report.sense``);
2. report: each subleader sends its Pack P_s(k) (eq. 3) and the corridors its ring shows
   (Section 3.2); the leader's planner reads only these reports (``report.report``);
3. decide: z(k) (eq. 18) -> decision source -> Pi_feas (eq. 22) -> split / merge / keep
   (``structure``);
4. assign targets: task modes (eq. 12), corridor choice and waypoints c_s(k) (``navigate``),
   follower reassignment (eq. 41), formation references (eq. 23) (``targets``);
5. control: the eight force terms (eq. 38) and the saturation of eq. (39) (``control``).

The stages pass one :class:`~swarmnav.methods.hes.step.Step`. The class holds the planner's
memory (partition, sub-swarms, cooldowns) and the parts of ours that the parameters switch on
(:func:`swarmnav.methods.hes.parts.build_parts`), which plug in at the hooks listed in ``hooks.py``.
"""

from __future__ import annotations

import copy
import math
from typing import Any

import numpy as np

from swarmnav.dynamics import DampedDoubleIntegrator
from swarmnav.llm import decision_source
from swarmnav.methods.base import Observation
from swarmnav.methods.hes import forces as F
from swarmnav.methods.hes.control import control, couple_workspace
from swarmnav.methods.hes.corridors import Corridor
from swarmnav.methods.hes.decision import DecisionSource, DecisionState, RulePolicy, project
from swarmnav.methods.hes.hierarchy import Report
from swarmnav.methods.hes.navigate import navigate
from swarmnav.methods.hes.oracle import OracleSource
from swarmnav.methods.hes.networked import (PLAN, REPORT, RING_MIN, Picture, control_known, flown_rows,
                                            leader_rings, leader_view, part_rows, plan_of, plans_flown,
                                            publication, reports_received, reports_sent)
from swarmnav.methods.hes.params import HesParams
from swarmnav.methods.hes.parts import build_parts
from swarmnav.methods.hes.hooks import Part, hook_table
from swarmnav.methods.hes.report import decision_state, reelect, report, report_constants, sense, split_paths
from swarmnav.methods.hes.step import NEVER, Partition, Step, SubSwarm, partition
from swarmnav.methods.hes.structure import merge, reassign_followers, split
from swarmnav.methods.hes.targets import references
from swarmnav.params import build
from swarmnav.sensing import PreparedGeometry, ray_table
from swarmnav.world.scenario import Scenario


class Hes:
    """The HES method (see module docstring); parameters: :class:`HesParams`."""

    name = "hes"
    networked = True  # on a network each agent reads the others only as received (networked.py, docs/methods/hes-network.md)
    dims = (2,)  # planar, as its paper: a 3-D scene is flown in its horizontal slice at z_fly
    range_sensor = True  # its LiDAR ring is read through Observation.scan (docs/sensing.md)

    def __init__(self, **overrides: Any):
        self.params = build(HesParams, overrides, context="hes")
        self.dt = self.params.paper.dt
        self.dynamics = DampedDoubleIntegrator()  # eq. (5)-(7): m = 5 kg, c_d = 0.5, inverse model
        self.gains = F.gain_vector(self.params)
        self.cos, self.sin = ray_table(self.params.paper.n_rays)
        self.dirs = np.column_stack([self.cos, self.sin])  # (R, 2) the ring's rays, for Observation.scan
        self.pair_radius = max(self.params.core.r_sep, self.params.core.d_ir)  # [m] reach of the pair terms (eq. 25, 31)
        p = self.params
        self.ring_angles = np.linspace(0.0, 2 * np.pi, p.core.enc_samples, endpoint=False)  # encircle slot candidates
        self._source_override: DecisionSource | None = None
        #: decision=oracle: the source the run hands its lookahead simulator (docs/oracle.md); else None
        self.oracle: OracleSource | None = None
        self.parts: list[Part] = []
        self.at: dict[str, list[Part]] = hook_table([])  # hook name -> the parts that override it
        self._part_key: tuple | None = None  # the labels and ids the cached Partition was built for
        self._part: Partition | None = None

    def use_source(self, source: DecisionSource) -> Hes:
        """Decide structure with ``source`` instead of the rule policy (from the next reset)."""
        self._source_override = source
        return self

    def rule_policy(self) -> RulePolicy:
        """A fresh rule policy a_k^rule (Section 3.2) as this build decides by it (``core.merge_rule``)."""
        p = self.params
        return RulePolicy(p.paper.d_merge, p.paper.t_cd, merge=p.core.merge_rule)

    def part(self, name: str) -> Part | None:
        """The part of ours called ``name`` (``passage``, ``stall``, ``trail``, ``hold``, ``commit``,
        ``wall``, ``guard``, ``ring_yield``, ``projection``), or None when it is switched off."""
        return next((q for q in self.parts if q.name == name), None)

    # ------------------------------------------------------------------ lifecycle
    def reset(self, scenario: Scenario, positions: np.ndarray, velocities: np.ndarray,
              rng: np.random.Generator) -> None:
        p = self.params
        self.scenario = scenario
        self.goal = scenario.goal_array.astype(float)
        self.geom = scenario.geometry
        self.obstacles = PreparedGeometry(self.geom)  # the per-step LiDAR and line-of-sight queries
        self.no_obstacles = self.geom.is_empty
        n = len(positions)
        self.n = n
        self.arange = np.arange(n)  # agent indices (compared with per-agent indices every step)
        rule = self.rule_policy()
        if self._source_override is not None:
            self.source: DecisionSource = self._source_override
        elif p.decision == "oracle":
            self.source = OracleSource(rule, p)
        else:
            self.source = decision_source(p, rule, project)
        self.oracle = self.source if isinstance(self.source, OracleSource) else None
        c = positions.mean(axis=0)
        self.leader = int(np.argmin(np.sum((positions - c) ** 2, axis=1)))  # one leader, eq. (1) roles
        self.labels = np.zeros(n, dtype=np.int64)
        self.subs: dict[int, SubSwarm] = {0: SubSwarm(0, self.leader, c.copy())}
        self._next_id = 1
        self.k_last: int | None = None
        self.last_move = np.full(n, NEVER, dtype=np.int64)
        self.cd_steps = int(round(p.paper.t_cd / p.paper.dt))
        self.ra_steps = int(round(p.paper.tau_ra / p.paper.dt))
        self.stats = {"splits": 0, "merges": 0, "reassigned": 0, "projected_to_keep": 0, "plan_engaged": 0}
        self.last_z: DecisionState | None = None
        self.last_reports: dict[int, Report] = {}
        self.last_step: Step | None = None
        self.parts = build_parts(p)
        self.at = hook_table(self.parts)
        self._part_key = None
        self._roles_key: tuple | None = None  # the leader and subleaders the cached roles were built for
        self.needs_blocked = any(q.needs_blocked for q in self.parts)  # a part reads Step.blocked
        # the report's approach to narrow throats (hook attribute ``approach``; the last part that sets it)
        self.approach = next(((q.approach, q.approach_w) for q in reversed(self.parts) if q.approach > 0.0),
                             (0.0, math.inf))
        for q in self.parts:
            q.reset(self, positions)
        self.report_gaps, self.report_consts = report_constants(self)
        self.report_c = np.array(self.report_gaps + self.report_consts, dtype=float)  # report_rows' scalars
        self.couple_ws = couple_workspace(n)  # the control stage's coupling arrays, rewritten every step
        # on a network (networked.py): the start positions every agent knows before take-off, each
        # agent's plan flown last step, the leader's kept reports and the step of each sub-swarm's last change
        self.start_x, self.start_v = np.array(positions, dtype=float), np.array(velocities, dtype=float)
        self.flown: list = [None] * n
        self.kept: dict = {}
        self.subs_since: dict[int, int] = {}

    def summary(self) -> dict[str, float]:
        out = {"llm_calls": 0.0, "llm_fallback_used": 0.0}
        out.update({f"hes_{k}": float(v) for k, v in self.stats.items()})
        if hasattr(self.source, "summary"):
            out.update({k: float(v) for k, v in self.source.summary().items()})
        return out

    def timings(self) -> dict[str, float]:
        """Wall-clock figures (``RunResult.timings``): the oracle's lookahead cost when it decides."""
        return self.oracle.timings() if self.oracle is not None else {}

    def clone(self) -> Hes:
        """An independent copy of this method mid-run (its planner memory, parts, caches and
        decision source): fed the same observations, the copy and the original act
        bit-identically. What never changes after reset (parameters, scene, prepared obstacles,
        ray tables) is shared, not copied. A copied oracle source decides by the rule; an LLM
        source cannot be copied (TypeError)."""
        shared = [getattr(self, name) for name in ("params", "scenario", "geom", "obstacles", "dynamics", "gains",
                                                   "cos", "sin", "dirs", "ring_angles") if hasattr(self, name)]
        return copy.deepcopy(self, {id(o): o for o in shared})

    def artifacts(self) -> dict[str, str]:
        """Extra run files: ``llm_transcript.jsonl`` when an LLM decides (docs/llm.md)."""
        return self.source.artifacts() if hasattr(self.source, "artifacts") else {}

    def partition(self) -> Partition:
        """The current sub-swarms as arrays (:class:`Partition`), rebuilt only when the labels or
        the sub-swarm ids have changed since the last call."""
        key = (self.labels.tobytes(), tuple(self.subs))
        if key != self._part_key:
            self._part_key, self._part = key, partition(self.labels, self.subs)
        return self._part

    def new_id(self) -> int:
        """A fresh sub-swarm id."""
        self._next_id += 1
        return self._next_id - 1

    def split_paths(self, step: Step, rep: Report) -> list[Corridor]:
        """The split paths of one report (n_c of eq. 13, see :func:`report.split_paths`)."""
        p = self.params
        return split_paths(rep, self.goal, step.ring[rep.pack.subleader], p.core.w_split, p.core.rho_vis, p.paper.lidar_range)

    # ------------------------------------------------------------------ one step
    def act(self, obs: Observation, rng: np.random.Generator) -> tuple[np.ndarray, dict]:
        """One step of Section 4.4; returns the commanded accelerations (N, 2) [m/s^2] and
        ``{"labels", "events", "roles"}`` (roles: see :meth:`roles`). On a non-ideal network
        (``obs.view``) :meth:`_act_networked`."""
        if obs.view is not None:
            return self._act_networked(obs)
        x = np.ascontiguousarray(obs.positions, dtype=np.float64)
        v = np.ascontiguousarray(obs.velocities, dtype=np.float64)
        # 1. perceive
        step = Step(obs.step, x, v, obs.scan(lambda at: sense(self, at), x, self.dirs, self.params.paper.lidar_range))
        for q in self.at["observe"]:
            q.observe(step)
        reelect(self, step)
        # 2. report, 3. decide through Pi_feas
        events = self._decide(step)
        # 4. modes, routes, waypoints, reassignment, references
        self._route_agents(step, final=False)
        for s, sub in self.subs.items():
            navigate(self, step, sub, step.reports[s])
        reassign_followers(self, x, step.k)
        self._route_agents(step, final=True)
        references(self, step)
        # 5. control
        a = control(self, step)
        self.last_step = step
        return a, {"labels": self.labels.copy(), "events": events, "roles": self.roles()}

    def _act_networked(self, obs: Observation) -> tuple[np.ndarray, dict]:
        """One step on a network (docs/methods/hes-network.md): every agent senses its own ring and
        publishes its nearest return (``RING_MIN``); each agent flies the newest plan it has received
        (``PLAN``); an agent whose plan makes it a subleader reports from its own picture
        (``REPORT``); the leader plans on its own picture of the agents and on the reports it holds,
        and publishes its plan, which it flies at once; every agent's control law reads the others
        only as it received them (``obs.known()``)."""
        x = np.ascontiguousarray(obs.positions, dtype=np.float64)  # each agent's own state
        v = np.ascontiguousarray(obs.velocities, dtype=np.float64)
        kx, kv, heard = obs.known()
        n, lead, k = self.n, self.leader, obs.step
        step = Step(k, x, v, sense(self, x))
        plans = plans_flown(obs.received(PLAN), lead, self.flown)
        sent = reports_sent(self, step, plans, kx, kv, heard, obs.received(RING_MIN))
        got = obs.received(REPORT)
        kept = reports_received(self, None if got is None else got[lead], sent, k, self.kept)
        # the parts' perception: the leader's map of the rings it holds, each agent's trail of its pictures
        if self.at["observe"]:
            seen = leader_rings(self, x[lead], step.ring[lead], kept, k)
            net = Picture(k, kx, kv, heard, None, plans)
            for q in self.at["observe"]:
                q.observe_known(seen, net)
        # the leader's picture: agents it has never heard where they started (the mission plan)
        hx = np.where(heard[lead][:, None], kx[lead], self.start_x)
        hv = np.where(heard[lead][:, None], kv[lead], self.start_v)
        hx[lead], hv[lead] = x[lead], v[lead]
        ring = np.full_like(step.ring, self.params.paper.lidar_range)  # rings it has not received: nothing seen
        ring[lead] = step.ring[lead]
        for m in kept.values():
            ring[m.subleader] = m.ring
        ps = Step(k, hx, hv, ring)
        reelect(self, ps)
        events = self._decide_networked(ps, kept)
        self._route_agents(ps, final=False)
        for s, sub in self.subs.items():
            if s in ps.reports:  # a sub-swarm with no report since its last change keeps its last waypoint and mode
                navigate(self, ps, sub, ps.reports[s])
        reassign_followers(self, hx, k)
        self._route_agents(ps, final=True)
        references(self, ps)
        passage = self.part("passage")
        if passage is not None:  # the next reports' cruise mask: the members' safety distances as the leader pictures them
            passage.planned_dsafe(ps.x, self.labels)
        plan = plan_of(self, ps)
        plans[lead] = plan
        self.flown = plans
        lab, coh, sl_idx, wp, nav, planned, step.slot, step.speed = flown_rows(plans, x)
        step.own, step.routed = part_rows(plans, n)
        step.own_target = np.where((step.own >= 0)[:, None], wp, 0.0)
        a = control_known(self, step, kx, kv, heard, lab, coh, sl_idx, wp, nav, planned, plans)
        self.last_step = step
        publish = {PLAN: publication(plan, lead, n), REPORT: sent, RING_MIN: step.ring_min.copy()}
        return a, {"labels": self.labels.copy(), "events": events, "roles": self.roles(),
                   "publish": publish}

    def _decide_networked(self, ps: Step, kept: dict) -> list[dict]:
        """Stages 2-3 on the leader's reports: z(k) and the source's proposal through Pi_feas only
        when it holds a report of every sub-swarm (else it keeps the structure); after a split or a
        merge it drops every report and waits for reports made on the new plan."""
        ps.reports = {s: leader_view(self, ps, kept[s]) for s in sorted(self.subs) if s in kept}
        if len(ps.reports) < len(self.subs):
            return []
        k, events = ps.k, []
        z = ps.z = decision_state(self, ps)
        prop = self.source.propose(z, k)
        action = project(prop.action, z)
        if action != prop.action:
            self.stats["projected_to_keep"] += 1
        if action == "split":
            events.append(split(self, ps, prop))
        elif action == "merge":
            events.append(merge(self, ps, prop))
        if action != "keep":
            self.k_last = k
            for s in self.subs:
                self.subs_since[s] = k
            kept.clear()
            ps.reports = {}
        self.last_z, self.last_reports = z, ps.reports
        return events

    def roles(self) -> np.ndarray:
        """(N,) uint8 role of each agent in the hierarchy of eq. (1): 2 the leader, 1 a
        subleader, 0 a follower (recorded by the run for the replay viewer)."""
        key = (self.leader, *[sub.subleader for sub in self.subs.values()])
        if key != self._roles_key:  # rebuilt only when a subleader or the leader changes
            r = np.zeros(self.n, dtype=np.uint8)
            r[list(key[1:])] = 1
            r[self.leader] = 2
            self._roles_key, self._roles = key, r
        return self._roles.copy()

    def _decide(self, step: Step) -> list[dict]:
        """Stages 2-3: the reports, z(k), the source's proposal through Pi_feas (eq. 22), executed."""
        k = step.k
        events: list[dict] = []
        step.reports = {s: report(self, step, s) for s in sorted(self.subs)}
        z = step.z = decision_state(self, step)
        prop = self.source.propose(z, k)
        action = project(prop.action, z)
        if action != prop.action:
            self.stats["projected_to_keep"] += 1
        if action == "split":
            events.append(split(self, step, prop))
        elif action == "merge":
            events.append(merge(self, step, prop))
        if action != "keep":
            self.k_last = k
            step.reports = {s: report(self, step, s) for s in sorted(self.subs)}
        self.last_z, self.last_reports = z, step.reports
        return events

    def _route_agents(self, step: Step, final: bool) -> None:
        """Agents routed on their own (hook ``targets``); none in the paper's method."""
        step.own = np.empty(self.n, dtype=np.int64)
        step.own.fill(-1)  # (np.full costs several times this on a small array)
        step.n_own = 0
        if final:
            step.own_target = np.zeros((self.n, 2))
            step.routed = np.zeros(self.n, dtype=np.bool_)
        for q in self.at["targets"]:
            q.targets(step, self.subs, self.labels, final)
