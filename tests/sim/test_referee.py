"""The referee: closed worlds, crash on contact, success by the scene's rules, no goal in a box."""

from dataclasses import dataclass

import numpy as np
import pytest

import swarmnav
from swarmnav.errors import ConfigError, ScenarioError
from swarmnav.sensing import lidar_ring, signed_distance
from swarmnav.sim.referee import Referee
from swarmnav.world.scenario import WALL_THICKNESS, from_dict, loads

SCENE = """
name = "box"
[world]
bounds = [0.0, 0.0, 20.0, 10.0]
[swarm]
n = 2
spawn = [2.0, 4.0, 3.0, 6.0]
[goal]
position = [18.0, 5.0]
"""


@dataclass
class _Params:
    pass


class _Straight:
    """A method that flies every agent at a fixed velocity (the command is the velocity)."""

    name = "straight"
    params = _Params()
    dt = 0.1
    dims = (2, 3)

    def __init__(self, velocity):
        self.v = np.asarray(velocity, dtype=float)
        self.dynamics = self

    def step(self, p, v, command, dt):
        return p + command * dt, command.copy()

    def reset(self, scenario, positions, velocities, rng):
        pass

    def act(self, obs, rng):
        return np.broadcast_to(self.v, obs.positions.shape).copy(), {}

    def summary(self):
        return {}


def test_walls_are_in_the_geometry_every_sensor_sees():
    scn = loads(SCENE)
    assert scn.boundary == "wall" and len(scn.walls) == 4
    # distance to the nearest wall from inside is the distance to the bounds
    pts = np.array([[1.0, 5.0], [10.0, 9.5], [19.0, 2.0]])
    np.testing.assert_allclose(signed_distance(scn.geometry, pts), [1.0, 0.5, 1.0])
    # a LiDAR ray along +x from (10, 5) meets the wall at x = 20
    ring = lidar_ring(scn.geometry, np.array([[10.0, 5.0]]), n_rays=4, max_range=50.0)
    np.testing.assert_allclose(ring[0], [10.0, 5.0, 10.0, 5.0])
    # the walls lie outside the world, WALL_THICKNESS thick, closed at the corners
    assert signed_distance(scn.geometry, np.array([[-WALL_THICKNESS / 2, -WALL_THICKNESS / 2]]))[0] < 0
    opened = from_dict({**_dict(), "world": {"bounds": [0.0, 0.0, 20.0, 10.0], "boundary": "open"}})
    assert opened.walls == () and opened.geometry.is_empty


def _dict():
    import tomllib

    return tomllib.loads(SCENE)


def test_3d_world_has_six_walls_floor_and_ceiling():
    scn = from_dict({"world": {"bounds": [0, 0, 0, 10, 10, 4]}, "swarm": {"n": 1, "spawn": [1, 1, 1, 2, 2, 2]},
                     "goal": {"position": [8, 8, 2]}})
    assert len(scn.walls) == 6
    np.testing.assert_allclose(signed_distance(scn.geometry, np.array([[5.0, 5.0, 0.5], [5.0, 5.0, 3.0]])),
                               [0.5, 1.0])


def test_an_agent_flying_at_a_wall_crashes_there_and_never_leaves_the_world():
    res = swarmnav.run(_Straight([0.0, 2.0]), loads(SCENE), seed=1, steps=60)
    P = res.positions
    assert (P[..., 1] <= 10.0).all() and (P[..., 1] >= 0.0).all()
    assert res.metrics["crashes"] == 2.0 and res.metrics["R_goal"] == 0.0
    crashes = [e for e in res.events if e["action"] == "crash"]
    assert {e["reason"] for e in crashes} == {"wall"} and len(crashes) == 2
    # it stays where it hit, at rest: the run ends once every agent has crashed
    k = crashes[0]["step"]
    assert res.positions.shape[0] == max(e["step"] for e in crashes) + 1
    assert np.all(res.velocities[k + 1:, crashes[0]["agent"]] == 0.0)
    assert np.all(res.positions[k:, crashes[0]["agent"]] == res.positions[k, crashes[0]["agent"]])
    assert 10.0 - res.positions[k, crashes[0]["agent"], 1] < 0.2 + 0.2 + 1e-9  # hit within a step of the wall


def test_counted_contacts_fly_on_and_an_open_world_lets_agents_leave_but_not_succeed():
    res = swarmnav.run(_Straight([0.0, 2.0]), loads(SCENE), seed=1, steps=60, contact="count")
    assert res.metrics["crashes"] == 0.0 and res.metrics["collisions"] >= 2.0
    assert res.positions[-1, :, 1].min() > 10.0  # through the wall: counted, never stopped
    out = swarmnav.run(_Straight([0.0, 2.0]), loads(SCENE), seed=1, steps=60, boundary="open")
    assert out.metrics["crashes"] == 0.0 and out.metrics["collisions"] == 0.0
    assert out.positions[-1, :, 1].min() > 10.0


class _Converge(_Straight):
    """Every agent flies at 1 m/s toward one point."""

    def act(self, obs, rng):
        d = self.v - obs.positions
        return d / np.maximum(np.linalg.norm(d, axis=1, keepdims=True), 1e-9), {}


def test_agent_contact_crashes_both_and_they_stay_apart_where_they_met():
    scn = from_dict({**_dict(), "swarm": {"n": 2, "spawn": [3.0, 4.9, 9.0, 5.1]}})
    res = swarmnav.run(_Converge([6.0, 5.0]), scn, seed=3, steps=100)
    crashes = [e for e in res.events if e["action"] == "crash"]
    assert res.metrics["crashes"] == 2.0 and {e["reason"] for e in crashes} == {"agent"}
    k = crashes[0]["step"]
    gap = np.linalg.norm(res.positions[-1, 0] - res.positions[-1, 1])
    assert 0.4 - 2 * 0.1 <= gap < 0.4  # they met within one 0.1 m step each of the contact distance
    assert res.positions.shape[0] == k + 1  # every agent crashed: the run ends there
    counted = swarmnav.run(_Converge([6.0, 5.0]), scn, seed=3, steps=100, contact="count")
    assert counted.metrics["crashes"] == 0.0 and counted.metrics["collisions"] == 1.0
    assert counted.metrics["min_inter_agent_distance"] < 0.1


def test_goal_needs_line_of_sight_not_only_the_radius():
    data = _dict()
    sealed = {**data, "obstacles": [{"type": "box", "min": [15.0, 3.0], "max": [16.0, 7.0]}]}
    # agents parked 4 m before the goal: within 8 m, but a wall stands between
    scn = from_dict({**sealed, "swarm": {"n": 2, "spawn": [13.0, 4.5, 14.0, 5.5]}})
    res = swarmnav.run(_Straight([0.0, 0.0]), scn, seed=1, steps=5)
    assert res.metrics["R_goal"] == 0.0 and res.metrics["Y"] == 0.0
    clear = from_dict({**data, "swarm": {"n": 2, "spawn": [13.0, 4.5, 14.0, 5.5]}})
    assert swarmnav.run(_Straight([0.0, 0.0]), clear, seed=1, steps=5).metrics["R_goal"] == 1.0
    # the radius is the scene's
    tight = from_dict({**data, "swarm": {"n": 2, "spawn": [13.0, 4.5, 14.0, 5.5]}, "rules": {"goal_radius": 3.0}})
    assert swarmnav.run(_Straight([0.0, 0.0]), tight, seed=1, steps=5).metrics["R_goal"] == 0.0
    assert swarmnav.run(_Straight([0.0, 0.0]), clear, seed=1, steps=5, goal_radius=3).metrics["R_goal"] == 0.0


def test_apf_through_the_gates_is_not_a_success():
    """The issue's case: APF with its repulsion off flew through every gate wall and scored Y = 1."""
    res = swarmnav.run("apf", "narrow_alternating_gates", seed=1, steps=1000, k_rep=0)
    m = res.metrics
    assert m["Y"] == 0.0 and m["crashes"] > 0 and m["collisions"] > 0
    assert m["S_scene"] < 0.4
    counted = swarmnav.run("apf", "narrow_alternating_gates", seed=1, steps=1000, k_rep=0, contact="count")
    assert counted.metrics["collisions"] > m["collisions"] and counted.metrics["crashes"] == 0.0


def test_periodic_box_reports_no_goal_metrics():
    res = swarmnav.run("vem", "periodic_box:n=30,rho=1.0", seed=1, steps=20)
    for k in ("Y", "R_goal", "E_mean", "S_scene", "path_stretch"):
        assert k not in res.metrics
    assert res.config["rules"]["contact"] == "count" and res.metrics["crashes"] == 0.0


def test_rules_load_from_the_scene_and_bad_values_are_refused():
    scn = from_dict({**_dict(), "rules": {"goal_radius": 2.5, "d_safe": 0.5, "body_radius": 0.1,
                                          "contact": "count"}})
    assert (scn.rules.goal_radius, scn.rules.d_safe, scn.rules.body_radius, scn.contact) == (2.5, 0.5, 0.1, "count")
    assert from_dict(scn.to_dict()).to_dict() == scn.to_dict()
    for bad in ({"contact": "bounce"}, {"goal_radius": 0}, {"d_safe": -1}, {"body_radius": "x"}, {"radius": 1}):
        with pytest.raises(ScenarioError, match="rules"):
            from_dict({**_dict(), "rules": bad})
    with pytest.raises(ScenarioError, match="world.boundary"):
        from_dict({**_dict(), "world": {"boundary": "rubber"}})
    with pytest.raises(ConfigError, match="contact"):
        swarmnav.run(_Straight([0, 0]), scn, seed=1, steps=1, contact="bounce")
    with pytest.raises(ConfigError, match="periodic"):
        swarmnav.run(_Straight([0, 0]), scn, seed=1, steps=1, boundary="periodic")


def test_generated_scene_label_rebuilds_the_scene():
    spec = "random_forest:density=0.3,seed=2,length=12,r_min=1.0,r_max=2.0,min_passage=1.0"
    scn = swarmnav.load_scenario(spec)
    assert scn.name == spec
    assert swarmnav.load_scenario(scn.name).to_dict() == scn.to_dict()
    resized = swarmnav.load_scenario("random_forest:density=0.2,seed=1", n=7)
    assert resized.name.endswith(",n=7") and swarmnav.load_scenario(resized.name).n == 7


def test_a_contact_at_a_3d_worlds_floor_is_named_ground():
    """In a walled 3-D world the floor is a wall too; a contact there is reported as the ground,
    one at a side wall as a wall, one in the open air as an obstacle."""
    ref = Referee(3, 0.2, bounds=(0.0, 0.0, 0.0, 10.0, 10.0, 4.0))
    pos = np.array([[5.0, 5.0, 0.1], [0.1, 5.0, 2.0], [5.0, 5.0, 2.0]])
    events = ref.judge(4, pos, np.array([0.1, 0.1, 0.05]))
    assert [(e["agent"], e["reason"]) for e in events] == [(0, "ground"), (1, "wall"), (2, "obstacle")]
