"""``sph`` on a 3-D scene: the same method, flown in (N, 3) (the SPH paper's Fig. 3 (C, D) setting)."""

import dataclasses

import numpy as np
import pytest

import swarmnav
from swarmnav.methods import registry
from swarmnav.methods.base import Observation
from swarmnav.methods.sph import Sph
from swarmnav.methods.sph.kernel import environment_force, sph_forces
from swarmnav.sensing import segments_blocked
from swarmnav.sensing.esdf import Esdf
from swarmnav.world import load_scenario, loads
from swarmnav.world.scenario import Swarm

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
    res = swarmnav.run("sph", scn, seed=3, steps=round(40.0 / dt), preset="paper")
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


def test_swarm_vertical_false_drops_only_the_vertical_component_of_algorithm_1():
    # two robots stacked 0.6 m apart in open space: their 1/r repulsion is vertical
    scn = loads(SCENE)
    scn = dataclasses.replace(scn, swarm=Swarm(n=2, spawn=scn.swarm.spawn))
    x = np.array([[-3.0, 0.0, 2.0], [-3.0, 0.0, 2.6]])
    v = np.array([[0.1, 0.0, 0.2], [0.0, 0.1, -0.1]])
    obs = Observation(step=0, time=0.0, positions=x, velocities=v)
    commands = {}
    for vertical in (True, False):
        m = registry.make("sph", swarm_vertical=vertical)
        m.reset(scn, x, v, np.random.default_rng(0))
        commands[vertical], _ = m.act(obs, np.random.default_rng(0))
    p = registry.make("sph").params
    force, _, _ = sph_forces(x, v, np.array([0]), np.array([1]), h=p.h, c=p.c, m=p.m, k_den=p.k_den,
                             k_rep=p.k_rep, k_vis=p.k_vis, rho0=p.rho0, gamma=p.gamma)
    assert abs(force[0, 2]) > 1.0  # the pair pushes itself apart vertically
    np.testing.assert_array_equal(commands[True][:, :2], commands[False][:, :2])
    np.testing.assert_allclose(commands[True][:, 2] - commands[False][:, 2], force[:, 2] / p.m, rtol=1e-12)


def test_retime_frees_a_robot_whose_spline_cuts_its_path_short():
    # Forest 0.25/7 of sph-forest-3d, where a robot of a 90 s run stood still for 40 s: at rest at
    # the mouth of a slot 0.88 m wide (narrower than 2 d_thr), its grid path climbs 1.5 m and comes
    # back down over the slot, and the spline, seeded on that path, cuts through the slot. The knots
    # are spent on the path's length, so the cut spline starts so slowly (3 mm in the first 0.2 s)
    # that every replan starts from rest again. Re-seeding the spline from its own curve frees it.
    sc = load_scenario("random_forest_3d:density=0.25,seed=7,n=15,h_min=3.0,length=12,overlap=true")
    at = np.array([2.31, 0.14, 3.39])
    one = dataclasses.replace(sc, swarm=Swarm(n=1, spawn=(*(at - 0.005), *(at + 0.005)), clearance=0.0))
    moved = {}
    for retime in (0.0, 0.8):
        res = swarmnav.run("sph", one, seed=1, horizon=8.0, preset="queue", retime=retime)
        moved[retime] = float(np.linalg.norm(res.positions[-1, 0] - res.positions[0, 0]))
        assert (res.metrics["sph_retimes"] > 0) == (retime > 0)
    assert moved[0.0] < 0.1  # stuck
    assert moved[0.8] > 3.0  # on its way, 0.4 m/s or more


def test_start_clearance_stops_a_reference_that_runs_into_a_trunk():
    # Forest 0.45/19 of sph-forest-3d, where a robot of a 90 s retime run came 0.063 m from a trunk:
    # held by the swarm 0.14 m from the trunk, its reference kept the 0.95 m/s it had towards the
    # trunk, every replan started from that reference state (clamped to ref_reset from the robot, at
    # the trunk's surface), so every new spline began by running into the trunk again. Here one
    # robot is put there with that velocity and then held still (the swarm's part), and the tracking
    # term of eq. (13) is measured along the way into the trunk.
    sc = load_scenario("random_forest_3d:density=0.45,seed=19,n=15,h_min=3.0,length=12,overlap=true")
    at = np.array([[0.52, 0.5, 4.41]])
    one = dataclasses.replace(sc, swarm=Swarm(n=1, spawn=(*(at[0] - 0.005), *(at[0] + 0.005)), clearance=0.0))
    esdf = Esdf.build(one.geometry, one.bounds, 0.1)
    d, grad = esdf.query(at)
    assert 0.1 < d[0] < 0.2
    env = environment_force(d, grad, 10.0, 0.5)  # Table I's k_env, d_thr (the retime preset keeps them)
    pressing = {}
    for start_clearance in (0.0, 0.2):
        m = Sph(preset="retime", start_clearance=start_clearance)
        rng = np.random.default_rng(1)
        m.reset(one, at, np.array([[0.95, 0.19, 0.2]]), rng)
        into = []
        for k in range(300):  # 3 s, 15 replans
            v = np.array([[0.95, 0.19, 0.2]]) if k == 0 else np.zeros((1, 3))
            a, _ = m.act(Observation(k, k * m.dt, at, v), rng)
            into.append(-float((a[0] - env[0]) @ grad[0]))  # tracking term towards the trunk [m/s^2]
        pressing[start_clearance] = float(np.mean(into[100:]))  # after the first second
    assert pressing[0.0] > 2.0  # the reference keeps pulling the robot into the trunk
    assert abs(pressing[0.2]) < 0.5  # restarted from the robot: no pull into it
