"""The surfaces the flocking methods see: one local minimum of the range ring (sphere) per wall
in sight, at the wall's distance, pointing at it; and the held broadcasts counted as messages."""

import numpy as np
import pytest

from swarmnav.methods.base import Observation
from swarmnav.methods.flocking.common import (
    STATE_BYTES,
    RangeSensor,
    StateBoard,
    local_minima,
)
from swarmnav.world import from_dict


@pytest.mark.parametrize("dim, n_walls", [(2, 4), (3, 6)])
def test_a_robot_in_a_closed_room_sees_each_wall_once_at_its_distance(dim, n_walls):
    lo, hi = [-3.0, -2.0, 0.0][:dim], [5.0, 4.0, 3.0][:dim]
    x0 = [0.5, 1.0, 1.2][:dim]
    scn = from_dict({"name": "room", "world": {"bounds": lo + hi}, "swarm": {"n": 1, "spawn": [c - 0.01 for c in x0] + [c + 0.01 for c in x0]},
                     "goal": {"position": x0}})
    sensor = RangeSensor(scn, 360, 4096, 20.0)
    x = np.array([x0])
    agent, dist, normal = sensor.surface_points(x, np.inf)
    assert len(agent) == n_walls and np.all(agent == 0)
    want = sorted([x0[a] - lo[a] for a in range(dim)] + [hi[a] - x0[a] for a in range(dim)])
    np.testing.assert_allclose(sorted(dist), want, rtol=0.01)
    # each normal points from its wall to the robot, along an axis (the ring exactly, the sphere within its spacing)
    assert np.all(np.abs(normal).max(axis=1) > 0.99)
    assert sensor.surface_points(x, 1.0)[0].size == 0  # nothing within 1 m


def test_plateaus_give_one_minimum_and_a_robot_in_contact_none():
    ring = np.array([[5.0, 3.0, 3.0, 3.0, 5.0, 6.0, 2.0, 6.0], [0.0] * 8])
    agent, ray = local_minima(ring, 10.0)
    assert agent.tolist() == [0, 0] and ray.tolist() == [1, 6]
    assert local_minima(ring, 2.5)[1].tolist() == [6]


def test_broadcasts_are_held_between_sends_and_counted():
    board = StateBoard(10.0, 0.02)  # every 5th step
    x = np.zeros((4, 2))
    for k in range(12):
        hx, _, heard = board.update(Observation(k, 0.02 * k, x + k, x))
        assert heard is None
        assert np.all(hx == (k // 5) * 5)  # the last broadcast
    s = board.summary()
    assert s["comm_messages"] == 3 * 4 and s["comm_bytes"] == 3 * 4 * STATE_BYTES == 3 * 4 * 88


def test_sphere_minima_match_a_per_ray_reference():
    from swarmnav.methods.apf import fibonacci_sphere
    from swarmnav.methods.flocking.common import sphere_neighbours

    dirs = fibonacci_sphere(256)
    nbrs = sphere_neighbours(dirs)
    rng = np.random.default_rng(1)
    ring = np.round(rng.uniform(0, 5, (4, 256)), 1)  # rounded: ties occur
    agent, ray = local_minima(ring, 3.0, nbrs)
    want = [(a, k) for a in range(4) for k in range(256) if ring[a, k] < 3.0
            and all(ring[a, k] < ring[a, j] if j < k else ring[a, k] <= ring[a, j] for j in nbrs[k])]
    assert list(zip(agent.tolist(), ray.tolist())) == want and len(want) > 10


@pytest.mark.parametrize("method", ["olfati-saber", "vasarhelyi"])
def test_as_an_env_baseline_it_flies_as_in_swarmnav_run(method):
    """Through swarmnav.env (its own dt and saturated dynamics) the method flies the rollout's run:
    the held broadcasts and the sensing depend only on the step and the state."""
    import swarmnav
    import swarmnav.env as E

    res = E.evaluate(method, "default_corridor", [1], horizon=10.0, terminate_at_goal=False)[0]
    ref = swarmnav.run(method, "default_corridor", seed=1, horizon=10.0)
    assert res.positions.shape == ref.positions.shape
    np.testing.assert_allclose(res.positions, ref.positions, atol=1e-8)  # up to the normalised action
    assert np.linalg.norm(ref.positions[-1] - ref.positions[0], axis=1).mean() > 3.0
