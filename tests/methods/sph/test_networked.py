"""SPH on a network (methods/sph/networked.py, docs/network.md): each robot sums its own directed
pairs from what it received. Fed every robot's true state, that path gives the ideal path's
commands (up to the order of floating-point sums); fed nothing, a robot acts alone."""

import numpy as np
import pytest

import swarmnav
from swarmnav.methods import registry
from swarmnav.methods.base import Observation
from swarmnav.sim.network import View
from swarmnav.world import load_scenario

FOREST = "random_forest:density=0.35,seed=3,length=12,r_min=1.0,r_max=2.0,min_passage=1.0,spawn_length=8"


def _state(n: int, steps: int):
    """A scene and the swarm's state after ``steps`` steps of the ideal default build."""
    scn = load_scenario(FOREST, n=n)
    res = swarmnav.run("sph", scn, seed=3, steps=steps)
    return scn, res.positions[-1], res.velocities[-1]


def _commands(scn, x, v, view, **params):
    m = registry.make("sph", **params)
    m.reset(scn, x.copy(), v.copy(), np.random.default_rng(0))
    out = []
    for k in range(3):
        a, info = m.act(Observation(k, 0.01 * k, x, v, view), np.random.default_rng(0))
        out.append((a, info["labels"]))
    return out, m.summary()


@pytest.mark.parametrize("n, params", [(30, {}), (15, {"plan_neighbours": 1.0})])
def test_true_states_over_the_network_give_the_ideal_commands(n, params):
    # 30 robots: the crowd parts (pair guard, cut-off, crowd guard) and yielding fly; 15 robots with
    # plan_neighbours: the planner's neighbour cost reads the pictures
    scn, x, v = _state(n, 1500)
    truth = View(np.broadcast_to(x, (n, n, 2)).copy(), np.broadcast_to(v, (n, n, 2)).copy(), np.zeros((n, n)))
    ideal, s_ideal = _commands(scn, x, v, None, **params)
    net, s_net = _commands(scn, x, v, truth, **params)
    for (a, lab), (b, lab2) in zip(ideal, net):
        assert np.allclose(a, b, rtol=1e-9, atol=1e-9)
        assert np.array_equal(lab, lab2)
    assert s_ideal["sph_waiting_fraction"] == s_net["sph_waiting_fraction"]
    if n == 30:
        assert s_ideal["sph_pair_guarded_fraction"] == s_net["sph_pair_guarded_fraction"]


def test_a_robot_that_hears_nothing_acts_alone():
    n = 30
    scn, x, v = _state(n, 1500)
    deaf = View(np.broadcast_to(x, (n, n, 2)).copy(), np.broadcast_to(v, (n, n, 2)).copy(), np.full((n, n), np.inf))
    np.fill_diagonal(deaf.age, 0.0)
    (a, labels), _ = _commands(scn, x, v, deaf)[0][0], None
    assert len(np.unique(labels)) == n  # nobody sees anybody: every robot its own sub-swarm
    m = registry.make("sph")
    m.reset(scn, x.copy(), v.copy(), np.random.default_rng(0))
    ideal, _ = m.act(Observation(0, 0.0, x, v), np.random.default_rng(0))
    assert not np.allclose(a, ideal)  # the neighbours it hears do change what it does


def test_sph_flies_the_real_flight_network():
    # Section IV-B: 10 robots sharing positions at 10 Hz over Wi-Fi; here 150 ms +- 50 ms, 10 % loss
    scn = load_scenario(FOREST.replace("density=0.35", "density=0.15"), n=10)
    opts = {"net.latency": 0.15, "net.jitter": 0.05, "net.loss": 0.1}
    a = swarmnav.run("sph", scn, seed=1, horizon=5.0, **opts)
    b = swarmnav.run("sph", scn, seed=1, horizon=5.0, **opts)
    assert np.array_equal(a.positions, b.positions)
    assert a.metrics["net_rate_hz"] == 10.0  # SPH's own broadcast rate, Section IV-A
    assert 0.85 < a.metrics["net_delivered_fraction"] < 0.95
