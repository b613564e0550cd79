"""The two crowd parts of SPH (ours, docs/methods/sph-crowd.md):
the repulsion cut-off (``rep_cutoff``) and the crowd guard (``crowd_guard``)."""

import numpy as np

import swarmnav
from swarmnav.methods import registry
from swarmnav.methods.base import Observation
from swarmnav.world import from_dict

GOAL = np.array([14.0, 0.0])


def test_cut_off_lets_thirty_robots_gather_inside_their_goal_disc():
    # Open plane: with the paper's repulsion (every robot within R = 20 m) the 30 gathered robots
    # push the crowd's edge out beyond the 4.24 m disc of the swarm test; cut at 3 m they pack
    # inside it at their contact spacing or more.
    scn = from_dict({"name": "crowd", "world": {"bounds": [-12.0, -14.0, 28.0, 14.0]},
                     "swarm": {"n": 30, "spawn": [-8.0, -4.0, 0.0, 4.0]}, "goal": {"position": GOAL.tolist()}})
    far = {}
    for cut in (0.0, 3.0):
        res = swarmnav.run("sph", scn, seed=1, horizon=45.0, preset="guard", rep_cutoff=cut)
        far[cut] = float(np.linalg.norm(res.positions[-1] - GOAL, axis=1).max())
        assert res.metrics["sph_swarm_goal_radius"] == np.sqrt(2) * 3.0
        if cut:
            assert res.metrics["sph_swarm_success"] == 1.0 and res.metrics["min_inter_robot_distance"] >= 0.4
    assert far[0.0] > 3.0 * np.sqrt(2) > far[3.0]


def _push_towards_wall(crowd_guard: bool) -> float:
    """Acceleration [m/s^2] of a robot 0.3 m from a wall (inside the 0.5 m band) towards the wall,
    with four robots behind it pressing it on, everything at rest."""
    scn = from_dict({"name": "wall", "world": {"bounds": [-6.0, -6.0, 6.0, 6.0]},
                     "swarm": {"n": 5, "spawn": [-4.0, -1.0, -2.0, 1.0]}, "goal": {"position": [-5.0, 0.0]},
                     "obstacles": [{"type": "box", "min": [1.0, -5.0], "max": [2.0, 5.0]}]})
    x = np.array([[0.7, 0.0], [0.2, 0.0], [0.2, 0.5], [0.2, -0.5], [-0.3, 0.0]])
    m = registry.make("sph", preset="guard", crowd_guard=crowd_guard)
    rng = np.random.default_rng(0)
    m.reset(scn, x, np.zeros_like(x), rng)
    a, _ = m.act(Observation(0, 0.0, x, np.zeros_like(x)), rng)
    return float(a[0, 0])  # +x: into the wall at x = 1


def test_crowd_guard_keeps_the_crowd_from_pressing_a_robot_into_an_obstacle():
    assert _push_towards_wall(False) > 0.0  # the crowd's 1/r push beats the ESDF force at 0.3 m
    assert _push_towards_wall(True) < 0.0  # guarded: only the ESDF force acts across the band


def test_default_build_flies_the_crowd_parts_on_2d_swarms_of_thirty_or_more_only():
    forest = "random_forest:density=0.35,seed=2,length=12,r_min=1.0,r_max=2.0,min_passage=1.0,spawn_length=8"

    from swarmnav.world import load_scenario

    def pos(n, **params):
        return swarmnav.run("sph", load_scenario(forest, n=n), seed=2, steps=150, **params).positions

    crowd = dict(preset="guard", rep_cutoff=3.0, crowd_guard=True, pair_guard=True)
    assert np.array_equal(pos(30), pos(30, **crowd)) and not np.array_equal(pos(30), pos(30, preset="guard"))
    assert np.array_equal(pos(29), pos(29, preset="guard"))  # below crowd_size: guard's set, bit for bit
