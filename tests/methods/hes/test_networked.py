"""HES's stages on each agent's own picture of the others (methods/hes/networked.py).

Oracles: fed the true states and one plan for all, the picture kernels give the ideal control
stage's couplings and commands, the ideal braking barriers and every report of a run bit for bit;
agent i's command from its picture is the ideal command of a swarm standing where agent i
believes the others to be (the agents it has not heard left out); an agent that has heard nobody
flies as a swarm of one. The plan travels over the real network: a step late when every message
arrives at once, never one an agent did not receive, only the leader's own when all are lost."""

import numpy as np
import pytest

from swarmnav.methods.hes import control as C
from swarmnav.methods.hes import forces as F
from swarmnav.methods.hes import networked as NW
from swarmnav.methods.hes.neighbours import neighbour_rows
from swarmnav.methods.hes.params import HesParams

P = HesParams()
G = F.gain_vector(P)
R = 360
TH = 2 * np.pi * np.arange(R) / R
COS, SIN = np.cos(TH), np.sin(TH)
REACH = max(P.core.r_sep, P.core.d_ir)


def random_case(rng, n, spread=6.0):
    """A random swarm of n agents in up to three sub-swarms (a subleader each), with rings that
    see a few walls, a slot, a c_s and a mode each."""
    x = rng.uniform(-spread, spread, (n, 2))
    v = rng.normal(size=(n, 2))
    labels = rng.integers(0, 3, n)
    sl = np.array([np.flatnonzero(labels == g)[0] for g in labels])
    ring = np.full((n, R), P.paper.lidar_range)
    for i in range(n):
        for _ in range(int(rng.integers(0, 4))):
            r0 = int(rng.integers(0, R))
            ring[i, r0:r0 + 40] = rng.uniform(0.3, 15.0) + rng.uniform(0, 1, len(ring[i, r0:r0 + 40]))
    return dict(x=x, v=v, labels=labels, sl=sl, wp=x + rng.normal(size=(n, 2)), nav=rng.random(n) < 0.7,
                slot=x + rng.normal(size=(n, 2)), speed=rng.uniform(0.5, 3.0, n),
                sig=rng.choice([0.0, 0.2, 1.0], (n, 4), p=[0.1, 0.2, 0.7]), ring=ring,
                dsafe=rng.uniform(0.5, P.paper.d_safe, n))


def ideal(c):
    """The ideal control stage's couplings (``control.couple``) and eq. (38) command."""
    x, v, labels = c["x"], c["v"], c["labels"]
    ids = np.unique(labels)
    col = np.searchsorted(ids, labels)
    sub_sl = np.array([c["sl"][np.flatnonzero(labels == s)[0]] for s in ids])
    rows = neighbour_rows(x, REACH)
    # c_s and the mode per sub-swarm: the test gives them per agent, so read them at the subleader
    sub_wp, sub_nav = c["wp"][sub_sl], c["nav"][sub_sl]
    sl_idx, wp, nav, follower, cent, nn = C.couple(x, labels, col, sub_sl, sub_wp, sub_nav, *rows)
    a = C.eq38(x, v, labels, sl_idx, follower, cent, wp, nav, c["slot"], c["speed"], P.core.eps_v, nn, c["sig"],
               c["ring"], COS, SIN, G, c["dsafe"], *rows)
    return dict(sl_idx=sl_idx, wp=wp, nav=nav, follower=follower, cent=cent, nn=nn, a=a)


def known(c, plan, kx, kv, heard, lab):
    """The picture kernels' couplings and eq. (38) command; ``plan`` gives each agent's subleader,
    c_s and mode (``sl_idx``, ``wp``, ``nav``)."""
    x, v = c["x"], c["v"]
    planned = plan["sl_idx"] != np.arange(len(x))
    cent, nn, nn_pos, sl_pos, sl_vel, follower = NW.couple_known(x, v, kx, kv, heard, lab, plan["sl_idx"], planned)
    a = NW.eq38_known(x, v, kx, heard, lab, sl_pos, sl_vel, follower, cent, nn, nn_pos, plan["wp"], plan["nav"],
                      c["slot"], c["speed"], P.core.eps_v, c["sig"], c["ring"], COS, SIN, G, c["dsafe"])
    return dict(cent=cent, nn=nn, nn_pos=nn_pos, sl_pos=sl_pos, sl_vel=sl_vel, follower=follower, a=a)


def true_pictures(x, v, labels):
    """What ``Observation.known()`` gives under the ideal network, and one plan for all."""
    n = len(x)
    return (np.broadcast_to(x, (n, n, 2)), np.broadcast_to(v, (n, n, 2)), np.ones((n, n), dtype=bool),
            np.ascontiguousarray(np.broadcast_to(labels, (n, n))))


@pytest.mark.parametrize("n_max,spread", [(30, 6.0), (90, 25.0)])  # 90: the cell-list neighbour rows
def test_true_pictures_give_the_ideal_couplings_and_commands_bit_for_bit(n_max, spread):
    rng = np.random.default_rng(3)
    for _ in range(60):
        n = int(rng.integers(1, n_max))
        c = random_case(rng, n, spread)
        ref = ideal(c)
        got = known(c, ref, *true_pictures(c["x"], c["v"], c["labels"]))
        assert np.array_equal(got["nn"], ref["nn"])
        assert np.array_equal(got["follower"], ref["follower"])
        assert got["cent"].tobytes() == ref["cent"].tobytes()
        assert got["a"].tobytes() == ref["a"].tobytes()  # the same bits, signed zeros included
        # eq. (30)'s segments from the pictured partners are the ideal ones
        P1, Q1, P2, Q2 = (np.empty((4 * n, 2)) for _ in range(4))
        C.occlusion_segments(c["x"], c["slot"], ref["nn"], ref["sl_idx"], ref["cent"], P1, Q1)
        NW.occlusion_segments_known(c["x"], c["slot"], got["nn_pos"], got["sl_pos"], got["cent"], P2, Q2)
        assert np.array_equal(P1, P2) and np.array_equal(Q1, Q2)


def test_each_agent_flies_the_ideal_command_of_the_swarm_it_pictures():
    """Stale, partial pictures and a plan of its own per agent: agent i's command is the ideal
    command of agent i in the swarm made of itself (true state) and the agents it has heard, at
    the states it last received, grouped as its own plan says."""
    rng = np.random.default_rng(8)
    for _ in range(40):
        n = int(rng.integers(2, 25))
        c = random_case(rng, n)
        x, v = c["x"], c["v"]
        kx = x[None] + rng.normal(0, 0.8, (n, n, 2))  # stale pictures
        kv = v[None] + rng.normal(0, 0.5, (n, n, 2))
        heard = rng.random((n, n)) < 0.7
        lab = np.where(rng.random((n, n)) < 0.2, rng.integers(0, 3, (n, n)), c["labels"][None])  # plans differ
        for i in range(n):
            kx[i, i], kv[i, i], heard[i, i] = x[i], v[i], True
        sl_idx = np.array([np.flatnonzero(lab[i] == lab[i, i])[0] for i in range(n)])
        # each agent's own plan: its subleader, c_s and mode
        got = known(c, dict(sl_idx=sl_idx, wp=c["wp"], nav=c["nav"]), kx, kv, heard, lab)
        for i in range(n):
            keep = np.flatnonzero(heard[i])
            me = int(np.flatnonzero(keep == i)[0])
            sub = {k: c[k][keep] for k in ("wp", "nav", "slot", "speed", "sig", "ring", "dsafe")}
            sub.update(x=kx[i, keep], v=kv[i, keep], labels=lab[i, keep])
            # agent i's subleader as it knows it: itself when that agent is unheard (no coupling)
            s = sl_idx[i]
            sub_sl = np.array([np.flatnonzero(sub["labels"] == g)[0] for g in sub["labels"]])
            if s != i and heard[i, s]:
                sub_sl[sub["labels"] == lab[i, i]] = int(np.flatnonzero(keep == s)[0])
            else:
                sub_sl[sub["labels"] == lab[i, i]] = me
            sub["sl"] = sub_sl
            sub["wp"][sub_sl[me]], sub["nav"][sub_sl[me]] = c["wp"][i], c["nav"][i]  # read at the subleader
            ref = ideal(sub)
            assert got["follower"][i] == ref["follower"][me]
            assert got["cent"][i].tobytes() == ref["cent"][me].tobytes()
            assert (got["nn"][i] < 0) == (ref["nn"][me] < 0)
            if got["nn"][i] >= 0:
                assert keep[ref["nn"][me]] == got["nn"][i]
            np.testing.assert_allclose(got["a"][i], ref["a"][me], rtol=1e-12, atol=1e-12)


def test_an_agent_that_heard_nobody_flies_alone():
    rng = np.random.default_rng(21)
    for _ in range(30):
        n = int(rng.integers(2, 20))
        c = random_case(rng, n)
        x, v = c["x"], c["v"]
        kx = np.full((n, n, 2), np.nan)  # nothing received: NaN pictures, as the network gives
        kv = np.full((n, n, 2), np.nan)
        heard = np.eye(n, dtype=bool)
        for i in range(n):
            kx[i, i], kv[i, i] = x[i], v[i]
        lab = np.ascontiguousarray(np.broadcast_to(c["labels"], (n, n)))
        ref_all = ideal(c)
        got = known(c, ref_all, kx, kv, heard, lab)
        assert np.isfinite(got["a"]).all()
        assert not got["follower"].any() and (got["nn"] < 0).all()
        assert np.array_equal(got["cent"], x)
        for i in range(n):  # the ideal command of a swarm of one
            one = {k: c[k][i:i + 1] for k in ("x", "v", "slot", "speed", "sig", "ring", "dsafe")}
            one.update(labels=np.zeros(1, dtype=np.int64), sl=np.zeros(1, dtype=np.int64),
                       wp=ref_all["wp"][i:i + 1], nav=ref_all["nav"][i:i + 1])
            assert got["a"][i].tobytes() == ideal(one)["a"][0].tobytes()


def test_an_agent_reads_only_its_own_row_of_pictures():
    rng = np.random.default_rng(4)
    n = 12
    c = random_case(rng, n)
    x, v = c["x"], c["v"]
    kx, kv, heard, lab = (np.array(a) for a in true_pictures(x, v, c["labels"]))
    ref = ideal(c)
    base = known(c, ref, kx, kv, heard, lab)["a"]
    kx[5] += rng.normal(0, 1.0, (n, 2))  # agent 5's picture changes, its own entry too (ignored)
    kv[5] += rng.normal(0, 1.0, (n, 2))
    heard[5, :3] = False
    lab[5, 7:] = 9
    got = known(c, ref, kx, kv, heard, lab)["a"]
    others = np.arange(n) != 5
    assert got[others].tobytes() == base[others].tobytes()
    assert not np.array_equal(got[5], base[5])


def picture_control(h, step):
    """The control stage on the pictures the ideal network gives, each agent flying the planner's
    current plan (``plan_rows``)."""
    n = step.n
    kx, kv = np.broadcast_to(step.x, (n, n, 2)), np.broadcast_to(step.v, (n, n, 2))
    labels, group, sl_idx, wp, nav, planned = NW.plan_rows(h, step)
    lab, coh = (np.ascontiguousarray(np.broadcast_to(a, (n, n))) for a in (labels, group))
    heard = np.ones((n, n), dtype=bool)
    trail = h.part("trail")
    if trail is not None:  # each agent's trail of its pictures: here the true positions
        trail.observe_known(step, NW.Picture(step.k, kx, kv, heard, lab, [None] * n))
    return NW.control_known(h, step, kx, kv, heard, lab, coh, sl_idx, wp, nav, planned)


@pytest.mark.parametrize("scene, overrides, steps", [
    ("dense_cross_blocks", {}, 600),  # trail following: members cut off in the crosses' corners
    ("narrow_alternating_gates", {"stall.time": 1.0}, 300),  # the stall planner engaged early
])
def test_the_default_builds_parts_on_true_pictures_fly_the_ideal_run_bit_for_bit(scene, overrides, steps, monkeypatch):
    """Trail following and the stall planner through their network hooks (each agent's trail of
    its pictures, the field's look-ahead carried by the plan), fed the true states: the ideal run."""
    from swarmnav.methods.hes import method as M
    from swarmnav.methods.hes.method import Hes
    from swarmnav.sim.rollout import run

    ref_h = Hes(**overrides)
    ref = run(ref_h, scene, seed=2, steps=steps)
    cut, engaged = [], []

    def control(h, step):
        a = picture_control(h, step)
        cut.append(int(h.part("trail").last_cut.sum()))
        engaged.append(any(h.part("stall").engaged(s) for s in h.subs))
        return a

    monkeypatch.setattr(M, "control", control)
    got = run(Hes(**overrides), scene, seed=2, steps=steps)
    assert any(cut) if scene == "dense_cross_blocks" else any(engaged)
    assert got.positions.tobytes() == ref.positions.tobytes()
    assert got.velocities.tobytes() == ref.velocities.tobytes()


@pytest.mark.parametrize("preset", [None, "paper"])
def test_a_run_flown_on_true_pictures_is_the_ideal_run_bit_for_bit(preset, monkeypatch):
    """The whole control stage (occlusion, the parts' hooks, agents routed on their own) on true
    pictures: the run is the ideal one, every position the same bits."""
    from swarmnav.methods.hes import method as M
    from swarmnav.methods.hes.method import Hes
    from swarmnav.sim.rollout import run

    kw = {} if preset is None else {"preset": preset}
    ref = run(Hes(**kw), "narrow_alternating_gates", seed=2, steps=400)
    seen = []
    monkeypatch.setattr(M, "control", lambda h, step: seen.append(step.n_own) or picture_control(h, step))
    got = run(Hes(**kw), "narrow_alternating_gates", seed=2, steps=400)
    assert len(seen) == 400
    if preset is None:  # our passage mode routes queued members on their own in these gates
        assert any(seen)
    assert got.positions.tobytes() == ref.positions.tobytes()
    assert got.velocities.tobytes() == ref.velocities.tobytes()


def synthetic_plan(k, n, rng):
    labels = rng.integers(0, 2, n)
    sl = np.array([np.flatnonzero(labels == g)[0] for g in labels])
    return NW.Plan(k, labels, labels.copy(), sl, rng.normal(size=(n, 2)), rng.random(n) < 0.5, sl != np.arange(n),
                   rng.normal(size=(n, 2)), rng.uniform(0.5, 2.0, n))


def fly_plans(net_options, steps=60, n=8, leader=3):
    """The leader publishes a new plan every step over a real network; every agent flies the plan
    :func:`plans_flown` gives. Returns the published plans and each step's flown plans."""
    from swarmnav.sim.network import Network, net_params

    rng = np.random.default_rng(0)
    dt = 0.05
    net = Network(net_params(net_options), n, 2, dt, seed=1)
    pos, vel = rng.uniform(-5, 5, (n, 2)), np.zeros((n, 2))
    flown, published, history = [None] * n, [], []
    for k in range(steps):
        view = net.step(k * dt, pos, vel)
        flown = NW.plans_flown(view.payload(NW.PLAN), leader, flown)
        history.append(list(flown))
        plan = synthetic_plan(k, n, rng)
        published.append(plan)
        net.publish({NW.PLAN: NW.publication(plan, leader, n)})
    return published, history


def test_with_every_message_delivered_at_once_every_agent_flies_the_plan_of_the_step_before():
    published, history = fly_plans({"net.range": 1e6})
    assert all(q is None for q in history[0])  # nothing published before the first step
    for k in range(1, len(history)):
        assert all(q is published[k - 1] for q in history[k])


def test_no_agent_flies_a_plan_it_has_not_received_and_none_goes_back_in_time():
    published, history = fly_plans({"net.latency": 0.15, "net.jitter": 0.1, "net.loss": 0.4})
    ids = {id(q) for q in published}
    n = len(history[0])
    for i in range(n):
        ks = [q.k if q is not None else -1 for q in (h[i] for h in history)]
        assert ks == sorted(ks)  # out-of-order arrivals never replace a newer plan
        assert all(q is None or (id(q) in ids and q.k < k) for k, q in enumerate(h[i] for h in history))
    late = [k - h[i].k for k, h in enumerate(history) for i in range(n) if h[i] is not None]
    assert min(late) >= 1 and max(late) > 3  # 0.15-0.25 s late and lost: several steps behind at times


def test_with_every_message_lost_only_the_leader_has_a_plan():
    published, history = fly_plans({"net.loss": 1.0})
    for k, h in enumerate(history[1:], start=1):
        assert h[3] is published[k - 1]  # its own publication, at once
        assert all(q is None for i, q in enumerate(h) if i != 3)


def test_an_agent_without_a_plan_flies_alone_and_the_others_their_own_rows():
    rng = np.random.default_rng(6)
    n = 9
    c = random_case(rng, n)
    x, v = c["x"], c["v"]
    plan = synthetic_plan(5, n, rng)
    plans = [plan] * n
    plans[4] = None
    lab, coh, sl_idx, wp, nav, planned, slot, speed = NW.flown_rows(plans, x)
    has = np.arange(n) != 4
    assert np.array_equal(lab[has], np.broadcast_to(plan.labels, (n - 1, n)))
    for a, b in ((sl_idx, plan.sl_idx), (wp, plan.wp), (nav, plan.nav), (planned, plan.planned), (slot, plan.slot),
                 (speed, plan.speed)):
        assert np.array_equal(a[has], b[has])
    assert sl_idx[4] == 4 and not planned[4] and not nav[4] and speed[4] == 0.0
    assert np.array_equal(slot[4], x[4]) and np.array_equal(wp[4], x[4])
    # on true pictures of everyone: agent 4 is a group of its own and brakes (eq. 24 with v* = 0)
    kx, kv, heard, _ = true_pictures(x, v, plan.labels)
    cent, nn, nn_pos, sl_pos, sl_vel, follower = NW.couple_known(x, v, kx, kv, heard, coh, sl_idx, planned)
    assert nn[4] == -1 and not follower[4] and np.array_equal(cent[4], x[4])
    a = NW.eq38_known(x, v, kx, heard, lab, sl_pos, sl_vel, follower, cent, nn, nn_pos, wp, nav, slot, speed,
                      P.core.eps_v, c["sig"], c["ring"], COS, SIN, G, c["dsafe"])
    one = {k: c[k][4:5] for k in ("x", "v", "sig", "ring", "dsafe")}
    one.update(labels=np.zeros(1, dtype=np.int64), sl=np.zeros(1, dtype=np.int64), wp=x[4:5], nav=np.zeros(1, bool),
               slot=x[4:5], speed=np.zeros(1))
    sep = NW.separation_known(x, kx, heard, lab, G[F.G_KSEP], P.core.r_sep, P.core.d_floor, False)[4]
    np.testing.assert_allclose(a[4], ideal(one)["a"][0] + sep, rtol=1e-12, atol=1e-12)  # it still keeps apart


def braking_case(rng, n):
    """Agents packed close (0.3-3 m apart), moving fast toward each other, with random commands."""
    x = rng.uniform(-2.0, 2.0, (n, 2))
    v = rng.normal(0, 2.0, (n, 2))
    a = rng.normal(0, 4.0, (n, 2))
    a *= np.minimum(1.0, P.a_bound / np.linalg.norm(a, axis=1))[:, None]
    return x, v, a


def test_the_braking_barriers_on_true_pictures_are_the_ideal_ones_bit_for_bit():
    from swarmnav.methods.hes.parts import barriers as B

    rng = np.random.default_rng(12)
    dt, brake, margin = P.paper.dt, 3.0, 0.5
    moved = 0
    for _ in range(200):
        n = int(rng.integers(1, 20))
        x, v, a = braking_case(rng, n)
        kx, kv, heard, _ = true_pictures(x, v, np.zeros(n, dtype=np.int64))
        active = rng.random(n) < 0.6
        ref = B.agent_barrier(a, x, v, active, dt, brake, margin, 2.0)
        assert NW.agent_barrier_known(a, x, v, kx, kv, heard, active, dt, brake, margin, 2.0).tobytes() == ref.tobytes()
        ref = B.agent_guard(a, x, v, dt, brake, margin, P.a_bound)
        assert NW.agent_guard_known(a, x, v, kx, kv, heard, dt, brake, margin, P.a_bound).tobytes() == ref.tobytes()
        moved += not np.array_equal(ref, a)
    assert moved > 100  # the guard binds in most cases


def test_each_agent_brakes_for_the_swarm_it_pictures():
    from swarmnav.methods.hes.parts import barriers as B

    rng = np.random.default_rng(13)
    dt, brake, margin = P.paper.dt, 3.0, 0.5
    for _ in range(60):
        n = int(rng.integers(2, 15))
        x, v, a = braking_case(rng, n)
        kx = x[None] + rng.normal(0, 0.4, (n, n, 2))
        kv = v[None] + rng.normal(0, 0.5, (n, n, 2))
        heard = rng.random((n, n)) < 0.7
        for i in range(n):
            kx[i, i], kv[i, i], heard[i, i] = x[i], v[i], True
        guard = NW.agent_guard_known(a, x, v, kx, kv, heard, dt, brake, margin, P.a_bound)
        barrier = NW.agent_barrier_known(a, x, v, kx, kv, heard, np.ones(n, dtype=bool), dt, brake, margin, 2.0)
        for i in range(n):
            keep = np.flatnonzero(heard[i])
            me = int(np.flatnonzero(keep == i)[0])
            xs, vs, as_ = kx[i, keep], kv[i, keep], a[keep]
            assert guard[i].tobytes() == B.agent_guard(as_, xs, vs, dt, brake, margin, P.a_bound)[me].tobytes()
            only = keep == i
            assert barrier[i].tobytes() == B.agent_barrier(as_, xs, vs, only, dt, brake, margin, 2.0)[me].tobytes()


def same_report(a, b):
    pa, pb = a.pack, b.pack
    assert (pa.sid, pa.subleader) == (pb.sid, pb.subleader)
    for f in ("members", "positions", "velocities", "centroid", "subleader_position"):
        assert np.asarray(getattr(pa, f)).tobytes() == np.asarray(getattr(pb, f)).tobytes(), f
    assert a.clearance == b.clearance and len(a.corridors) == len(b.corridors)
    for c, d in zip(a.corridors, b.corridors):
        assert c.mid.tobytes() == d.mid.tobytes() and c.width == d.width and c.cost == d.cost


@pytest.mark.parametrize("preset", [None, "paper"])
def test_a_subleaders_report_from_true_pictures_is_the_ideal_report(preset, monkeypatch):
    """Every report of a run, made again by its subleader from true pictures and every member's
    published nearest return: the same Pack, corridors and clearance."""
    from swarmnav.methods.hes import method as M
    from swarmnav.methods.hes.method import Hes
    from swarmnav.sim.rollout import run

    calls = []

    def checked(h, step, s):
        ref = original(h, step, s)
        n = step.n
        kx, kv, heard, _ = true_pictures(step.x, step.v, np.zeros(n, dtype=np.int64))
        same_report(NW.report_known(h, step, s, kx, kv, heard, np.broadcast_to(step.ring_min, (n, n))), ref)
        calls.append(s)
        return ref

    original = M.report
    monkeypatch.setattr(M, "report", checked)
    r = run(Hes(**({} if preset is None else {"preset": preset})), "dense_cross_blocks", seed=2, steps=250)
    assert len(calls) >= 250 and len(set(calls)) > 1  # a split happened: more than one sub-swarm reported
    assert r.events


def test_a_subleader_reports_only_the_members_it_heard():
    from swarmnav.methods.hes.method import Hes
    from swarmnav.sim.rollout import run

    h = Hes()
    run(h, "narrow_alternating_gates", seed=2, steps=5)
    step = h.last_step
    n, s = step.n, 0
    a = h.subs[s].subleader
    kx, kv, heard, _ = (np.array(q) for q in true_pictures(step.x, step.v, np.zeros(n, dtype=np.int64)))
    lost = [j for j in range(n) if j != a][:3]
    heard[a, lost] = False
    kx[a, lost] = np.nan  # never heard: NaN, as the network gives
    rm = np.array(np.broadcast_to(step.ring_min, (n, n)))
    rm[a, lost] = np.nan
    rep = NW.report_known(h, step, s, kx, kv, heard, rm)
    assert a in rep.pack.members and not set(lost) & set(rep.pack.members.tolist())
    assert len(rep.pack.members) == n - 3 and np.isfinite(rep.pack.positions).all()
    keep = np.setdiff1d(np.arange(n), lost)
    np.testing.assert_allclose(rep.pack.centroid, step.x[keep].mean(axis=0), rtol=1e-12)
    assert rep.clearance == step.ring_min[keep].min()
