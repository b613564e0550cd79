"""A scene's spawn region and goal lie in ``world.bounds``, and a spawn region has extent on every
axis (a point only as the centre of a ``swarm.density`` square): refused in one ScenarioError line
naming the key, exit 2 in the CLI. Every built-in scene and every scene of a shipped experiment
keeps to it."""

import copy
import tomllib
from importlib import resources

import pytest
from _helpers.cli import run_cli

from swarmnav.errors import ScenarioError
from swarmnav.experiments.spec import builtin_names as experiment_names
from swarmnav.world.catalog import load_scenario
from swarmnav.world.scenario import builtin_names, from_dict

PLANAR = {
    "world": {"bounds": [-6.0, -6.0, 12.0, 6.0]},
    "swarm": {"n": 4, "spawn": [-5.0, -2.0, -3.0, 2.0]},
    "goal": {"position": [10.0, 0.0]},
}
SOLID = {
    "world": {"bounds": [-6.0, -6.0, 0.0, 12.0, 6.0, 4.0]},
    "swarm": {"n": 4, "spawn": [-5.0, -2.0, 1.0, -3.0, 2.0, 2.0]},
    "goal": {"position": [10.0, 0.0, 1.5]},
}


def _load(base, table, key, value):
    d = copy.deepcopy(base)
    d[table][key] = value
    return from_dict(d, source="s.toml")


@pytest.mark.parametrize(("base", "table", "key", "value", "message"), [
    (PLANAR, "swarm", "spawn", [-8.0, -2.0, -3.0, 2.0],
     "s.toml: swarm.spawn [-8.0, -2.0, -3.0, 2.0] reaches outside world.bounds [-6.0, -6.0, 12.0, 6.0]"),
    (PLANAR, "swarm", "spawn", [-5.0, -2.0, -3.0, 6.5], "s.toml: swarm.spawn [-5.0, -2.0, -3.0, 6.5] reaches outside"),
    (PLANAR, "goal", "position", [13.0, 0.0],
     "s.toml: goal.position [13.0, 0.0] lies outside world.bounds [-6.0, -6.0, 12.0, 6.0]"),
    (SOLID, "swarm", "spawn", [-5.0, -2.0, -1.0, -3.0, 2.0, 2.0],
     "s.toml: swarm.spawn [-5.0, -2.0, -1.0, -3.0, 2.0, 2.0] reaches outside world.bounds"),
    (SOLID, "goal", "position", [10.0, 0.0, 5.0], "s.toml: goal.position [10.0, 0.0, 5.0] lies outside world.bounds"),
    (PLANAR, "swarm", "spawn", [0.0, 0.0, 0.0, 0.0],
     "s.toml: swarm.spawn [0.0, 0.0, 0.0, 0.0] has no extent: a spawn region needs xmax > xmin and ymax > ymin"),
    (PLANAR, "swarm", "spawn", [-5.0, 1.0, -3.0, 1.0], "s.toml: swarm.spawn [-5.0, 1.0, -3.0, 1.0] has no extent"),
    (SOLID, "swarm", "spawn", [-5.0, -2.0, 1.0, -3.0, 2.0, 1.0],
     "s.toml: swarm.spawn [-5.0, -2.0, 1.0, -3.0, 2.0, 1.0] has no extent: a spawn region needs xmax > xmin and "
     "ymax > ymin and zmax > zmin"),
])
def test_spawn_and_goal_outside_bounds_or_a_flat_spawn_are_refused(base, table, key, value, message):
    with pytest.raises(ScenarioError) as e:
        _load(base, table, key, value)
    assert str(e.value).startswith(message) and "\n" not in str(e.value)


def test_spawn_and_goal_on_the_bounds_are_inside():
    assert _load(PLANAR, "swarm", "spawn", [-6.0, -6.0, -3.0, 6.0]).n == 4
    opened = copy.deepcopy(PLANAR)
    opened["world"]["boundary"] = "open"
    assert _load(opened, "goal", "position", [12.0, 6.0]).goal == (12.0, 6.0)
    # in a closed world (the default with bounds) the bounds are walls: a goal on them is in the wall
    with pytest.raises(ScenarioError, match=r"goal.position \[12.0, 6.0\] lies inside the world's boundary wall"):
        _load(PLANAR, "goal", "position", [12.0, 6.0])


def test_a_point_spawns_only_as_the_centre_of_a_density_square():
    """The HWVEM mission scenes' use: spawn = [0, 0, 0, 0] with a density; the square grows with n
    and must stay in bounds, and without bounds the default bounds hold it."""
    d = copy.deepcopy(PLANAR)
    d["swarm"] = {"n": 20, "spawn": [0.0, 0.0, 0.0, 0.0], "density": 3.265, "min_spacing": 0.0}
    scn = from_dict(d, source="s.toml")
    assert scn.swarm.region[2] - scn.swarm.region[0] == pytest.approx((20 / 3.265) ** 0.5)
    square = r"\(the square of n=500 agents at density 3.265 /m\^2, \[-6.187, -6.187, 6.187, 6.187\]\)"
    with pytest.raises(ScenarioError, match=r"s.toml: swarm.spawn \[0.0, 0.0, 0.0, 0.0\] " + square + " reaches out"):
        scn.with_n(500)
    del d["world"]
    d["swarm"]["n"] = 500  # no bounds given: the default bounds pad the square, not just its centre
    assert from_dict(d).n == 500
    assert load_scenario("hwvem_mission", n=50).n == 50
    with pytest.raises(ScenarioError, match="hwvem_mission.toml: swarm.spawn .* reaches outside world.bounds"):
        load_scenario("hwvem_mission", n=2000)


@pytest.mark.parametrize("name", builtin_names())
def test_every_built_in_scene_keeps_spawn_and_goal_in_bounds(name):
    scn = load_scenario(name)
    d, region = scn.dim, scn.swarm.region
    assert all(scn.bounds[a] <= region[a] < region[d + a] <= scn.bounds[d + a] for a in range(d))
    assert all(scn.bounds[a] <= scn.goal[a] <= scn.bounds[d + a] for a in range(d))


@pytest.mark.parametrize("experiment", experiment_names())
def test_every_scene_of_a_shipped_experiment_loads(experiment):
    """Each scene a shipped spec names (its scenario_vars filled, seed 1, every swarm size it asks
    for) passes validation: spawn region and goal in bounds."""
    data = tomllib.loads(resources.files("swarmnav.experiments").joinpath("specs", f"{experiment}.toml").read_text())
    matrix = data.get("matrix", {})
    scenes = {data.get("scenario"), *matrix.get("scenario", []), *(v.get("scenario") for v in data.get("variants", []))}
    sizes = {data.get("n"), *matrix.get("n", []), *(v.get("n") for v in data.get("variants", []))}
    for scene in scenes - {None}:
        for key, value in {**data.get("scenario_vars", {}), "seed": 1}.items():
            scene = scene.replace("{" + key + "}", str(value))
        for n in sizes:
            assert load_scenario(scene, n=n).n >= 1


def test_cli_spawn_outside_bounds_is_one_line_exit_2(tmp_path):
    f = tmp_path / "out.toml"
    f.write_text("[world]\nbounds = [0.0, 0.0, 10.0, 10.0]\n[swarm]\nn = 2\nspawn = [-4.0, 1.0, -1.0, 4.0]\n"
                 "[goal]\nposition = [8.0, 5.0]\n")
    p = run_cli("run", "--method", "apf", "--scenario-file", f, "--out", tmp_path / "o")
    assert p.returncode == 2 and "Traceback" not in p.stderr, p.stderr
    assert p.stderr.splitlines() == [f"swarmnav: error: {f}: swarm.spawn [-4.0, 1.0, -1.0, 4.0] reaches outside "
                                     "world.bounds [0.0, 0.0, 10.0, 10.0]"]
