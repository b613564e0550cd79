"""The APF baseline behaves like a potential field: reaches an open goal, keeps off walls,
keeps agents apart, and saturates its command."""

import numpy as np
import pytest

import swarmnav
from swarmnav.methods.apf import Apf, separation
from swarmnav.methods.base import Observation
from swarmnav.world import from_dict

OPEN = {
    "name": "open", "swarm": {"n": 6, "spawn": [-2.0, -2.0, 2.0, 2.0]}, "goal": {"position": [25.0, 0.0]},
    "obstacles": [{"type": "circle", "center": [100.0, 100.0], "radius": 1.0}],
}


def test_reaches_goal_in_open_space():
    res = swarmnav.run("apf", from_dict(OPEN), seed=1, steps=400)
    assert res.metrics["R_goal"] == 1.0
    assert res.metrics["E_mean"] < 4.0
    assert res.metrics["collisions"] == 0.0


def test_wall_repulsion_points_away_and_saturates():
    scn = from_dict({**OPEN, "obstacles": [{"type": "box", "min": [-5.0, 1.0], "max": [40.0, 2.0]}],
                     "swarm": {"n": 1, "spawn": [-0.01, -0.01, 0.01, 0.01]}})
    m = Apf(k_att=0.0)
    m.reset(scn, None, None, None)
    a, _ = m.act(Observation(0, 0.0, np.array([[0.0, 0.5]]), np.zeros((1, 2))), None)
    assert a[0, 1] < 0 and abs(a[0, 0]) < 1e-9  # pushed straight down, away from the wall above
    assert np.linalg.norm(a) <= m.params.a_max + 1e-12


def test_separation_is_antisymmetric_and_local():
    x = np.array([[0.0, 0.0], [1.0, 0.0], [10.0, 0.0]])
    f = separation(x, 1.0, 2.0, 0.05)
    np.testing.assert_allclose(f[0], -f[1])
    assert f[0, 0] < 0 and np.all(f[2] == 0)
    np.testing.assert_allclose(f.sum(axis=0), 0, atol=1e-12)


def test_apf_in_corridor_keeps_clearance_positive():
    res = swarmnav.run("apf", "default_corridor", seed=2, steps=300)
    assert res.metrics["d_clr_min"] > 0.0  # never inside a wall
    assert np.isfinite(res.metrics["E_mean"])
