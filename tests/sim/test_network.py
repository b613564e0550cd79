"""The network between the agents (swarmnav/sim/network.py, docs/network.md): delay, loss in
bursts, range; seeded; the ideal network changes nothing; a lost message leaves an agent alone."""

import copy
import json
from dataclasses import dataclass

import numpy as np
import pytest

import swarmnav
from swarmnav.errors import ConfigError
from _helpers.cli import run_cli
from swarmnav.methods import registry
from swarmnav.methods.base import Observation
from swarmnav.sim.network import STATE_BYTES, NetParams, Network, View, net_params
from swarmnav.world import from_dict


def _walk(p: NetParams, n=6, steps=400, dt=0.1, seed=3, spread=1.0, rate=None):
    """A network over ``steps`` steps of agents on a line ``spread`` m apart; the views."""
    net = Network(p, n, 2, dt, seed, rate=rate)
    pos = np.c_[np.arange(n) * spread, np.zeros(n)]
    views = [net.step(k * dt, pos + [0.01 * k, 0.0], np.zeros((n, 2))) for k in range(steps)]
    return net, views


def test_latency_makes_every_state_that_much_older():
    net, views = _walk(NetParams(latency=0.25))
    # sent every 0.1 s step, delivered 0.25 s later: the newest state at a step is 0.3 s old
    off = ~np.eye(6, dtype=bool)
    assert np.allclose(views[-1].age[off], 0.3) and np.all(views[-1].age[~off] == 0.0)
    assert np.all(np.isinf(views[0].age[off]))  # nothing has arrived at the first step
    # what agent 0 holds of agent 3 is agent 3's state 3 steps ago
    assert np.allclose(views[-1].positions[0, 3], [3.0 + 0.01 * 396, 0.0])


def test_jitter_spreads_the_ages_within_latency_and_latency_plus_jitter():
    _, views = _walk(NetParams(latency=0.1, jitter=0.5))
    off = ~np.eye(6, dtype=bool)
    ages = np.concatenate([v.age[off] for v in views[50:]])
    assert ages.min() >= 0.1 - 1e-9 and ages.max() <= 0.1 + 0.5 + 0.1 + 1e-9  # + one step to the next send
    assert ages.std() > 0.05


def test_independent_loss_loses_its_fraction():
    net, _ = _walk(NetParams(loss=0.3), steps=2000)
    s = net.summary()
    assert abs(s["net_lost_fraction"] - 0.3) < 0.01  # 60 000 messages: 3 sigma = 0.006
    assert s["net_delivered_fraction"] == pytest.approx(1.0 - s["net_lost_fraction"], abs=1e-3)


def test_bursty_loss_keeps_its_fraction_and_loses_in_runs_of_the_mean_length():
    p = NetParams(loss=0.3, burst=5.0)
    n, steps = 4, 6000
    net = Network(p, n, 2, 0.1, 7)
    pos = np.c_[np.arange(n) * 1.0, np.zeros(n)]
    heard = []
    for k in range(steps):
        v = net.step(k * 0.1, pos, np.zeros((n, 2)))
        heard.append(v.age[0, 1] < 0.05)  # agent 0 got agent 1's state of this very step
    lost = ~np.array(heard[1:])
    assert abs(lost.mean() - 0.3) < 0.03
    runs, k = [], 0
    for x in lost:
        if x:
            k += 1
        elif k:
            runs.append(k)
            k = 0
    assert 4.0 < np.mean(runs) < 6.0  # independent losses at 0.3 would give runs of 1.43


def test_a_publication_travels_with_the_state_it_left_with():
    """A method's payload (info["publish"]) rides in the same messages as the state: late by the
    latency, the row of the step it was published before the message left, never its newer rows."""
    n, dt = 4, 0.1
    net = Network(NetParams(latency=0.25), n, 2, dt, 3)
    pos = np.c_[np.arange(n) * 1.0, np.zeros(n)]
    plans = [f"plan-{j}" for j in range(n)]
    for k in range(20):
        view = net.step(k * dt, pos, np.zeros((n, 2)))
        if k >= 1:
            got = view.payload("heading")
            own = np.arange(n)
            assert np.array_equal(got[own, own, 0], 100 * (k - 1) + own)  # its own last row, at once
            # the state sent at step k - 3 (age 0.3 s) carries the row published at step k - 4
            expect = 100 * (k - 4) + np.arange(n) if k >= 4 else np.full(n, np.nan)
            assert np.array_equal(got[0, :, 0][1:], expect[1:], equal_nan=True)
            assert np.allclose(view.age[0, 1:], 0.3) or k < 3
        net.publish({"heading": (100 * k + np.arange(n))[:, None].astype(float), "plan": plans})
    obj = view.payload("plan")
    assert obj.dtype == object and obj[2, 1] == "plan-1" and view.payload("nothing") is None


def test_a_lost_message_loses_its_publication_too():
    n, dt = 3, 0.1
    net = Network(NetParams(loss=1.0), n, 2, dt, 3)
    pos = np.zeros((n, 2))
    for k in range(5):
        view = net.step(k * dt, pos, np.zeros((n, 2)))
        net.publish({"layer": np.arange(n, dtype=float)})
    got = view.payload("layer")
    off = ~np.eye(n, dtype=bool)
    assert np.all(np.isnan(got[off])) and np.array_equal(np.diag(got), np.arange(n))


def test_observation_received_is_none_under_the_ideal_network():
    obs = Observation(0, 0.0, np.zeros((2, 2)), np.zeros((2, 2)), None)
    assert obs.received("heading") is None


def test_range_keeps_far_agents_unheard():
    _, views = _walk(NetParams(range=2.5), spread=1.0)
    heard = views[-1].heard
    dist = np.abs(np.arange(6)[:, None] - np.arange(6)[None, :])
    assert np.array_equal(heard, dist <= 2)


def test_rate_sends_at_that_rate():
    net, _ = _walk(NetParams(latency=0.01), steps=1000, dt=0.01, rate=10.0)
    assert net.summary()["net_messages"] == pytest.approx(10.0 * 6 * 5 * 10.0, rel=0.02)  # 10 s, 6 x 5 links


def test_same_seed_loses_the_same_messages_and_leaves_the_method_draws_alone():
    scene = "narrow_alternating_gates"
    a = swarmnav.run("vasarhelyi", scene, seed=4, steps=150, **{"net.loss": 0.4, "net.jitter": 0.2})
    b = swarmnav.run("vasarhelyi", scene, seed=4, steps=150, **{"net.loss": 0.4, "net.jitter": 0.2})
    c = swarmnav.run("vasarhelyi", scene, seed=4, steps=150, **{"net.loss": 0.4, "net.jitter": 0.3})
    assert np.array_equal(a.positions, b.positions) and a.metrics == b.metrics
    assert not np.array_equal(a.positions, c.positions)
    assert np.array_equal(a.positions[0], c.positions[0])  # the same spawn: the method's stream is its own
    assert a.config["net"]["loss"] == 0.4


def test_ideal_network_is_no_network():
    assert NetParams().ideal and net_params({}).ideal
    plain = swarmnav.run("olfati-saber", "narrow_alternating_gates", seed=2, steps=120)
    zero = swarmnav.run("olfati-saber", "narrow_alternating_gates", seed=2, steps=120,
                        **{"net.latency": 0.0, "net.loss": 0.0})
    assert np.array_equal(plain.positions, zero.positions) and plain.metrics == zero.metrics
    assert "net" not in zero.config and "net_messages" not in zero.metrics


@pytest.mark.parametrize("method", ["olfati-saber", "vasarhelyi", "apf"])
def test_an_agent_that_hears_nothing_acts_as_if_alone(method):
    # five robots close together; with every message lost, robot 2's command is the one it gives
    # when it is the only robot in the world
    base = {"name": "five", "world": {"bounds": [-10.0, -10.0, 10.0, 10.0]}, "goal": {"position": [8.0, 0.0]}}
    x = np.array([[0.0, 0.0], [0.8, 0.1], [0.4, 0.6], [-0.5, 0.3], [0.2, -0.7]])
    v = np.array([[0.3, 0.0], [0.0, 0.2], [0.1, -0.1], [0.2, 0.2], [-0.1, 0.0]])
    crowd = registry.make(method)
    crowd.reset(from_dict({**base, "swarm": {"n": 5, "spawn": [-1.0, -1.0, 1.0, 1.0]}}), x, v, np.random.default_rng(0))
    deaf = View(np.broadcast_to(x, (5, 5, 2)).copy(), np.broadcast_to(v, (5, 5, 2)).copy(), np.full((5, 5), np.inf))
    np.fill_diagonal(deaf.age, 0.0)
    a_deaf, _ = crowd.act(Observation(0, 0.0, x, v, deaf), np.random.default_rng(0))
    a_all, _ = crowd.act(Observation(0, 0.0, x, v), np.random.default_rng(0))
    alone = registry.make(method)
    one = from_dict({**base, "swarm": {"n": 1, "spawn": [-1.0, -1.0, 1.0, 1.0]}})
    alone.reset(one, x[2:3], v[2:3], np.random.default_rng(0))
    a_alone, _ = alone.act(Observation(0, 0.0, x[2:3], v[2:3]), np.random.default_rng(0))
    assert np.allclose(a_deaf[2], a_alone[0], atol=1e-12)
    assert not np.allclose(a_all[2], a_alone[0])  # with its neighbours heard it does act differently
    truth = View(np.broadcast_to(x, (5, 5, 2)).copy(), np.broadcast_to(v, (5, 5, 2)).copy(), np.zeros((5, 5)))
    if method == "apf":  # stateless: every true picture over the network is the ideal network
        a_true, _ = crowd.act(Observation(0, 0.0, x, v, truth), np.random.default_rng(0))
        assert np.allclose(a_true, a_all, rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("setting, words", [
    ("net.latency=-0.1", "latency"), ("net.loss=1.5", "loss"), ("net.range=-1", "range"),
    ("net.jitter=nan", "jitter"), ("net.lag=1", "unknown parameter 'lag'"),
    ("net.burst=0.5", "burst"), ("net.bandwidth=-1", "bandwidth"),
])
def test_impossible_network_is_one_line_and_exit_2(tmp_path, setting, words):
    extra = ["--set", "net.loss=0.2"] if setting == "net.burst=0.5" else []
    r = run_cli("run", "--method", "vasarhelyi", "--scenario", "default_corridor", "--steps", "5",
                "--out", str(tmp_path / "r"), "--set", setting, *extra)
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert words in r.stderr and len(r.stderr.strip().splitlines()) == 1


@dataclass(frozen=True)
class _NoParams:
    pass


class _Hover:
    """A method of a user's own (a Method instance) that never says it reads the others through the
    network: every agent hovers where it is."""

    name, params, dt, dims = "hover", _NoParams(), 0.1, (2,)

    class dynamics:  # noqa: N801
        @staticmethod
        def step(p, v, command, dt):
            return p + v * dt, v + command * dt

    def reset(self, scenario, positions, velocities, rng):
        pass

    def act(self, obs, rng):
        return -obs.velocities, {}

    def summary(self):
        return {}


def test_a_method_that_cannot_use_the_network_is_refused_in_one_line():
    assert swarmnav.run(_Hover(), "default_corridor", seed=1, steps=5).positions.shape[0] == 6
    with pytest.raises(ConfigError) as e:
        swarmnav.run(_Hover(), "default_corridor", seed=1, steps=5, **{"net.loss": 0.3})
    msg = str(e.value)
    assert "hover does not read the other agents through the network" in msg and "\n" not in msg
    assert all(m in msg for m in ("apf", "olfati-saber", "sph", "vasarhelyi", "vem", "hwvem",
                                  "ego-swarm", "lsc", "nmpc", "mader", "hes"))


def test_the_default_hes_build_flies_a_network_on_the_cli(tmp_path):
    r = run_cli("run", "--method", "hes", "--scenario", "default_corridor", "--steps", "5",
                "--out", str(tmp_path / "r"), "--set", "net.loss=0.3")
    assert r.returncode == 0, r.stderr
    config = json.loads((tmp_path / "r" / "config.json").read_text())
    assert config["net"]["loss"] == 0.3 and config["params"]["passage.on"] is True


# ---------------------------------------------------------------- the trajectory planners (Table II)

PLANNERS = ["ego-swarm", "lsc", "nmpc", "mader"]
_CROWD = {"name": "crowd", "world": {"bounds": [-4.0, -6.0, 14.0, 6.0]}, "goal": {"position": [10.0, 0.0]},
          "obstacles": [{"type": "circle", "center": [5.0, 0.6], "radius": 0.8}]}
# robot 0 behind the others, on the line through robot 1 to the goal: it must plan around them
_X0 = np.array([[-1.3, 0.1], [0.0, 0.0], [-0.6, 0.5], [-0.6, -0.5], [-1.2, -1.0]])


def _fly(method, x, steps, net=None, keep=None, before=None):
    """Fly a planner by hand over ``steps`` steps (every goal the scene's point: goal_disc = 0, so a
    robot's goal does not depend on how many fly), the network ``net`` (None: ideal) between the
    robots; the positions (steps + 1, N, 2). ``before(k, method, x, v)`` is called before each act,
    ``keep(k, method, obs, info)`` after it."""
    scn = from_dict({**_CROWD, "swarm": {"n": len(x), "spawn": [-2.0, -2.0, 1.0, 1.0]}})
    m = registry.make(method, goal_disc=0.0)
    rng = np.random.default_rng(0)
    v = np.zeros_like(x)
    m.reset(scn, x.copy(), v.copy(), rng)
    network = None if net is None else Network(net, len(x), 2, m.dt, seed=0)
    out = [x.copy()]
    for k in range(steps):
        if before is not None:
            before(k, m, x, v)
        view = None if network is None else network.step(k * m.dt, x, v)
        obs = Observation(k, k * m.dt, x, v, view)
        a, info = m.act(obs, rng)
        if keep is not None:
            keep(k, m, obs, info)
        if network is not None and "publish" in info:
            network.publish(info["publish"])
        x, v = m.dynamics.step(x, v, a, m.dt)
        out.append(x.copy())
    return np.array(out)


@pytest.mark.parametrize("method", PLANNERS)
def test_a_planner_that_hears_nothing_plans_alone(method):
    # every message lost: robot 0 flies exactly as it does when it is the only robot in the world
    steps = int(round(2.0 / registry.make(method).dt))  # 2 s
    deaf = _fly(method, _X0, steps, NetParams(loss=1.0))
    alone = _fly(method, _X0[:1], steps)
    crowd = _fly(method, _X0, steps)
    assert np.array_equal(deaf[:, 0], alone[:, 0])
    assert not np.allclose(crowd[:, 0], alone[:, 0], atol=1e-6)  # the neighbours it hears change its flight


@pytest.mark.parametrize("method", ["lsc", "nmpc", "mader"])
def test_a_planner_that_hears_every_message_at_once_flies_the_ideal_run(method):
    # LSC and NMPC plan synchronously from the plans of the previous round, which a network that
    # delivers every message at once has delivered; MADER's robots start their replans at distinct
    # steps (5 robots, 20 steps per replan), so every trajectory committed before a check has arrived
    steps = 150
    ideal = _fly(method, _X0, steps)
    assert np.array_equal(_fly(method, _X0, steps, NetParams(range=1e6)), ideal)


def test_ego_swarm_fed_the_true_plans_replans_as_the_ideal_run_but_after_same_step_commits():
    # EGO-Swarm's robots replan one after another within a step, each seeing the plans committed
    # before it in that step: no network delivers those in time (a plan published in a step travels
    # from the next). Fed every plan committed before the step, a robot replans as in the ideal run
    # unless a robot before it committed in the same step.
    twins, sent = {}, {}

    def before(k, m, x, v):
        if k >= 10 and k % 2 == 0:  # EGO-Swarm's check steps (check_period 0.05 s of 0.02 s steps)
            twins[k] = (copy.deepcopy(m), x.copy(), v.copy())

    def keep(k, m, obs, info):
        sent[k] = info["publish"]["trajectory"]  # this step's rows, as published

    _fly("ego-swarm", _X0, 101, before=before, keep=keep)
    n, compared, tau = len(_X0), 0, np.linspace(0.0, 3.0, 31)
    for k, (twin, x, v) in twins.items():
        truth = np.empty((n, n), dtype=object)
        for i in range(n):
            truth[i, :] = sent[k - 1]
        view = View(np.broadcast_to(x, (n, n, 2)).copy(), np.broadcast_to(v, (n, n, 2)).copy(), np.zeros((n, n)),
                    {"trajectory": truth})
        _, info = twin.act(Observation(k, k * twin.dt, x, v, view), np.random.default_rng(0))
        got, want = info["publish"]["trajectory"], sent[k]
        committed = [r for r in range(n) if want[r] is not sent[k - 1][r]]
        for r in range(n):
            if any(c < r for c in committed):
                continue  # the ideal robot r saw a plan of this step
            assert got[r].start == want[r].start
            assert np.array_equal(got[r].sampler(tau)[0], want[r].sampler(tau)[0])
            compared += r in committed
    assert compared >= 3  # new plans compared, not only the old ones


def test_bandwidth_delays_each_message_by_its_sending_time():
    bits = 8 * STATE_BYTES  # a state message
    net, views = _walk(NetParams(bandwidth=bits / 0.05), rate=10.0)  # 0.05 s on the air, a message every 0.1 s
    s = net.summary()
    assert s["net_dropped_fraction"] == 0.0 and s["net_queue_delay_mean"] == pytest.approx(0.05, rel=1e-9)
    assert s["net_delivered_fraction"] > 0.99
    plain, plain_views = _walk(NetParams(latency=1e-9), rate=10.0)
    # every state arrives one step later than without the limit (0.05 s, delivered at the next 0.1 s step)
    off = ~np.eye(6, dtype=bool)
    assert np.all(views[-1].age[off] >= plain_views[-1].age[off] + 0.1 - 1e-9)


def test_an_overloaded_sender_sends_what_its_bandwidth_carries_and_drops_the_rest():
    bits = 8 * STATE_BYTES
    period, airtime = 0.1, 0.25  # a message due every 0.1 s takes 0.25 s to send
    net, views = _walk(NetParams(bandwidth=bits / airtime), rate=1 / period, steps=2000, dt=0.01)
    s = net.summary()
    # the radio carries one message per 0.25 s of the 0.1 s it is asked for: 60 % dropped
    assert s["net_dropped_fraction"] == pytest.approx(1 - period / airtime, abs=0.01)
    per_sender = s["net_messages"] / (6 * 5)  # messages each of 6 senders put on the air (5 copies each)
    assert per_sender <= 2000 * 0.01 / airtime + 1  # 20 s at one message per 0.25 s, and the first
    # a queued message never waits longer than the send period before it leaves
    assert s["net_queue_delay_mean"] <= period + airtime


def test_a_bandwidth_far_above_the_load_flies_exactly_as_no_limit():
    kw = dict(seed=4, steps=60)
    plain = swarmnav.run("vasarhelyi", "default_corridor", **kw, **{"net.latency": 0.1})
    wide = swarmnav.run("vasarhelyi", "default_corridor", **kw, **{"net.latency": 0.1, "net.bandwidth": 1e12})
    assert np.array_equal(plain.positions, wide.positions)
    assert wide.metrics["net_dropped_fraction"] == 0.0 and "net_dropped_fraction" not in plain.metrics
    narrow = swarmnav.run("vasarhelyi", "default_corridor", **kw, **{"net.latency": 0.1, "net.bandwidth": 2000})
    assert narrow.metrics["net_dropped_fraction"] > 0.5  # 704 bit a message at 10 Hz needs 7 kbit/s
    assert not np.array_equal(plain.positions, narrow.positions)


def test_a_planner_trajectory_counts_its_size_on_the_air():
    from swarmnav.planning.messages import HEADERS, Broadcast, trajectory_bytes

    net = Network(NetParams(bandwidth=1e6), 3, 2, 0.1, 1)
    rec = Broadcast(lambda tau: (np.zeros((len(tau), 2)),), 0.0, 1.0, None, trajectory_bytes(10) - HEADERS)
    net.publish({"trajectory": [rec, None, rec], "heading": np.zeros(3)})
    assert list(net.message_bytes(np.arange(3))) == [STATE_BYTES + trajectory_bytes(10) - HEADERS + 8,
                                                     STATE_BYTES + 8, STATE_BYTES + trajectory_bytes(10) - HEADERS + 8]
