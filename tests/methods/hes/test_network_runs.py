"""HES flown over a non-ideal network (docs/methods/hes-network.md): whole runs through the rollout."""

import inspect

import numpy as np
import pytest

from swarmnav.cli import main
from swarmnav.errors import ConfigError
from swarmnav.methods.hes import networked as NW
from swarmnav.methods.hes.method import Hes
from swarmnav.sim.rollout import run
from swarmnav.world import load_scenario

SCENE = "narrow_alternating_gates"


class Recorder(Hes):
    """HES that keeps, each step, every plan each agent has received from the leader so far, the
    plan each agent flies, the plan the leader published and the labels it returned; and the
    reports sent at the last step."""

    def reset(self, scenario, positions, velocities, rng):
        super().reset(scenario, positions, velocities, rng)
        self.got = [set() for _ in range(len(positions))]
        self.log = []

    def act(self, obs, rng):
        rec = obs.received(NW.PLAN)
        if rec is not None:
            for i, q in enumerate(rec[:, self.leader]):
                if q is not None:
                    self.got[i].add(id(q))
        a, info = super().act(obs, rng)
        plan = info["publish"][NW.PLAN][self.leader]
        self.reports = [m for m in info["publish"][NW.REPORT] if m is not None]  # the reports sent this step
        self.got[self.leader].add(id(plan))
        self.log.append((obs.step, list(self.flown), plan, info["labels"], [set(g) for g in self.got]))
        return a, info


def fly(steps=150, **net):
    h = Recorder(preset="paper")
    r = run(h, SCENE, seed=1, steps=steps, **{f"net.{k}": v for k, v in net.items()})
    return h, r


def check_plans(h):
    """No agent flies a plan it has not received; the leader flies the plan it made this step; the
    run's labels are the leader's plan's."""
    for k, flown, plan, labels, got in h.log:
        assert flown[h.leader] is plan and plan.k == k
        assert np.array_equal(labels, plan.labels)
        for i, q in enumerate(flown):
            assert q is None or (id(q) in got[i] and q.k <= k)


def test_with_every_message_delivered_at_once_each_agent_flies_the_leaders_plan_of_the_step_before():
    h, r = fly(range=1e6)
    assert np.isfinite(r.positions).all()
    check_plans(h)
    plans = {id(p): p for _, _, p, _, _ in h.log}
    for k, flown, plan, _, _ in h.log[1:]:
        assert all(q is plans[id(q)] and q.k == k - 1 for i, q in enumerate(flown) if i != h.leader)
    # the swarm still makes its way: within 25 % of the ideal run's progress toward the goal
    ideal = run(Hes(preset="paper"), SCENE, seed=1, steps=150)
    goal = load_scenario(SCENE).goal_array.astype(float)
    d0 = np.linalg.norm(ideal.positions[0] - goal, axis=1).mean()
    gain_ideal = d0 - np.linalg.norm(ideal.positions[-1] - goal, axis=1).mean()
    gain_net = d0 - np.linalg.norm(r.positions[-1] - goal, axis=1).mean()
    assert gain_ideal > 5.0 and gain_net > 0.75 * gain_ideal


def test_late_and_lost_messages_never_give_an_agent_a_plan_it_has_not_received():
    h, r = fly(latency=0.15, jitter=0.05, loss=0.3)
    assert np.isfinite(r.positions).all() and np.isfinite(r.velocities).all()
    check_plans(h)
    late = [k - q.k for k, flown, _, _, _ in h.log for i, q in enumerate(flown) if q is not None and i != h.leader]
    assert late and min(late) >= 1 and max(late) > 2
    _, again = fly(latency=0.15, jitter=0.05, loss=0.3)  # the same seed loses the same messages
    assert again.positions.tobytes() == r.positions.tobytes()


@pytest.mark.parametrize("preset", ["paper", None])
def test_with_every_message_lost_each_agent_flies_alone(preset):
    h = Recorder(**({} if preset is None else {"preset": preset}))
    r = run(h, SCENE, seed=1, steps=80, **{"net.loss": 1.0})
    assert np.isfinite(r.positions).all()
    check_plans(h)
    for _, flown, _, _, _ in h.log:
        assert all(q is None for i, q in enumerate(flown) if i != h.leader)
    # an agent alone has no slot to fly to but its own position: it brakes to a hover
    speed = np.linalg.norm(r.velocities[-1], axis=1)
    others = np.arange(len(speed)) != h.leader
    assert speed[others].max() < 0.3


def fly_default(scene=SCENE, steps=150, seed=1, **net):
    h = Recorder()
    r = run(h, scene, seed=seed, steps=steps, **{f"net.{k}": v for k, v in net.items()})
    return h, r


def test_the_default_build_delivered_at_once_flies_the_leaders_plan_of_the_step_before():
    h, r = fly_default(range=1e6)
    assert np.isfinite(r.positions).all()
    check_plans(h)
    plans = {id(p): p for _, _, p, _, _ in h.log}
    for k, flown, plan, _, _ in h.log[1:]:
        assert all(q is plans[id(q)] and q.k == k - 1 for i, q in enumerate(flown) if i != h.leader)
    # passage mode, the stall planner and trail following are on, and the plan carries passage mode's rows
    assert all(h.part(name) is not None for name in ("passage", "stall", "trail"))
    assert all(p.own is not None and p.throats is not None for _, _, p, _, _ in h.log)
    # the swarm still makes its way: within 25 % of the ideal run's progress toward the goal
    ideal = run(Hes(), SCENE, seed=1, steps=150)
    goal = load_scenario(SCENE).goal_array.astype(float)
    d0 = np.linalg.norm(ideal.positions[0] - goal, axis=1).mean()
    gain_ideal = d0 - np.linalg.norm(ideal.positions[-1] - goal, axis=1).mean()
    gain_net = d0 - np.linalg.norm(r.positions[-1] - goal, axis=1).mean()
    assert gain_ideal > 5.0 and gain_net > 0.75 * gain_ideal


@pytest.mark.parametrize("scene", [SCENE, "default_corridor"])
def test_the_default_build_flies_200_ms_latency_and_10_percent_loss(scene):
    h, r = fly_default(scene, steps=400, latency=0.2, loss=0.1)
    assert np.isfinite(r.positions).all() and np.isfinite(r.velocities).all()
    check_plans(h)
    late = [k - q.k for k, flown, _, _, _ in h.log for i, q in enumerate(flown) if q is not None and i != h.leader]
    # a plan leaves with the next step's message and is 200 ms (2 steps of 0.1 s) on its way; some are lost
    assert late and min(late) == 3 and max(late) > 4
    assert 0.85 < r.metrics["net_delivered_fraction"] < 0.95
    _, again = fly_default(scene, steps=400, latency=0.2, loss=0.1)  # the same seed loses the same messages
    assert again.positions.tobytes() == r.positions.tobytes()
    assert again.metrics["net_delivered_fraction"] == r.metrics["net_delivered_fraction"]


def test_the_default_build_routes_queued_members_through_the_throats_its_plan_carries():
    """In the gates on a late, lossy network passage mode remembers throats in the leader's
    planner, and the plans the agents fly carry them with the members' queues."""
    h, r = fly_default(steps=500, latency=0.1, loss=0.1)
    flown = [q for _, fl, _, _, _ in h.log for i, q in enumerate(fl) if q is not None and i != h.leader]
    assert any(q.throats for q in flown) and any((q.own >= 0).any() for q in flown)
    # the plan's size counts what it carries: every row, and 44 B a throat
    q = max(flown, key=lambda q: sum(map(len, q.throats.values())))
    base = 8 + sum(a.nbytes for a in (q.labels, q.group, q.sl_idx, q.wp, q.nav, q.planned, q.slot, q.speed,
                                        q.own, q.routed))
    assert q.nbytes == base + 44 * sum(map(len, q.throats.values())) + (
        0 if q.field_pt is None else q.field_pt.nbytes + q.field_half.nbytes)
    # a report counts its ring (360 rays of 8 B) and the members' nearest returns passage mode adds
    assert h.reports and all(m.nbytes > 8 * 360 + m.ring_min.nbytes for m in h.reports)


def test_the_cli_flies_hes_on_a_lossy_late_network(tmp_path):
    assert main(["run", "--method", "hes", "--scenario", SCENE, "--horizon", "3", "--set", "preset=paper",
                 "--set", "net.latency=0.15", "--set", "net.loss=0.3", "--out", str(tmp_path / "r"),
                 "--quiet"]) == 0


def test_the_network_step_reads_no_other_agent_through_the_true_states():
    src = inspect.getsource(Hes._act_networked)
    assert "obs.positions[" not in src and "obs.velocities[" not in src and "obs.others" not in src
