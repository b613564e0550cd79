"""``sph`` on a 3-D scene: the same method, flown in (N, 3) (the SPH paper's Fig. 3 (C, D) setting)."""

import numpy as np
import pytest

import swarmnav
from swarmnav.methods import registry
from swarmnav.sensing import segments_blocked
from swarmnav.world import loads

# 30 m x 10 m x 6 m: posts, a low box, a hanging box and a ball between the swarm and its goal,
# closed by walls, ground and ceiling so the swarm must thread the obstacles in 3-D
SCENE = """
name = "sph_3d_small"
[world]
bounds = [-5.0, -5.0, 0.0, 25.0, 5.0, 6.0]
[swarm]
n = 10
spawn = [-4.0, -2.0, 1.5, -1.0, 2.0, 3.5]
[goal]
position = [20.0, 0.0, 2.5]
[[obstacles]]
type = "cylinder"
center = [5.0, 0.0]
radius = 0.8
z = [0.0, 6.0]
[[obstacles]]
type = "cylinder"
center = [7.0, 3.0]
radius = 0.6
z = [0.0, 6.0]
[[obstacles]]
type = "box"
min = [9.0, -4.0, 0.0]
max = [11.0, -1.0, 2.5]
[[obstacles]]
type = "box"
min = [9.0, 1.0, 3.5]
max = [11.0, 4.0, 6.0]
[[obstacles]]
type = "sphere"
center = [14.0, 0.0, 2.5]
radius = 1.2
[[obstacles]]
type = "cylinder"
center = [16.5, -2.5]
radius = 0.6
z = [0.0, 6.0]
"""


@pytest.fixture(scope="module")
def flight():
    scn = loads(SCENE)
    assert scn.dim == 3
    dt = registry.make("sph").dt
    res = swarmnav.run("sph", scn, seed=3, steps=round(40.0 / dt))
    return scn, res


def test_sph_flies_a_3d_scene_to_the_goal_without_contact(flight):
    scn, res = flight
    m = res.metrics
    assert res.positions.shape[2] == 3 and "plane" not in res.config  # flown in 3-D, not in a slice
    assert m["sph_success"] == 1.0 and m["collisions"] == 0.0
    assert m["min_inter_robot_distance"] >= 0.4
    assert res.min_clearance.min() > 0.2  # body radius: no robot touched an obstacle
    assert np.ptp(res.positions[:, :, 2]) > 0.5  # the swarm used the third dimension
    speed = np.linalg.norm(np.diff(res.positions, axis=0), axis=2) / registry.make("sph").dt
    assert speed.max() <= 1.0 + 1e-9  # eq. (2), the norm of the 3-D velocity
    assert m["sph_search_failures"] == 0.0


def test_sph_3d_visibility_labels_follow_the_3d_line_of_sight(flight):
    scn, res = flight
    geom = scn.geometry
    for k in range(0, res.positions.shape[0], 500):
        x, lab = res.positions[k], res.labels[k]
        i, j = np.triu_indices(len(x), 1)
        near = np.linalg.norm(x[i] - x[j], axis=1) <= registry.make("sph").params.R
        seen = near & ~segments_blocked(geom, x[i], x[j])
        assert np.all(lab[i[seen]] == lab[j[seen]])  # mutually visible robots share a sub-swarm


def test_sph_3d_is_deterministic_for_a_seed():
    scn = loads(SCENE)
    a = swarmnav.run("sph", scn, seed=4, steps=150)
    b = swarmnav.run("sph", scn, seed=4, steps=150)
    np.testing.assert_array_equal(a.positions, b.positions)
    np.testing.assert_array_equal(a.velocities, b.velocities)
    c = swarmnav.run("sph", scn, seed=5, steps=150)
    assert not np.array_equal(a.positions, c.positions)
