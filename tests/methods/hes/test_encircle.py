"""The circulating encircle ring near an obstacle: ``core.enc_yield`` bends it around the obstacle."""

import numpy as np

import swarmnav
from swarmnav.methods.hes import Hes
from swarmnav.world import from_dict

# a separator ending 7 m before the goal, 1 m outside the 6 m ring (default_corridor's layout, small)
TIP = {"name": "tip", "swarm": {"n": 8, "spawn": [-3.0, -3.0, 3.0, 3.0]}, "goal": {"position": [20.0, 0.0]},
       "obstacles": [{"type": "box", "min": [4.0, -0.4], "max": [13.0, 0.4]}]}


def test_yielding_ring_keeps_its_members_out_of_d_safe_and_keeps_turning():
    d_safe = Hes().params.paper.d_safe
    unsafe, speed = {}, {}
    for y in (0.0, 3.5):
        res = swarmnav.run("hes", from_dict(TIP), seed=3, steps=600, **{"core.enc_orbit": True, "core.enc_yield": y})
        late = res.clearance[300:].min(axis=1)  # the last 30 s: on the ring
        unsafe[y] = float(np.mean(late < d_safe))
        speed[y] = float(np.linalg.norm(res.velocities[300:], axis=2).mean())
        assert res.metrics["R_goal"] == 1.0
    # the plain ring brings a member within d_safe of the separator's end on every lap
    assert unsafe[0.0] > 0.2
    assert unsafe[3.5] < 0.5 * unsafe[0.0]
    assert speed[3.5] > 0.5 * Hes().params.core.v_s  # it still circulates


def test_yield_is_off_by_default_and_in_the_paper_preset():
    assert Hes().params.core.enc_yield == 0.0
    assert Hes(preset="paper").params.core.enc_yield > 0.0
