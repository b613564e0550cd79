"""HES's stages on each agent's own picture of the others (docs/network.md, docs/methods/hes-network.md).

Under the ideal network every stage reads every agent's true position and velocity. On a network
agent i knows agent j only as its last message carried it (``Observation.known``: positions ``kx``
(N, N, 2) [m], velocities ``kv`` (N, N, 2) [m/s], row i agent i's picture, column i its own true
state, and ``heard`` (N, N) bool), and its sub-swarm only as the plan it flies says: ``lab`` (N, N)
int, row i the sub-swarm labels of agent i's plan, ``coh`` its cohesion groups, and its own rows
of that plan (subleader, c_s, mode, slot, speed).

- **Control (eq. 26-31, 38)**: agent i's cohesion centroid (eq. 29) is the mean of its own
  position and its pictures of the heard agents its plan puts in its group; its nearest
  neighbour (eq. 26) the nearest of those; its subleader's state (eq. 27) its picture of it (a
  follower that has never heard its subleader is not coupled to it); the separation terms (eq.
  25, 31) are summed over its own *directed* pairs (:func:`couple_known`, :func:`eq38_known`,
  :func:`control_known`).
- **Our braking barriers**: the contact guard and passage mode's queue barrier brake each agent
  for the agents it has heard, at their pictured states (:func:`agent_guard_known`,
  :func:`agent_barrier_known`).
- **The plan as a message**: the leader publishes its :class:`Plan` (``PLAN``); each agent flies
  the newest plan it has received, never one it has not, and alone without one
  (:func:`plans_flown`, :func:`flown_rows`).
- **A subleader's report**: its Pack from its picture of the members it has heard, its own ring's
  corridors, the members' published nearest returns (:func:`report_known`, ``RING_MIN``); as it
  travels (``REPORT``, :class:`Sent`, :func:`reports_sent`) and as the leader keeps it
  (:func:`reports_received`).

Fed every agent's true state and one plan for all, the control stage and the report give the
ideal path's values bit for bit (tests/methods/hes/test_networked.py). ``Hes._act_networked``
wires them into one step.

- **Our default build's parts**: their planner hooks run in the leader's planner on its picture;
  the plan carries what their control hooks need of it (passage mode's throats and queues, the
  stall planner's look-ahead for each engaged member: :func:`plan_of`), and the control hooks
  read that plan and the agent's pictures (``steer_known``, ``brake_known``, :class:`Picture`);
  the leader applies passage mode's report hooks to the reports it receives (:func:`leader_view`)
  and maps the rings it holds (:func:`leader_rings`); trail following keeps each agent's trail of
  its pictures.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from numba import njit

from swarmnav.methods.hes import forces as F
from swarmnav.methods.hes.control import _sub_rows, eq38_sum
from swarmnav.methods.hes.neighbours import neighbour_rows
from swarmnav.methods.hes.parts.barriers import brake_pair, brake_reach2, keep_braking
from swarmnav.methods.hes.report import report
from swarmnav.methods.hes.step import Step


@njit(cache=True)
def couple_known(x, v, kx, kv, heard, lab, sl_idx, planned):
    """Each agent's couplings from its own picture: its cohesion centroid ``cent`` (N, 2) [m], its
    nearest group mate ``nn`` (N,) (-1: none heard) and that mate's pictured position ``nn_pos``
    (N, 2) (its own position if none), its subleader's pictured position ``sl_pos`` and velocity
    ``sl_vel`` (N, 2) (its own state if it is its own subleader or has never heard it), and
    ``follower`` (N,) bool: its plan makes it a follower (``planned``), its subleader is another
    agent and it has heard that agent.

    Args:
        x, v: (N, 2) own positions [m] and velocities [m/s].
        kx, kv: (N, N, 2) agent i's picture of agent j (``Observation.known``).
        heard: (N, N) bool, agent i has received a message of agent j.
        lab: (N, N) int, the cohesion group of agent j in the plan agent i flies (its sub-swarm;
            see :func:`plan_rows` for agents routed on their own).
        sl_idx: (N,) int, agent i's subleader in that plan (i itself: not a follower).
        planned: (N,) bool, the plan couples agent i to its subleader (eq. 27).
    """
    n = x.shape[0]
    cent = np.empty((n, 2))
    nn = np.full(n, -1, dtype=np.int64)
    nn_pos = np.empty((n, 2))
    sl_pos = np.empty((n, 2))
    sl_vel = np.empty((n, 2))
    follower = np.zeros(n, dtype=np.bool_)
    for i in range(n):
        g = lab[i, i]
        sx = 0.0
        sy = 0.0
        cnt = 0.0
        best = np.inf
        for j in range(n):
            if lab[i, j] != g:
                continue
            if j == i:
                px, py = x[i, 0], x[i, 1]
            elif heard[i, j]:
                px, py = kx[i, j, 0], kx[i, j, 1]
            else:
                continue
            sx += px
            sy += py
            cnt += 1.0
            if j != i:
                dx = x[i, 0] - px
                dy = x[i, 1] - py
                d2 = dx * dx + dy * dy
                if d2 < best:
                    best = d2
                    nn[i] = j
        cent[i, 0] = sx / cnt
        cent[i, 1] = sy / cnt
        j = nn[i]
        if j >= 0:
            nn_pos[i, 0], nn_pos[i, 1] = kx[i, j, 0], kx[i, j, 1]
        else:
            nn_pos[i, 0], nn_pos[i, 1] = x[i, 0], x[i, 1]
        s = sl_idx[i]
        follower[i] = planned[i] and s != i and heard[i, s]
        if s != i and heard[i, s]:
            sl_pos[i, 0], sl_pos[i, 1] = kx[i, s, 0], kx[i, s, 1]
            sl_vel[i, 0], sl_vel[i, 1] = kv[i, s, 0], kv[i, s, 1]
        else:
            sl_pos[i, 0], sl_pos[i, 1] = x[i, 0], x[i, 1]
            sl_vel[i, 0], sl_vel[i, 1] = v[i, 0], v[i, 1]
    return cent, nn, nn_pos, sl_pos, sl_vel, follower


@njit(cache=True)
def separation_known(x, kx, heard, lab, k, radius, d_floor, same_group):
    """``forces.separation`` over each agent's directed pairs: agent i pushed by ``k (p_i - q_ij) /
    max(d, d_floor)^2`` from its picture ``q_ij`` of every heard agent j within ``radius`` [m] (of
    its own sub-swarm by its plan when ``same_group``: eq. 31; else every one: eq. 25), summed in
    ascending j. (N, 2) [m/s^2]."""
    n = x.shape[0]
    out = np.zeros((n, 2))
    r2 = radius * radius
    f2 = d_floor * d_floor
    for i in range(n):
        g = lab[i, i]
        for j in range(n):
            if j == i or not heard[i, j]:
                continue
            if same_group and lab[i, j] != g:
                continue
            dx = x[i, 0] - kx[i, j, 0]
            dy = x[i, 1] - kx[i, j, 1]
            d2 = dx * dx + dy * dy
            if d2 >= r2:
                continue
            s = k / max(d2, f2)
            out[i, 0] += s * dx
            out[i, 1] += s * dy
    return out


@njit(cache=True)
def occlusion_segments_known(x, slot, nn_pos, sl_pos, cent, P, Q):
    """``control.occlusion_segments`` from the pictured partners: the 4N segments of eq. (30) into
    ``P`` (starts) and ``Q`` (ends), (4N, 2) each: agent i to its slot (row i), its nearest group
    mate (N + i), its subleader (2N + i) and its centroid (3N + i)."""
    n = x.shape[0]
    for i in range(n):
        for c in range(2):
            P[i, c] = P[n + i, c] = P[2 * n + i, c] = P[3 * n + i, c] = x[i, c]
            Q[i, c] = slot[i, c]
            Q[n + i, c] = nn_pos[i, c]
            Q[2 * n + i, c] = sl_pos[i, c]
            Q[3 * n + i, c] = cent[i, c]


@njit(cache=True)
def eq38_known(x, v, kx, heard, lab, sl_pos, sl_vel, follower, cent, nn, nn_pos, wp, nav, slot, speed, eps_v, sig,
               ring, cos_t, sin_t, g, dsafe):
    """Eq. (38) (as ``control.eq38``) with every other agent read from the receiving agent's
    picture: the couplings of :func:`couple_known`, the separation terms of
    :func:`separation_known`, the agent's own slot, c_s, mode, ring and safety distance. (N, 2)
    [m/s^2], before saturation."""
    n = x.shape[0]
    sep = separation_known(x, kx, heard, lab, g[F.G_KSEP], g[F.G_RSEP], g[F.G_DFLOOR], False)
    ir = separation_known(x, kx, heard, lab, g[F.G_KIR], g[F.G_DIR], g[F.G_DFLOOR], True)
    obs = F.lidar_repulsion_each(ring, cos_t, sin_t, g[F.G_KREP], g[F.G_RT], g[F.G_KB], g[F.G_GAMMA], g[F.G_KE],
                                 dsafe, g[F.G_DFLOOR], g[F.G_KE_RATIO] > 0.5)
    return eq38_sum(x, v, nn_pos, sl_pos, sl_vel, nn >= 0, follower, cent, wp, nav, slot, speed, eps_v, sig,
                    sep, ir, obs, g)


@njit(cache=True)
def eq38_terms_known(x, v, kx, heard, lab, sl_pos, sl_vel, follower, cent, nn, nn_pos, wp, nav, slot, speed, eps_v,
                     sig, ring, cos_t, sin_t, g, dsafe):
    """The eight terms of :func:`eq38_known`, an (8, N, 2) stack in the order of ``forces.TERMS``
    (as ``forces.force_terms``, for the parts that edit the terms)."""
    n = x.shape[0]
    out = np.zeros((8, n, 2))
    out[0] = F.attraction(x, v, slot, F.slot_velocity(x, slot, speed, eps_v), g[F.G_KP], g[F.G_KV])
    out[1] = separation_known(x, kx, heard, lab, g[F.G_KSEP], g[F.G_RSEP], g[F.G_DFLOOR], False)
    out[2] = F.centering(x, wp, g[F.G_KPATH])
    out[3] = F.spring(x, nn_pos, g[F.G_KINTRA], g[F.G_DTHR], nn >= 0)
    out[4] = separation_known(x, kx, heard, lab, g[F.G_KIR], g[F.G_DIR], g[F.G_DFLOOR], True)
    out[5] = F.spring(x, sl_pos, g[F.G_KL], g[F.G_D0], follower) + F.velocity_match(v, sl_vel, g[F.G_KVL], follower)
    out[6] = F.spring(x, cent, g[F.G_KCOH], g[F.G_DC], np.ones(n, dtype=np.bool_))
    out[7] = F.lidar_repulsion_each(ring, cos_t, sin_t, g[F.G_KREP], g[F.G_RT], g[F.G_KB], g[F.G_GAMMA], g[F.G_KE],
                                    dsafe, g[F.G_DFLOOR], g[F.G_KE_RATIO] > 0.5)
    for i in range(n):
        for c in range(2):
            out[0, i, c] *= sig[i, F.SIG_SLOT]
            out[3, i, c] *= sig[i, F.SIG_NN]
            out[5, i, c] *= sig[i, F.SIG_SL]
            out[6, i, c] *= sig[i, F.SIG_CENT]
            if not nav[i]:  # eq. (38): path and intra-repulsion only in navigate mode
                out[2, i, c] = 0.0
                out[4, i, c] = 0.0
    return out


def plan_rows(h, step: Step) -> tuple:
    """The planner's current plan as the control stage reads it, one row per agent: the sub-swarm
    label of every agent (N,) int, its cohesion group (N,) int (its sub-swarm; with agents routed
    on their own, the pair of its sub-swarm and its own group), each agent's subleader (N,) int, c_s (N, 2) [m] (an agent routed
    on its own: its own point), navigate flag (N,) bool and whether the plan couples it to its
    subleader (N,) bool (not the subleaders, not the agents routed on their own)."""
    part, sub_sl, sub_wp, sub_nav = _sub_rows(h)
    col = part.col
    sl_idx, wp, nav = sub_sl[col], sub_wp[col], sub_nav[col]
    planned = sl_idx != h.arange
    group = h.labels
    if step.n_own:
        queued = step.own >= 0
        group = col * (int(step.own.max()) + 2) + step.own + 1
        wp[queued] = step.own_target[queued]
        planned &= ~queued
    return h.labels, group, sl_idx, wp, nav, planned


def control_known(h, step: Step, kx, kv, heard, lab, coh, sl_idx, wp, nav, planned, plans=None) -> np.ndarray:
    """``control.control`` with every other agent read from the receiving agent's picture (``kx``,
    ``kv``, ``heard`` as ``Observation.known``) and each agent flying the plan it holds (``lab``,
    ``coh`` (N, N): row i the sub-swarms and cohesion groups of agent i's plan; ``sl_idx``, ``wp``, ``nav``, ``planned`` (N,) its
    own rows, as :func:`plan_rows` gives them). The commanded acceleration (N, 2) [m/s^2].

    ``plans``: the plan each agent flies (default: the planner's current plan for every agent);
    the parts read it and the pictures through ``steer_known`` and ``brake_known``
    (:class:`Picture`); the contact guard brakes for each agent's pictures
    (:func:`agent_guard_known`); ``push_back`` and the other ``guard`` hooks read only each
    agent's own state, ring and plan rows (``step.own``, ``step.dsafe``)."""
    p = h.params
    x, v, n = step.x, step.v, h.n
    net = Picture(step.k, kx, kv, heard, lab, [plan_of(h, step)] * n if plans is None else plans)
    cent, nn, nn_pos, sl_pos, sl_vel, follower = couple_known(x, v, kx, kv, heard, coh, sl_idx, planned)
    step.rows = neighbour_rows(x, h.pair_radius)
    step.col = h.partition().col
    step.sl_idx, step.wp, step.nav, step.follower, step.cent, step.nn = sl_idx, wp, nav, follower, cent, nn
    if h.no_obstacles or (p.sigma == 1.0 and not h.needs_blocked):
        step.blocked = np.zeros((n, 4), dtype=np.bool_)
        step.sig = np.ones((n, 4))
    else:
        P, Q = np.empty((4 * n, 2)), np.empty((4 * n, 2))
        occlusion_segments_known(x, step.slot, nn_pos, sl_pos, cent, P, Q)
        step.blocked = h.obstacles.blocked_into(P, Q, np.empty(4 * n, dtype=np.bool_)).reshape(4, n).T
        step.sig = np.where(step.blocked, p.sigma, 1.0)
    step.dsafe = np.empty(n)
    step.dsafe.fill(p.paper.d_safe)
    step.exit_dir = np.zeros((n, 2))
    step.exit_free = np.zeros(n, dtype=np.bool_)
    for part in h.at["steer"]:
        part.steer_known(step, net)
    args = (x, v, kx, heard, lab, sl_pos, sl_vel, step.follower, step.cent, step.nn, nn_pos, step.wp, step.nav,
            step.slot, step.speed, p.core.eps_v, step.sig, step.ring, h.cos, h.sin, h.gains, step.dsafe)
    edit = [part for part in h.at["push_back"] if part.push_back(step)]
    if edit:
        t = eq38_terms_known(*args)
        for part in edit:
            part.edit_terms(step, t)
        a = t.sum(axis=0)
    else:
        a = eq38_known(*args)
    for part in h.at["brake"]:
        a = part.brake_known(step, a, net)
    a = F.saturate(a, p.a_bound)
    for part in h.at["guard"]:
        if part.name == "guard":  # the contact guard: each agent brakes for its pictures of the others
            a = agent_guard_known(np.ascontiguousarray(a), x, v, kx, kv, heard, p.paper.dt, p.guard.brake,
                                  p.guard.margin, p.a_bound)
        else:
            a = part.guard(step, a)
    return a


#: The name the leader publishes its plan under (``info["publish"]``, ``Observation.received``).
PLAN = "hes_plan"


@dataclass(frozen=True, slots=True)
class Plan:
    """The leader's plan of step ``k`` as the control stage flies it, one row per agent (N agents):
    sub-swarm ``labels`` and cohesion ``group`` (int), ``sl_idx`` the subleader (int), ``wp`` c_s
    (N, 2) [m], ``nav`` navigate flag (bool), ``planned`` coupled to its subleader (bool),
    ``slot`` p*_i (N, 2) [m] and ``speed`` v_s (N,) [m/s] of eq. (23)."""

    k: int
    labels: np.ndarray
    group: np.ndarray
    sl_idx: np.ndarray
    wp: np.ndarray
    nav: np.ndarray
    planned: np.ndarray
    slot: np.ndarray
    speed: np.ndarray
    #: the default build's parts (None when off): ``own`` (N,) int an agent's passage queue (-1:
    #: none) and ``routed`` (N,) bool routed by a part (passage mode); ``throats`` {sid: tuple of
    #: Corridor} the passages each sub-swarm is routed through (passage mode); ``field_pt`` (N, 2)
    #: [m] and ``field_half`` (N,) [m] the stall planner's look-ahead point and narrow half-width
    #: for each member of an engaged sub-swarm (NaN: not engaged), from the leader's picture
    own: np.ndarray | None = None
    routed: np.ndarray | None = None
    throats: dict | None = None
    field_pt: np.ndarray | None = None
    field_half: np.ndarray | None = None

    @property
    def nbytes(self) -> int:
        """[B] the plan's size in a message (docs/network.md): 8 B the step, every row's array,
        and per throat its sub-swarm id (4 B) and mid, normal and width (5 floats of 8 B)."""
        rows = (self.labels, self.group, self.sl_idx, self.wp, self.nav, self.planned, self.slot, self.speed,
                self.own, self.routed, self.field_pt, self.field_half)
        size = 8 + sum(a.nbytes for a in rows if a is not None)
        return size + sum(44 * len(t) for t in (self.throats or {}).values())


def plan_of(h, step: Step) -> Plan:
    """The planner's plan of this step (after the references of eq. 23), copied: what the leader
    sends. With passage mode on it carries each agent's queue and routing and each sub-swarm's
    throats; with the stall planner on, each engaged member's look-ahead down the planner's field
    from the leader's picture of it (``step.x``)."""
    labels, group, sl_idx, wp, nav, planned = plan_rows(h, step)
    extra = {}
    passage, stall = h.part("passage"), h.part("stall")
    if passage is not None:
        extra.update(own=np.array(step.own, dtype=np.int64), routed=np.array(step.routed, dtype=np.bool_),
                     throats=passage.throats())
    if stall is not None:
        rows = stall.field_rows(step.x, labels)
        if rows is not None:
            extra.update(field_pt=rows[0], field_half=rows[1])
    return Plan(step.k, labels.copy(), np.array(group, copy=True), sl_idx.copy(), wp.copy(), nav.copy(),
                planned.copy(), step.slot.copy(), step.speed.copy(), **extra)


def by_plan(plans: list):
    """The distinct plans among the agents' (None skipped), each with the agents flying it: a list
    of (plan, (M,) int rows), in order of first appearance."""
    distinct: dict[int, tuple] = {}
    for i, q in enumerate(plans):
        if q is not None:
            distinct.setdefault(id(q), (q, []))[1].append(i)
    return [(q, np.array(r)) for q, r in distinct.values()]


def part_rows(plans: list, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Each agent's passage queue ``own`` (N,) int (-1: none) and ``routed`` (N,) bool from the
    plan it flies (an agent with no plan, or a plan without them: -1 and False)."""
    own, routed = np.full(n, -1, dtype=np.int64), np.zeros(n, dtype=np.bool_)
    for q, r in by_plan(plans):
        if q.own is not None:
            own[r], routed[r] = q.own[r], q.routed[r]
    return own, routed


@dataclass(frozen=True, slots=True)
class Picture:
    """What each agent holds on a network, for the parts' ``*_known`` hooks: ``kx``, ``kv`` (N, N, 2)
    and ``heard`` (N, N) as ``Observation.known``, ``lab`` (N, N) int row i the sub-swarm labels of
    agent i's plan, ``plans`` the plan each agent flies (None: none), ``k`` the step."""

    k: int
    kx: np.ndarray
    kv: np.ndarray
    heard: np.ndarray
    lab: np.ndarray
    plans: list


def publication(plan: Plan, leader: int, n: int) -> list:
    """The ``info["publish"][PLAN]`` rows: the leader's row its plan, every other agent's None."""
    rows = [None] * n
    rows[leader] = plan
    return rows


def plans_flown(received: np.ndarray | None, leader: int, last: list) -> list:
    """Each agent's plan this step: the newer (by its step ``k``) of the leader's last plan it has
    received (``received[i, leader]``, ``Observation.received(PLAN)``; None: nothing received) and
    the plan it flew before (``last[i]``, None: none). An agent never flies a plan it has not
    received."""
    if received is None:
        return list(last)
    got = received[:, leader]
    return [g if g is not None and (p is None or g.k > p.k) else p for g, p in zip(got, last)]


def flown_rows(plans: list, x: np.ndarray) -> tuple:
    """:func:`control_known`'s plan arguments and the references from each agent's own plan:
    ``lab``, ``coh`` (N, N) (row i agent i's plan's sub-swarms and cohesion groups), ``sl_idx``,
    ``wp``, ``nav``, ``planned``, ``slot``, ``speed`` (agent i's own rows of its plan). An agent
    with no plan flies alone: a group of its own, no subleader, no corridor centering, its slot
    its own position at speed 0 (it brakes and keeps off obstacles by its own ring)."""
    n = len(x)
    lab = np.broadcast_to(np.arange(n), (n, n)).copy()
    coh = lab.copy()
    sl_idx = np.arange(n)
    wp, slot = x.copy(), x.copy()
    nav, planned = np.zeros(n, dtype=np.bool_), np.zeros(n, dtype=np.bool_)
    speed = np.zeros(n)
    for q, r in by_plan(plans):  # a few distinct plans among the N agents: fill their rows at once
        lab[r], coh[r] = q.labels, q.group
        sl_idx[r], wp[r], nav[r], planned[r] = q.sl_idx[r], q.wp[r], q.nav[r], q.planned[r]
        slot[r], speed[r] = q.slot[r], q.speed[r]
    return lab, coh, sl_idx, wp, nav, planned, slot, speed


# --------------------------------------------------------------------------- our braking barriers on pictures

@njit(cache=True)
def _brake_toward_pictured(w, x, kx, kv, heard, i, a_brake, margin, a_lead, tol, reach2):
    """``barriers._brake_toward_neighbours`` for agent i with its neighbours read from its picture:
    every heard agent j, in ascending index, at its pictured position ``kx[i, j]`` and velocity
    ``kv[i, j]``. In place on ``w[i]``; returns whether it changed."""
    moved = False
    for j in range(x.shape[0]):
        if j == i or not heard[i, j]:
            continue
        if brake_pair(w, i, x[i, 0], x[i, 1], kx[i, j, 0], kx[i, j, 1], kv[i, j, 0], kv[i, j, 1], a_brake, margin,
                      a_lead, tol, reach2):
            moved = True
    return moved


@njit(cache=True)
def agent_barrier_known(a, x, v, kx, kv, heard, active, dt, a_brake, margin, a_lead):
    """``barriers.agent_barrier`` (passage mode's queue barrier) with each active agent braking for
    the agents it has heard, at their pictured states. Returns the acceleration (N, 2) [m/s^2]."""
    w = v + dt * a
    for i in range(x.shape[0]):
        if active[i]:
            _brake_toward_pictured(w, x, kx, kv, heard, i, a_brake, margin, a_lead, 0.0, np.inf)
    return (w - v) / dt


@njit(cache=True)
def agent_guard_known(a, x, v, kx, kv, heard, dt, a_brake, margin, a_max, passes=4):
    """``barriers.agent_guard`` (the contact guard) with each agent braking for the agents it has
    heard, at their pictured states; its reach from the fastest speed it knows (its own and its
    pictures'). Returns the new (N, 2) command [m/s^2]."""
    n = x.shape[0]
    w = v + dt * a
    for i in range(n):
        v2 = 0.0
        for j in range(n):
            if j == i:
                v2 = max(v2, v[i, 0] * v[i, 0] + v[i, 1] * v[i, 1])
            elif heard[i, j]:
                v2 = max(v2, kv[i, j, 0] * kv[i, j, 0] + kv[i, j, 1] * kv[i, j, 1])
        reach2 = brake_reach2(w[i, 0] * w[i, 0] + w[i, 1] * w[i, 1], v2, a_brake, margin)
        for _ in range(passes):
            if not _brake_toward_pictured(w, x, kx, kv, heard, i, a_brake, margin, 0.0, 1e-12, reach2):
                break
    return keep_braking(a, v, w, dt, a_max)  # the braking kept whole, the rest scaled


# --------------------------------------------------------------------------- a subleader's report from its picture

#: The name each agent publishes its ring's nearest return under (a report's ``clear``).
RING_MIN = "hes_ring_min"


def report_known(h, step: Step, s: int, kx, kv, heard, ring_min_seen):
    """Sub-swarm s's report (``report.report``) as its subleader a makes it from what it received:
    the Pack of the members it has heard (itself always), at their pictured states ``kx[a]``,
    ``kv[a]`` (N, N, 2 as ``Observation.known``), the corridors of its own ring, and the nearest
    return over the members' published ``ring_min_seen[a]`` ((N, N) [m], NaN: none received; its
    own from its ring at once; a member whose return has not arrived does not lower it)."""
    a = h.subs[s].subleader
    part = h.partition()
    members = part.members[part.index[s]]
    members = members[heard[a, members] | (members == a)]
    rm = np.array(ring_min_seen[a], dtype=np.float64)
    rm[a] = step.ring_min[a]
    rm[np.isnan(rm)] = np.inf
    pic = Step(step.k, np.ascontiguousarray(kx[a]), np.ascontiguousarray(kv[a]), step.ring, ring_min=rm)
    return report(h, pic, s, members)


# --------------------------------------------------------------------------- one step on a network

#: The name a subleader publishes its report under (a :class:`Sent`).
REPORT = "hes_report"

@dataclass(frozen=True, slots=True)
class Sent:
    """A subleader's report as it travels: sent at step ``k`` by agent ``subleader`` for sub-swarm
    ``sid`` of the plan it flies (made by the leader at step ``plan_k``), with its LiDAR ``ring``
    (R,) [m] (the leader's split test and corridor choice read the reporting subleader's ring,
    eq. 13 and Section 3.2)."""

    k: int
    plan_k: int
    sid: int
    subleader: int
    report: object
    ring: np.ndarray
    #: (2,) [m] where the subleader sensed ``ring`` (its own position; the leader's map of returns
    #: with the stall planner) and (m,) [m] the nearest returns of the reported members as the
    #: subleader holds them (the leader's cruise mask with passage mode); None without those parts
    at: np.ndarray | None = None
    ring_min: np.ndarray | None = None

    @property
    def nbytes(self) -> int:
        """[B] the report's size in a message (docs/network.md): its steps (2 x 8 B), sub-swarm and
        subleader ids (2 x 4 B), the Pack (a 4 B id, position and velocity, 8 B a float, a
        member; the centroid), 65 B a corridor (8 floats and a flag), the clearance, the ring (8 B
        a ray) and what the parts add (``at``, ``ring_min``)."""
        pack = self.report.pack
        size = 16 + 8 + len(pack.members) * (4 + 32) + 16 + 65 * len(self.report.corridors) + 8 + self.ring.nbytes
        return size + sum(a.nbytes for a in (self.at, self.ring_min) if a is not None)


def reports_sent(h, step: Step, plans: list, kx, kv, heard, ring_min_seen) -> list:
    """The ``REPORT`` rows of this step: agent a sends a :class:`Sent` when the plan it flies makes
    it its sub-swarm's subleader (``sl_idx[a] == a``), reporting the members of that plan's
    sub-swarm it has heard (itself always) at its pictures of them, its own ring's corridors and the
    members' published nearest returns (:func:`report_known`'s reading); every other row None."""
    n = h.n
    rows = [None] * n
    rm_all = np.full((n, n), np.nan) if ring_min_seen is None else np.asarray(ring_min_seen, dtype=np.float64)
    for a, q in enumerate(plans):
        if q is None or q.sl_idx[a] != a:
            continue
        s = int(q.labels[a])
        members = np.flatnonzero(q.labels == s)
        members = members[heard[a, members] | (members == a)]
        rm = rm_all[a].copy()
        rm[a] = step.ring_min[a]
        rm[np.isnan(rm)] = np.inf
        pic = Step(step.k, np.ascontiguousarray(kx[a]), np.ascontiguousarray(kv[a]), step.ring, ring_min=rm)
        # passage mode's corridor filter and cruise mask read the planner's memory of throats: the
        # leader applies them to the report it receives (leader_view)
        rep = report(h, pic, s, members, subleader=a, planner_hooks=False)
        extra = {}
        if h.part("stall") is not None:
            extra["at"] = step.x[a].copy()
        if h.part("passage") is not None:
            extra["ring_min"] = rm[members].copy()
        rows[a] = Sent(step.k, q.k, s, a, rep, step.ring[a].copy(), **extra)
    return rows


def leader_view(h, ps: Step, m: Sent):
    """The report ``m`` as the leader's planner reads it: passage mode's corridor filter and cruise
    mask (hooks ``corridors``, ``cruise_mask``), which read the planner's memory of throats, applied
    by the leader to what the subleader sent (the cruise mask to the members' nearest returns the
    report carries). The report itself without those parts."""
    rep = m.report
    if not (h.at["corridors"] or h.at["cruise_mask"]):
        return rep
    sub = h.subs[m.sid]
    cors = list(rep.corridors)
    for q in h.at["corridors"]:
        cors = q.corridors(ps, sub, cors)
    clear = rep.clearance
    clr = None
    for q in h.at["cruise_mask"]:
        free = q.cruise_mask(rep.pack.members)
        if free is not None and m.ring_min is not None:
            clr = m.ring_min if clr is None else clr
            clr = clr[free] if np.count_nonzero(free) else clr
    if clr is not None:
        clear = min(clr.tolist())
    return replace(rep, corridors=tuple(cors), clearance=clear)


def leader_rings(h, x_lead, ring_lead, kept: dict, k: int) -> Step:
    """The rings the leader holds this step, as a step of their own for the parts' ``observe``
    hooks (the stall planner's map of returns): its own at its position and each kept report's
    at the position where its subleader sensed it."""
    xs, rings = [x_lead], [ring_lead]
    for m in kept.values():
        if m.at is not None:
            xs.append(m.at)
            rings.append(m.ring)
    x = np.array(xs, dtype=float)
    return Step(k, x, np.zeros_like(x), np.ascontiguousarray(np.array(rings, dtype=float)))


def reports_received(h, got, own: list, k: int, kept: dict) -> dict:
    """The leader's newest report of each current sub-swarm: of what it received (``got``: its row
    of ``Observation.received(REPORT)``, None: nothing), its own rows sent this step (``own``) and
    what it kept (``kept`` {sid: Sent}, updated in place; sub-swarms that no longer exist dropped).
    A report made on a plan older than the planner's last change of that sub-swarm (a split or a
    merge at step ``h.subs_since[sid]``) describes other members and is not kept."""
    for sid in [s for s in kept if s not in h.subs]:
        del kept[sid]
    for m in [*(got if got is not None else ()), *own]:
        if m is None or m.sid not in h.subs or m.plan_k < h.subs_since.get(m.sid, -1):
            continue
        prev = kept.get(m.sid)
        if prev is None or m.k > prev.k or (m.k == prev.k and m.subleader == h.subs[m.sid].subleader):
            kept[m.sid] = m
    return kept
