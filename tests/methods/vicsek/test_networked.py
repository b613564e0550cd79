"""The Vicsek family on a network (methods/vicsek/networked.py, docs/network.md): each agent
aligns with the headings, layers and positions it received. On a network that delivers every
message at once, that path flies the ideal path's commands (up to the order of floating-point
sums) from the second step on (the first step's messages carry no heading yet); fed nothing, an
agent flies alone; a run on a lossy network is seeded."""

import numpy as np
import pytest

import swarmnav
from swarmnav.errors import ConfigError
from swarmnav.methods import registry
from swarmnav.methods.base import Observation
from swarmnav.methods.vicsek import MODELS
from swarmnav.sim.network import NetParams, Network, View
from swarmnav.world import from_dict, load_scenario
from swarmnav.world.generators import periodic_box


def _perfect(x, v, published):
    """The view of a network that delivers every state and last publication at once."""
    n = len(x)
    data = {k: np.broadcast_to(np.asarray(r, dtype=float), (n, *np.shape(r))).copy() for k, r in published.items()}
    return View(np.broadcast_to(x, (n, n, 2)).copy(), np.broadcast_to(v, (n, n, 2)).copy(), np.zeros((n, n)), data)


def _side_by_side(model, scn, steps, **params):
    """The ideal path, and the network path on a network that delivers every message at once
    (``net.range = 1e6``: not ideal, but nothing is late, lost or out of range), stepped on the same
    states: their commands and what they published, step by step."""
    ideal, net = registry.make(model, **params), registry.make(model, **params)
    x = scn.spawn_positions(np.random.default_rng(5))
    v = np.zeros_like(x)
    for m in (ideal, net):
        m.reset(scn, x.copy(), v.copy(), np.random.default_rng(5))
    network = Network(NetParams(range=1e6), len(x), 2, ideal.dt, seed=5)
    out = []
    for k in range(steps):
        a, info_a = ideal.act(Observation(k, float(k), x, v), np.random.default_rng(k))
        view = network.step(float(k), x, v)
        # the first step's messages carry nothing yet: there the agents are given the true headings
        # (view None), so that both paths start from the same state
        b, info_b = net.act(Observation(k, float(k), x, v, view if k else None), np.random.default_rng(k))
        network.publish(info_b["publish"])
        out.append((a, b, info_a["publish"], info_b["publish"]))
        x, v = ideal.dynamics.step(x, v, a, ideal.dt)
        if scn.periodic:
            lo, side = scn.bounds[0], scn.bounds[2] - scn.bounds[0]
            x = lo + np.mod(x - lo, side)
    assert network.summary()["net_delivered_fraction"] == 1.0
    return out, ideal.summary(), net.summary()


@pytest.mark.parametrize("model", list(MODELS))
def test_every_state_delivered_at_once_flies_the_ideal_commands(model):
    # circles around the start: agents avoid them (and publish o_j = 1); layers; the information UAV
    scn = from_dict({"name": "ring", "world": {"bounds": [-6.0, -6.0, 12.0, 6.0], "boundary": "open"},
                     "rules": {"contact": "count"}, "goal": {"position": [10.0, 0.0]},
                     "swarm": {"n": 30, "spawn": [-1.5, -1.5, 1.5, 1.5], "min_spacing": 0.0, "clearance": 0.0},
                     "obstacles": [{"type": "circle", "center": c, "radius": 0.3}
                                   for c in ([2.2, 0.4], [0.0, 2.1], [-2.1, -0.5], [0.5, -2.2])]})
    steps, avoided = 60, False
    out, s_ideal, s_net = _side_by_side(model, scn, steps)
    for a, b, pa, pb in out:
        assert np.allclose(a, b, rtol=1e-9, atol=1e-12)
        for name in pa:
            assert np.allclose(pa[name], pb[name], rtol=1e-9, atol=1e-12)
        avoided |= bool(np.any(pa["vicsek_avoiding"]))
    assert avoided  # the obstacle rule flew in the comparison
    assert s_ideal == pytest.approx(s_net, rel=1e-9)


@pytest.mark.parametrize("model", ["vem", "ivem", "hwvem"])
def test_every_state_delivered_at_once_flies_the_ideal_commands_in_a_periodic_box(model):
    # neighbours across the box's seam (minimum image); IVEM compares the raw numbers it publishes
    out, _, _ = _side_by_side(model, periodic_box(60, 4.102), 40, v0=0.03, eta=0.1)
    for a, b, pa, pb in out:
        assert np.allclose(a, b, rtol=1e-9, atol=1e-12)
        if model == "ivem":
            assert np.allclose(pa["vicsek_theta_num"], pb["vicsek_theta_num"], rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("model", list(MODELS))
def test_an_agent_that_hears_nothing_flies_as_if_alone(model):
    # five agents within one interaction radius; agent 2 deaf in the crowd gives the command it
    # gives when the others are far away (the same headings and noise: the same draws)
    base = {"name": "five", "world": {"bounds": [-10.0, -10.0, 10.0, 10.0]}, "goal": {"position": [8.0, 0.0]},
            "swarm": {"n": 5, "spawn": [-1.0, -1.0, 1.0, 1.0]}}
    scn = from_dict(base)
    x = np.array([[0.0, 0.0], [0.5, 0.1], [0.3, 0.4], [-0.3, 0.3], [0.2, -0.5]])
    far = x.copy()
    far[2] = [6.0, 6.0]  # more than r = 1 m from everyone
    v = np.zeros_like(x)

    def command(pos, view):
        m = registry.make(model)
        m.reset(scn, pos.copy(), v.copy(), np.random.default_rng(0))
        a, info = m.act(Observation(0, 0.0, pos, v, view), np.random.default_rng(1))
        return a, info["publish"]

    a_heard, published = command(x, None)
    # every message lost: the agent holds its own state and publications, nothing of the others
    deaf = _perfect(x, v, published)
    deaf = View(deaf.positions, deaf.velocities, np.full((5, 5), np.inf), deaf.data)
    np.fill_diagonal(deaf.age, 0.0)
    a_deaf, _ = command(x, deaf)
    a_alone, _ = command(far, None)
    assert np.allclose(a_deaf[2], a_alone[2], atol=1e-12)
    assert not np.allclose(a_heard[2], a_alone[2])  # with its neighbours heard it does fly differently


def test_a_lossy_network_run_is_seeded_and_total_loss_leaves_every_agent_alone():
    scn = load_scenario("hwvem_mission", n=20)
    opts = {"net.latency": 2.0, "net.loss": 0.3}
    a = swarmnav.run("hwvem", scn, seed=2, steps=60, **opts)
    b = swarmnav.run("hwvem", scn, seed=2, steps=60, **opts)
    assert np.array_equal(a.positions, b.positions) and a.metrics == b.metrics
    ideal = swarmnav.run("hwvem", scn, seed=2, steps=60)
    assert not np.array_equal(a.positions, ideal.positions)
    # no message ever arrives: no agent aligns with or is pushed by another, so every agent but
    # the information UAV keeps its drawn heading (eta = 0) and speed v0 the whole run
    deaf = swarmnav.run("hwvem", scn, seed=2, steps=60, eta=0.0, **{"net.loss": 1.0})
    step = np.diff(deaf.positions, axis=0)
    others = np.arange(20) != int(deaf.metrics["info_uav"])
    assert np.allclose(step[:, others], step[:1, others], atol=1e-12)
    assert np.allclose(np.linalg.norm(step[:, others], axis=2), 0.1)


def test_eq4_layers_need_the_whole_graph_and_are_refused_on_a_network():
    with pytest.raises(ConfigError, match="eq4"):
        swarmnav.run("hwvem", load_scenario("hwvem_mission", n=10), seed=0, steps=3, layer_update="eq4",
                     **{"net.loss": 0.1})
