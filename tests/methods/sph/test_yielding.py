"""Yielding in narrow places (``yield_range``): two robots abreast at a gap narrower than two bodies
outside the obstacle band pass it one after the other instead of being pressed together."""

import numpy as np
import pytest

import swarmnav
from swarmnav.methods import registry
from swarmnav.methods.sph.parts.yielding import goal_distance_field, yield_rates
from swarmnav.sensing.esdf import Esdf
from swarmnav.world import from_dict

GAP = 1.1  # [m] < 2 d_thr + 2 body radii = 1.4 m: two robots abreast in it are in both obstacle bands
WALL = {"name": "wall_gap", "swarm": {"n": 2, "spawn": [-0.001, -0.5, 0.001, 0.5]}, "goal": {"position": [10.0, 0.0]},
        "world": {"bounds": [-3.0, -5.0, 14.0, 5.0]},
        "obstacles": [{"type": "box", "min": [3.0, -5.0], "max": [4.0, -GAP / 2]},
                      {"type": "box", "min": [3.0, GAP / 2], "max": [4.0, 5.0]}]}


@pytest.mark.parametrize("seed", [1, 3])
def test_two_robots_abreast_pass_a_narrow_gap_in_turn_only_when_yielding(seed):
    def fly(**params):
        return swarmnav.run(registry.make("sph", preset="headroom", **params), from_dict(WALL),
                            seed=seed, horizon=20.0).metrics

    side_by_side = fly()
    assert side_by_side["min_inter_robot_distance"] < 0.4  # pressed together by the two bands: a contact
    assert side_by_side["sph_waiting_fraction"] == 0.0
    queue = fly(yield_range=1.2)
    assert queue["min_inter_robot_distance"] > 0.55  # kept apart by more than a body diameter
    assert queue["sph_success"] == 1.0  # both at the goal, no contact
    assert queue["sph_waiting_fraction"] > 0.0  # one of them waited


def test_the_robot_farther_from_its_goal_waits_and_only_near_obstacles():
    goals = np.zeros((3, 2))
    x = np.array([[-2.0, 0.0], [-2.3, 0.5], [-2.8, 0.6]])  # nearest to farthest from the goal
    i, j = np.array([0, 0, 1]), np.array([1, 2, 2])
    r01, r02 = np.linalg.norm(x[0] - x[1]), np.linalg.norm(x[0] - x[2])
    near = np.array([0.3, 2.0, 2.0])  # only robot 0 is near an obstacle
    way = np.linalg.norm(goals - x, axis=1)
    phi = yield_rates(way, x, near, i, j, yield_range=1.2, yield_clearance=0.7)
    assert phi[0] == 1.0  # the robot nearest its goal never waits
    assert phi[1] == pytest.approx(np.clip(2 * r01 / 1.2 - 1, 0, 1))  # slowed by robot 0, linear in the gap
    # robot 2 waits for robot 0 (1.0 m away), not for robot 1 (0.51 m away): neither of those two is near an obstacle
    assert phi[2] == pytest.approx(2 * r02 / 1.2 - 1)
    far = np.full(3, 2.0)  # ... and with no robot near an obstacle nobody waits
    assert np.all(yield_rates(way, x, far, i, j, 1.2, 0.7) == 1.0)
    assert np.all(yield_rates(way, x, near, i, j, 0.0, 0.7) == 1.0)  # 0 = off


def test_no_two_robots_wait_for_each_other():
    rng = np.random.default_rng(4)
    x = rng.uniform(-1.0, 1.0, (12, 2))
    goals = np.tile([5.0, 0.0], (12, 1))
    i, j = np.triu_indices(12, 1)
    way = np.linalg.norm(goals - x, axis=1)
    phi = yield_rates(way, x, np.zeros(12), i, j, yield_range=3.0, yield_clearance=0.7)
    lead = np.argmin(way)
    assert phi[lead] == 1.0 and np.all(np.delete(phi, lead) < 1.0)  # all in range: only the leader moves on
    # two robots exactly abreast (equally far from the goal): the larger index waits, the other does not
    pair = np.array([[1.0, 0.3], [1.0, -0.3]])
    phi = yield_rates(np.full(2, 4.0), pair, np.zeros(2), np.array([0]), np.array([1]), 1.2, 0.7)
    assert phi[0] == 1.0 and phi[1] == 0.0


def test_queue_preset_is_headroom_with_yielding_and_paper_does_not_yield():
    queue, headroom = registry.make("sph", preset="queue").params, registry.make("sph", preset="headroom").params
    assert (queue.plan_v_max, queue.ref_reset, queue.yield_range) == (headroom.plan_v_max, headroom.ref_reset, 1.2)
    assert registry.make("sph", preset="paper").params.yield_range == 0.0 == headroom.yield_range


def test_the_order_is_the_way_around_obstacles_not_the_straight_line():
    # the wall (x = 3-4 m) with its gap at y = 0: (2.5, 3) is nearer the goal (10, 0) in a straight line
    # than (0, 0), in front of the gap, but its way leads down to the gap first: it is behind
    scn = from_dict(WALL)
    esdf = Esdf.build(scn.geometry, scn.bounds, 0.1)
    way, _ = goal_distance_field(esdf, scn.goal_array, 0.3, 0.2).query(np.array([[0.0, 0.0], [2.5, 3.0], [10.0, 0.0]]))
    assert np.linalg.norm([10.0, 0.0]) > np.linalg.norm([7.5, 3.0]) + 1.5
    assert way[0] == pytest.approx(10.0, abs=0.1)  # straight through the gap
    assert way[1] > way[0]
    assert way[2] == pytest.approx(0.0, abs=1e-9)
