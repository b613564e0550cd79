"""Scene files: the issue's example loads; every kind of bad input fails with a clear message."""

import math

import numpy as np
import pytest

from swarmnav import load_scenario
from swarmnav.errors import ScenarioError
from swarmnav.world import Box, Circle, Polygon, builtin_names, loads
from swarmnav.world.generators import periodic_box, random_forest

EXAMPLE = """
name = "my_scene"
[world]
bounds = [-12.0, -8.0, 64.0, 8.0]
[swarm]
n = 20
spawn = [-10.0, -5.0, 0.0, 5.0]
[goal]
position = [60.0, 0.0]
[[obstacles]]
type = "box"
min = [5.0, 4.5]
max = [25.0, 5.5]
[[obstacles]]
type = "circle"
center = [30.0, 2.0]
radius = 1.5
[[obstacles]]
type = "polygon"
points = [[52.0, -3.0], [56.0, -3.0], [54.0, 1.0]]
"""


def test_issue_example_loads():
    s = loads(EXAMPLE, "example.toml")
    assert s.name == "my_scene" and s.n == 20 and s.goal == (60.0, 0.0)
    assert [type(o) for o in s.obstacles] == [Box, Circle, Polygon]
    assert s.geometry.n_polygons == 2 + 4 and s.geometry.n_circles == 1  # + the four boundary walls
    assert len(s.geometry.seg_a) == 4 + 3 + 4 * 4  # + the four boundary walls


def test_bounds_optional():
    s = loads(EXAMPLE.replace("bounds = [-12.0, -8.0, 64.0, 8.0]", ""), "x.toml")
    x0, y0, x1, y1 = s.bounds
    assert x0 <= -10 and x1 >= 60 and y0 <= -5 and y1 >= 5.5


def test_round_trip_through_dict():
    from swarmnav.world import from_dict

    s = loads(EXAMPLE, "example.toml")
    t = from_dict(s.to_dict())
    assert t.to_dict() == s.to_dict()


@pytest.mark.parametrize(
    "edit, fragment",
    [
        (lambda t: t.replace("n = 20", "n = 0"), "swarm.n must be >= 1"),
        (lambda t: t.replace("n = 20", "n = 2.5"), "swarm.n must be an integer"),
        (lambda t: t.replace("n = 20", "m = 20"), "unknown key 'swarm.m'"),
        (lambda t: t.replace('type = "circle"', 'type = "ellipse"'), "unknown obstacle type 'ellipse'"),
        (lambda t: t.replace("radius = 1.5", "radius = -1.5"), "radius must be > 0"),
        (lambda t: t.replace("radius = 1.5", "radius = nan"), "must be finite"),
        (lambda t: t.replace("max = [25.0, 5.5]", "max = [5.0, 5.5]"), "size must be positive"),
        (lambda t: t.replace("position = [60.0, 0.0]", "position = [30.0, 2.0]"), "inside an obstacle"),
        (lambda t: t.replace("[[52.0, -3.0], [56.0, -3.0], [54.0, 1.0]]", "[[0, 0], [1, 1], [1, 0], [0, 1]]"), "simple polygon"),
        (lambda t: t.replace("name =", "nmae ="), "unknown key 'nmae'"),
        (lambda t: t.replace("[goal]", "[gaol]"), "unknown key 'gaol'"),
        (lambda t: t.replace("[goal]\nposition = [60.0, 0.0]", ""), "[goal] table is required"),
        (lambda t: t + "\n[[obstacles]]\ntype = 'box'\nmin = [1, 1]\nmax = [2, 2]\ncolor = 'red'\n", "unknown key 'obstacles[3].color'"),
        (lambda t: t.replace("n = 20", "n = 5000"), "cannot hold n=5000"),
        (lambda t: t.replace("= [60.0, 0.0]", "= [60.0, 0.0"), "malformed TOML"),
    ],
)
def test_bad_scene_names_file_and_problem(edit, fragment):
    with pytest.raises(ScenarioError) as e:
        loads(edit(EXAMPLE), "bad.toml")
    msg = str(e.value)
    assert msg.startswith("bad.toml:"), msg
    assert fragment in msg, msg
    assert "\n" not in msg


def test_spawn_blocked_by_obstacle():
    text = EXAMPLE + '\n[[obstacles]]\ntype = "box"\nmin = [-11.0, -6.0]\nmax = [1.0, 6.0]\n'
    with pytest.raises(ScenarioError, match="cannot hold"):
        loads(text, "blocked.toml")


def test_missing_file_and_unknown_name(tmp_path):
    with pytest.raises(ScenarioError, match="no such scene file"):
        load_scenario(tmp_path / "nope.toml")
    with pytest.raises(ScenarioError, match="unknown scene"):
        load_scenario("no_such_scene")


def test_spawn_respects_spacing_clearance_and_seed():
    s = load_scenario("default_corridor")
    a = s.spawn_positions(np.random.default_rng(3))
    b = s.spawn_positions(np.random.default_rng(3))
    np.testing.assert_array_equal(a, b)
    assert a.shape == (20, 2)
    assert np.all((a >= -10) & (a <= 0))
    from scipy.spatial.distance import pdist

    from swarmnav.sensing import signed_distance

    assert pdist(a).min() >= s.swarm.min_spacing
    assert signed_distance(s.geometry, a).min() >= s.swarm.clearance


HES_SCENES = {
    "default_corridor": (60.0, 0.0),
    "narrow_alternating_gates": (66.0, 0.0),
    "dense_cross_blocks": (68.0, 0.0),
    "off_axis_goal": (70.0, 7.5),
}


def test_builtin_hes_scenes_match_paper_protocol():
    assert set(HES_SCENES) <= set(builtin_names())
    from swarmnav.sensing import lidar_ring

    for name, goal in HES_SCENES.items():
        s = load_scenario(name)
        assert s.goal == goal and s.n == 20 and s.swarm.spawn == (-10.0, -10.0, 0.0, 0.0)
        # channel walls: a vertical ray from the channel axis at x = 0 stops at y = +-10.4
        ring = lidar_ring(s.geometry, np.array([[0.0, 0.0]]), 4, 20.0)
        assert ring[0, 1] == pytest.approx(10.4) and ring[0, 3] == pytest.approx(10.4)


def test_gate_scene_gaps_are_sub_2_4_m_and_alternate():
    s = load_scenario("narrow_alternating_gates")
    gates = [o for o in s.obstacles if isinstance(o, Box) and o.max[0] - o.min[0] < 2]
    xs = sorted((0.5 * (g.min[0] + g.max[0]), g) for g in gates)
    assert [round(x) for x, _ in xs] == [12, 22, 32, 42, 52]
    for k, (_, g) in enumerate(xs):
        upper = g.max[1] == 10.4
        assert upper == (k % 2 == 0)
        gap = (g.min[1] + 10.4) if upper else (10.4 - g.max[1])
        assert 2.0 < gap < 2.4


def test_default_corridor_layout():
    s = load_scenario("default_corridor")
    boxes = {(o.min, o.max) for o in s.obstacles}
    assert ((5.0, 4.5), (25.0, 5.5)) in boxes and ((5.0, -5.5), (25.0, -4.5)) in boxes
    assert ((32.0, -0.5), (53.0, 0.5)) in boxes


def test_dense_cross_blocks_has_eight_blocks_at_stated_stations():
    s = load_scenario("dense_cross_blocks")
    blocks = [o for o in s.obstacles if o.max[0] - o.min[0] < 20]
    assert len(blocks) == 8
    stations = sorted({round(0.5 * (b.min[0] + b.max[0])) for b in blocks})
    assert stations == [15, 27, 39, 51, 62]


def test_random_forest_density_and_determinism():
    for d in (0.15, 0.35):
        f = random_forest(density=d, seed=4)
        trees = [o for o in f.obstacles if isinstance(o, Circle)]
        area = sum(math.pi * t.radius**2 for t in trees)
        assert area / (40.0 * 20.0) == pytest.approx(d, abs=0.01)
        c = np.array([t.center for t in trees])
        r = np.array([t.radius for t in trees])
        dd = np.linalg.norm(c[:, None] - c[None], axis=2) - r[:, None] - r[None]
        np.fill_diagonal(dd, 1.0)
        assert dd.min() >= 0  # discs never overlap
    assert random_forest(density=0.25, seed=1).to_dict() == random_forest(density=0.25, seed=1).to_dict()
    assert random_forest(density=0.25, seed=1).to_dict() != random_forest(density=0.25, seed=2).to_dict()
    s = load_scenario("random_forest:density=0.25,seed=1")
    assert s.to_dict() == random_forest(density=0.25, seed=1).to_dict()


def test_periodic_box():
    s = periodic_box(n=100, rho=4.102)
    assert s.periodic and s.geometry.is_empty
    assert s.bounds[2] == pytest.approx(math.sqrt(100 / 4.102))
    assert load_scenario("periodic_box:n=200").n == 200


@pytest.mark.parametrize("spec, fragment", [
    ("random_forest:density=0.9", "density must be in"),
    ("random_forest:dens=0.2", "unknown parameter"),
    ("random_forest:density", "expected key=value"),
    ("volcano:x=1", "unknown generator"),
])
def test_bad_generator_specs(spec, fragment):
    with pytest.raises(ScenarioError, match=fragment):
        load_scenario(spec)
