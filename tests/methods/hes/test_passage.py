"""Passage mode (ours, docs/methods/hes.md "Passage mode"): the safety distance of eq. (36)
inside a narrow throat the planner chose, the throat memory and queue, the corridor filters."""

from __future__ import annotations

import numpy as np
import pytest

import swarmnav
from swarmnav.methods.base import Observation
from swarmnav.methods.hes.control import control
from swarmnav.methods.hes.report import sense
from swarmnav.methods.hes.step import Step
from swarmnav.methods.hes.targets import references
from swarmnav.methods.hes import control as hes_control
from swarmnav.methods.hes import forces as F
from swarmnav.methods.hes.corridors import detect_gaps, seen_passages
from swarmnav.methods.hes.params import HesParams
from swarmnav.methods.hes.parts.passage import passage_dsafe
from swarmnav.sensing import lidar_ring, ray_table
from swarmnav.world.catalog import load_scenario

P = HesParams()
COS, SIN = ray_table(P.paper.n_rays)
GATES = "narrow_alternating_gates"
MID, NORMAL, W = np.array([11.6, -9.25]), np.array([1.0, 0.0]), 2.3  # gate 1's 2.3 m gap (x = 11.6..12.4)


def _tube(x, width=W):
    return passage_dsafe(np.atleast_2d(x), MID, NORMAL, width, P.paper.d_safe, P.passage.margin, P.passage.length,
                         P.passage.reach)


@pytest.mark.parametrize("width", [2.0, 2.3, 2.9, 3.5, 3.6, 4.0, 8.0])
def test_d_safe_eff_never_exceeds_half_the_throat_nor_d_safe(width):
    rng = np.random.default_rng(0)
    x = MID + rng.uniform(-6.0, 6.0, size=(400, 2))
    d = _tube(x, width)
    assert np.all(d <= P.paper.d_safe)
    inside = d < P.paper.d_safe
    # inside the tube the centre line keeps `margin` of clearance beyond d_safe_eff
    assert np.all(d[inside] <= 0.5 * width - P.passage.margin + 1e-12)
    if width >= 2 * (P.paper.d_safe + P.passage.margin):  # wide corridors are not affected
        assert not inside.any()


def test_leaving_the_tube_restores_d_safe():
    along = np.array([-P.passage.length - 0.1, -1.0, 0.0, 0.4, 1.0, P.passage.length - 0.1, P.passage.length + 0.1, 6.0])
    d = _tube(MID + along[:, None] * NORMAL)
    eff = 0.5 * W - P.passage.margin
    np.testing.assert_allclose(d, [P.paper.d_safe, eff, eff, eff, eff, eff, P.paper.d_safe, P.paper.d_safe])
    far_across = MID + np.array([0.0, 0.5 * W + P.passage.reach + 0.1])
    assert _tube(far_across)[0] == P.paper.d_safe


def test_eq36_closes_the_gap_and_passage_mode_opens_it():
    """In front of the 2.3 m gap, on its centre line 0.6 m before the gate: eq. (36) with the
    paper's d_safe pushes back with > 10 a_max (the near-obstacle term of the gate corner and the
    channel wall); inside the tube with d_safe_eff the near-obstacle term is off, only the base
    term of eq. (36) remains."""
    x = np.array([[11.0, -9.25]])
    ring = lidar_ring(load_scenario(GATES).geometry, x, P.paper.n_rays, P.paper.lidar_range)
    paper = F.lidar_repulsion(ring, COS, SIN, P.paper.k_rep, P.paper.r_trigger, P.paper.k_b, P.paper.gamma, P.paper.k_e, P.paper.d_safe, P.core.d_floor)
    assert paper[0, 0] < -10 * P.paper.a_max
    ds = _tube(x)
    assert ds[0] < P.paper.d_safe
    relaxed = F.lidar_repulsion_each(ring, COS, SIN, P.paper.k_rep, P.paper.r_trigger, P.paper.k_b, P.paper.gamma, P.paper.k_e, ds, P.core.d_floor)
    base = F.lidar_repulsion(ring, COS, SIN, P.paper.k_rep, P.paper.r_trigger, P.paper.k_b, P.paper.gamma, 0.0, P.paper.d_safe, P.core.d_floor)
    np.testing.assert_allclose(relaxed, base)
    assert abs(relaxed[0, 0]) < 0.15 * abs(paper[0, 0])


def test_lidar_repulsion_each_with_equal_d_safe_is_the_papers_law():
    rng = np.random.default_rng(3)
    ring = rng.uniform(0.3, 20.0, size=(5, P.paper.n_rays))
    a = F.lidar_repulsion(ring, COS, SIN, P.paper.k_rep, P.paper.r_trigger, P.paper.k_b, P.paper.gamma, P.paper.k_e, P.paper.d_safe, P.core.d_floor)
    b = F.lidar_repulsion_each(ring, COS, SIN, P.paper.k_rep, P.paper.r_trigger, P.paper.k_b, P.paper.gamma, P.paper.k_e, np.full(5, P.paper.d_safe),
                               P.core.d_floor)
    np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("seed", [1, 2])
def test_single_uav_is_pushed_back_without_passage_mode_and_passes_with_it(seed):
    scene = load_scenario(GATES, n=1)
    off = swarmnav.run("hes", scene, seed=seed, steps=300, passage_mode=False)
    on = swarmnav.run("hes", scene, seed=seed, steps=300)
    assert off.positions[:, 0, 0].max() < 11.6  # never reaches the gate's face
    assert on.positions[:, 0, 0].max() > 22.4 + 1.0  # through gates 1 and 2
    assert on.metrics["d_clr_min"] > 0.0 and on.metrics["collisions"] == 0


def test_the_d_safe_actually_used_is_d_safe_outside_passages():
    """A run on the default corridor (no throat narrower than 2 (d_safe + margin) is ever the only
    way) never relaxes d_safe, and passage_mode=false never does on the gates scene."""
    from swarmnav.methods import registry

    for scene, kw in (("default_corridor", {}), (GATES, {"passage_mode": False})):
        m = registry.make("hes", **kw)
        seen = []
        orig = m.act

        def spy(obs, rng, orig=orig, seen=seen, m=m):
            out = orig(obs, rng)
            seen.append(float(m.last_step.dsafe.min()))  # the d_safe of eq. (36) the step used
            return out

        m.act = spy
        swarmnav.run(m, scene, seed=1, steps=250)
        assert min(seen) == P.paper.d_safe, scene


def test_concave_corner_seen_at_a_grazing_angle_is_not_a_passage():
    """From just above gate 1's gap the ring shows an 'opening' 3.4 m wide at the concave corner of
    gate 1 and the upper channel wall (consecutive hits metres apart on the grazed wall); the real
    gap and the channel are kept."""
    p = np.array([[10.33, -7.48]])
    ring = lidar_ring(load_scenario(GATES).geometry, p, P.paper.n_rays, P.paper.lidar_range)[0]
    gaps = detect_gaps(ring, p[0, 0], p[0, 1], COS, SIN, P.paper.lidar_range, P.core.h_open)
    ok = seen_passages(gaps, ring, p[0, 0], p[0, 1], COS, SIN, P.passage.gap_depth, P.paper.lidar_range)
    mids = 0.5 * (gaps[:, 0:2] + gaps[:, 2:4])
    corner = np.flatnonzero((mids[:, 1] > 7.0) & (gaps[:, 4] > 2.0) & (gaps[:, 4] < 5.0))
    gap1 = np.flatnonzero(np.hypot(*(mids - MID).T) < 1.0)
    assert len(corner) == 1 and len(gap1) == 1
    assert not ok[corner[0]] and ok[gap1[0]]


# ---------------------------------------------------------------- per-agent routing along the chain of throats
def _chain_method(crossed_1, crossed_2, route_is_2, mode=None):
    """A HES instance on the gates scene with one sub-swarm of 6 agents and two remembered passages:
    gate 1's gap (11.6, -9.25), normal +x, and gate 2's gap (21.6, +9.25), normal +x."""
    from swarmnav.methods import registry
    from swarmnav.methods.hes.corridors import Corridor
    from swarmnav.methods.hes.parts.passage import Passage

    scene = load_scenario(GATES, n=6)
    x = np.array([[8.0, -8.0], [9.0, -9.0], [14.0, -8.0], [16.0, 0.0], [18.0, 6.0], [24.0, 8.0]])
    m = registry.make("hes")
    m.reset(scene, x, np.zeros_like(x), np.random.default_rng(0))
    g1 = Corridor(MID.copy(), NORMAL.copy(), W, MID + 3.0 * NORMAL, 0.0)
    mid2 = np.array([21.6, 9.25])
    g2 = Corridor(mid2, NORMAL.copy(), W, mid2 + 3.0 * NORMAL, 0.0)
    sub = m.subs[0]
    m.part("passage").set_passages(0, [Passage(g1, 0, np.asarray(crossed_1)), Passage(g2, 0, np.asarray(crossed_2))])
    sub.route = g2 if route_is_2 else None
    if mode is not None:
        sub.mode = mode
    return m, x, g1, g2


def test_an_agent_through_throat_k_targets_throat_k_plus_1():
    """Agents 0-1 are in front of gate 1, agents 2-4 are through gate 1 but in front of gate 2, agent 5
    is through both. The route is beyond gate 2 (None): each agent is routed to the next throat of the
    chain it has not crossed -- gate 1, gate 2, or (through both) the sub-swarm's waypoint."""
    c1 = [False, False, True, True, True, True]
    c2 = [False, False, False, False, False, True]
    m, x, g1, g2 = _chain_method(c1, c2, route_is_2=False)
    q_idx, q_tgt = m.part("passage").queue(x, m.labels, m.subs)
    np.testing.assert_array_equal(q_idx, [0, 0, 1, 1, 1, -1])
    np.testing.assert_allclose(q_tgt[:2], np.tile(g1.mid + P.core.through * g1.normal, (2, 1)))
    np.testing.assert_allclose(q_tgt[2:5], np.tile(g2.mid + P.core.through * g2.normal, (3, 1)))


@pytest.mark.parametrize("n_through, queued", [(1, False), (2, True)])
def test_the_routes_throat_queues_its_tail_once_a_head_is_through(n_through, queued):
    """While gate 2 is the route, its members follow the waypoint until `passage_head` (= 2) members
    are through; then the head moves on and the others queue for gate 2."""
    assert P.passage.head == 2
    c1 = [True] * 6
    c2 = [False] * (6 - n_through) + [True] * n_through
    m, x, _, _ = _chain_method(c1, c2, route_is_2=True)
    q_idx, _ = m.part("passage").queue(x, m.labels, m.subs)
    near = np.hypot(*(x - np.array([21.6, 9.25])).T) <= P.passage.queue  # agents 2-4 (0-1 are > 20 m away)
    behind = np.flatnonzero(~np.asarray(c2) & near)
    assert len(behind) >= 2
    assert np.all(q_idx[behind] == (1 if queued else -1))
    assert np.all(q_idx[~near] == -1)
    assert np.all(q_idx[np.asarray(c2)] == -1)


def test_the_queue_holds_in_encircle_mode():
    """The head reaching the goal (encircle mode) does not cancel the tail's queue behind the last gate."""
    from swarmnav.methods.hes.decision import ENCIRCLE

    m, x, _, _ = _chain_method([True] * 6, [False, False, False, False, True, True], route_is_2=True, mode=ENCIRCLE)
    q_idx, _ = m.part("passage").queue(x, m.labels, m.subs)
    np.testing.assert_array_equal(q_idx, [-1, -1, 1, 1, -1, -1])  # agents 0-1 are beyond passage_queue
    x2 = x.copy()
    x2[3] = [20.5, 9.25]  # in gate 2's mouth: the tube relaxation stays available in encircle mode
    d = m.part("passage").safe_distance(x2, m.labels, np.full(6, P.paper.d_safe), np.zeros((6, 2)))
    assert d[3] == pytest.approx(0.5 * W - P.passage.margin) and d[0] == P.paper.d_safe


def test_the_head_does_not_wait_for_the_tail():
    """On the gates scene the head moves on from gate 1 while the tail still streams through it: when
    the 16th agent crosses gate 1, the head is already well into the bay (>= 4 m past the gate) and
    the sub-swarm's waypoint is past the gate; no corridor behind a crossed passage is ever reported."""
    from swarmnav.methods import registry

    m = registry.make("hes")
    seen = {}
    orig = m.act

    def act(obs, rng, orig=orig):
        a, info = orig(obs, rng)
        k = obs.step
        through = int(np.count_nonzero(obs.positions[:, 0] > 12.4))
        if through >= 16 and "k16" not in seen:
            seen["k16"] = k
            seen["head_x"] = float(obs.positions[:, 0].max())
            seen["wp_x"] = max(float(s.waypoint[0]) for s in m.subs.values())
        for s, sub in m.subs.items():
            for c in m.last_reports[s].corridors:
                for q in m.part("passage").passages(s):
                    if q.crossed[sub.subleader] and not c.direct:
                        assert float(np.dot(c.mid - q.throat.mid, q.throat.normal)) >= 0.0
        return a, info

    m.act = act
    swarmnav.run(m, GATES, seed=2, steps=260)
    assert "k16" in seen
    assert seen["head_x"] >= 12.4 + 4.0
    assert seen["wp_x"] > 12.4


def test_the_last_member_of_a_queue_is_not_held_at_the_mouth(monkeypatch):
    """A lone queued member at rest 1 m in front of gate 1's gap, 0.3 m off its centre line (where the
    last member stalled for good on every gates seed): the base term of eq. (36) from the gate corner
    ahead balances its slot attraction (the eight terms sum to <= 0 along the exit direction), but
    in the tube the repulsion's part against the exit direction is dropped, so the command drives it
    into the gap."""
    from swarmnav.methods.hes.decision import ENCIRCLE

    c1 = [True, False, True, True, True, True]
    m, x, _, _ = _chain_method(c1, [False] * 5 + [True], route_is_2=False, mode=ENCIRCLE)
    x[0], x[1] = [20.0, -2.0], [10.6, -8.93]  # agent 1 alone in front of gate 1
    v = np.zeros_like(x)
    assert m.part("passage").queue(x, m.labels, m.subs)[0][1] == 0  # queued for gate 1
    seen = {}
    terms = hes_control.eq38_terms

    def spy(*args):
        seen["t"] = terms(*args).copy()
        return terms(*args)

    monkeypatch.setattr(hes_control, "eq38_terms", spy)
    step = Step(0, x, v, sense(m, x))  # stages 4-5 of the step, with the sub-swarm kept in encircle mode
    m.part("passage").targets(step, m.subs, m.labels, final=True)
    assert step.own[1] == 0
    references(m, step)
    a = control(m, step)
    assert seen["t"][:, 1].sum(axis=0) @ NORMAL <= 0.0  # the paper's sum holds it at the mouth
    assert a[1] @ NORMAL > 1.0  # passage mode lets it in
    assert seen["t"][7, 1] @ NORMAL < -1.0  # the corner's push-back is there, and is what was dropped


@pytest.mark.parametrize("chained", [False, True])
def test_a_waypoint_behind_a_wall_restarts_from_the_subleader_after_a_chain(chained):
    """After a chain's passages have lapsed (a gates seed stalled this way: the head past gate 5, a
    straggler in front of it, the waypoint pushed off the far side of the wall), a waypoint that the
    subleader sees behind a wall restarts from the subleader; a sub-swarm never routed through a
    passage keeps the paper's waypoint (it only advances toward its target)."""
    m, _, _, _ = _chain_method([True] * 6, [False] * 6, route_is_2=False)
    sub = m.subs[0]
    m.part("passage").set_passages(0, [], chained=chained)
    sub.subleader = 0
    x = np.array([[14.0, -2.0], [15.0, -1.0], [14.5, 0.5], [13.5, -0.5], [9.0, 0.0], [15.5, 1.0]])  # 4 in front
    sub.waypoint = np.array([10.0, -1.0])  # in front of gate 1's wall (x = 11.6..12.4), the head beyond it
    m.act(Observation(0, 0.0, x, np.zeros_like(x)), np.random.default_rng(0))
    assert m.subs[0] is sub and sub.subleader == 0
    if chained:
        assert sub.waypoint[0] > 12.4  # on the head's side of the wall
    else:
        assert sub.waypoint[0] < 11.6


@pytest.mark.parametrize("front", [True, False])
def test_a_passage_outlives_its_memory_while_members_are_in_front_of_it(front):
    """Long after both throats stopped being the route (100 s > passage_memory), gate 1 is still
    remembered while members are in front of it within passage_queue (they keep their queue), and
    forgotten once every member has crossed it; gate 2, crossed by all, lapses."""
    c1 = [not front, not front, True, True, True, True]  # agents 0-1 at (8, -8), (9, -9): in front of gate 1
    m, x, g1, g2 = _chain_method(c1, [True] * 6, route_is_2=False)
    part = m.part("passage")
    k = int(100.0 / P.paper.dt)
    part.remember(0, None, None, x, k)
    assert any(q.throat is g1 for q in part.passages(0)) == front
    assert not any(q.throat is g2 for q in part.passages(0))


def test_passage_relief_widens_a_4m_throat_and_leaves_narrow_ones_alone():
    """A 4 m throat leaves a 1 m band under d_safe = 1.5 m; in its tube d_safe_eff is
    d_safe - passage_relief (band 1.4 m), outside the tube d_safe. A 2.3 m throat keeps
    w/2 - margin, which is already below d_safe - relief."""
    x = MID + np.array([[0.0, 0.0], [0.0, 1.0], [-P.passage.length - 0.1, 0.0]])  # centre, off centre, before the tube
    args = (MID, NORMAL)
    wide = passage_dsafe(x, *args, 4.0, P.paper.d_safe, P.passage.margin, P.passage.length, P.passage.reach, P.passage.relief)
    np.testing.assert_allclose(wide, [P.paper.d_safe - P.passage.relief] * 2 + [P.paper.d_safe])
    narrow = passage_dsafe(x, *args, 2.3, P.paper.d_safe, P.passage.margin, P.passage.length, P.passage.reach, P.passage.relief)
    np.testing.assert_allclose(narrow[:2], 2.3 / 2 - P.passage.margin)
    # which throats are passages: the free band under d_safe narrower than passage_band
    assert 4.0 - 2 * P.paper.d_safe < P.passage.band <= 4.5 - 2 * P.paper.d_safe
