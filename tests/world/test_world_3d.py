"""3-D scenes: the random 3-D forest (density, placement, determinism, a closed world), the
built-in Fig. 3 (C) scene, and the horizontal slice planar methods fly in."""

import math

import numpy as np
import pytest

from swarmnav.errors import ScenarioError
from swarmnav.sensing import points_inside, signed_distance
from swarmnav.world.catalog import load_scenario
from swarmnav.world.generators import random_forest_3d
from swarmnav.world.obstacles import Box, Circle, Cylinder, Polygon, Sphere
from swarmnav.world.scenario import builtin_names, from_dict

L, W, H = 26.0, 18.0, 6.0  # the generator's default forest box [m]


def _trunks(scn):
    """The trunks of a generated forest: every obstacle standing on the ground inside the forest box."""
    return [o for o in scn.obstacles
            if isinstance(o, Cylinder) or (isinstance(o, Box) and o.min[2] == 0.0 and o.min[0] >= 0.0)]


def _volume(o) -> float:
    if isinstance(o, Cylinder):
        return math.pi * o.radius**2 * (o.z[1] - o.z[0])
    return float(np.prod(np.subtract(o.max, o.min)))


@pytest.mark.parametrize("density", [0.05, 0.15, 0.25])
@pytest.mark.parametrize("box_share", [0.0, 0.5])
def test_forest_density_is_the_requested_volume_fraction(density, box_share):
    scn = random_forest_3d(density=density, seed=4, box_share=box_share)
    v_total = L * W * H
    d = sum(_volume(o) for o in _trunks(scn)) / v_total
    # only the last trunk can miss the target: it is shortened to meet it, but never below
    # h_min = 0.1 m, so the density overshoots by at most one footprint (<= d_max^2) x h_min
    # (1e-12: the sum of trunk volumes is rounded in another order here than in the generator)
    assert density - 1e-12 <= d <= density + 1.5**2 * 0.1 / v_total + 1e-12
    if box_share:
        assert any(isinstance(o, Box) for o in _trunks(scn)) and any(isinstance(o, Cylinder) for o in _trunks(scn))


def test_forest_trunks_follow_the_released_map_sizes_and_never_overlap():
    scn = random_forest_3d(density=0.2, seed=1, box_share=0.3)
    trunks = _trunks(scn)
    assert len(trunks) > 100
    centres, reach = [], []
    for o in trunks:
        if isinstance(o, Cylinder):
            w, c, r = 2 * o.radius, np.array(o.center), o.radius
            assert o.z[0] == 0.0
        else:
            w, c = o.max[0] - o.min[0], (np.array(o.min[:2]) + np.array(o.max[:2])) / 2
            assert math.isclose(w, o.max[1] - o.min[1])
            r = w / math.sqrt(2)
        top = o.z[1] if isinstance(o, Cylinder) else o.max[2]
        assert 0.6 - 1e-12 <= w <= 1.5 + 1e-12 and 0.1 - 1e-12 <= top <= H
        assert w / 2 - 1e-9 <= c[0] <= L - w / 2 + 1e-9 and abs(c[1]) <= W / 2 - w / 2 + 1e-9
        centres.append(c)
        reach.append(r)
    c, r = np.array(centres), np.array(reach)
    gap = np.linalg.norm(c[:, None] - c[None], axis=2) - (r[:, None] + r[None])
    np.fill_diagonal(gap, np.inf)
    assert gap.min() >= -1e-12


def test_forest_keeps_spawn_and_goal_clear_at_flying_altitude():
    scn = random_forest_3d(density=0.25, seed=2)
    assert scn.dim == 3 and scn.n == 30 and scn.goal == (L + 4.0, 0.0, 1.5)
    x0, y0, z0, x1, y1, z1 = scn.swarm.spawn
    assert (z0 + z1) / 2 == 1.5 == scn.default_altitude()
    # no trunk reaches into the spawn box or within 3 m of the goal
    g = np.meshgrid(np.linspace(x0, x1, 9), np.linspace(y0, y1, 9), np.linspace(z0, z1, 5))
    box = np.stack([a.ravel() for a in g], axis=1)
    assert signed_distance(scn.geometry, box).min() >= 1.0
    assert signed_distance(scn.geometry, scn.goal_array[None])[0] >= 1.0
    pos = scn.spawn_positions(np.random.default_rng(0))
    assert pos.shape == (30, 3) and signed_distance(scn.geometry, pos).min() >= scn.swarm.clearance


def test_forest_world_is_closed_so_the_swarm_must_cross_it():
    scn = random_forest_3d(density=0.1, seed=0)
    xs = np.linspace(-8.0, L + 6.0, 50)
    side = [np.column_stack([xs, np.full(50, s * (W / 2 + 0.25)), np.full(50, 1.5)]) for s in (1, -1)]
    ends = [np.column_stack([xs, np.zeros(50), np.full(50, z)]) for z in (-0.25, H + 0.25)]
    for pts in side + ends:  # side walls, ground and ceiling
        assert points_inside(scn.geometry, pts).all()


def test_forest_is_determined_by_its_spec_and_seed():
    a = load_scenario("random_forest_3d:density=0.1,seed=3")
    b = load_scenario("random_forest_3d:density=0.1,seed=3")
    c = load_scenario("random_forest_3d:density=0.1,seed=4")
    assert a.to_dict()["obstacles"] == b.to_dict()["obstacles"] != c.to_dict()["obstacles"]
    assert a.name == "random_forest_3d:density=0.1,seed=3"
    assert load_scenario("random_forest_3d:density=0.1,seed=3", n=12).n == 12
    # the scene-file form round-trips
    assert from_dict(a.to_dict()).to_dict() == a.to_dict()


@pytest.mark.parametrize(
    ("spec", "match"),
    [
        ("random_forest_3d:density=0.3", "density must be in"),
        ("random_forest_3d:density=nan", "density must be in"),
        ("random_forest_3d:altitude=5.5", "altitude must be in"),
        ("random_forest_3d:d_min=2,d_max=1", "d_min <= d_max"),
        ("random_forest_3d:box_share=2", "box_share"),
        ("random_forest_3d:h_min=7", "h_min <= height"),
        ("random_forest_3d:radius=1", "unknown parameter"),
        ("random_forest_3d:density=abc", "random_forest_3d"),
    ],
)
def test_forest_rejects_bad_parameters(spec, match):
    with pytest.raises(ScenarioError, match=match):
        load_scenario(spec)


def test_forest_reaches_table_ii_densities_with_full_height_trunks():
    # Table II goes to d_obs = 0.45; trunks of random height fill at most ~0.25 of the box, so
    # the high densities need full-height trunks (h_min = height). No trunk can then be shortened:
    # the overshoot is at most one trunk (d_max^2 x height)
    scn = random_forest_3d(density=0.45, seed=0, h_min=6.0)
    d = sum(_volume(o) for o in _trunks(scn)) / (L * W * H)
    assert 0.45 - 1e-12 <= d <= 0.45 + 1.5**2 * H / (L * W * H)


# --------------------------------------------------------------------------- Fig. 3 (C)

def test_cluttered_3d_scene_is_built_in_with_every_3d_shape():
    assert "sph_cluttered_3d" in builtin_names()
    scn = load_scenario("sph_cluttered_3d")
    assert scn.dim == 3 and scn.n == 30  # the paper's M = 30
    kinds = {type(o) for o in scn.obstacles}
    assert {Box, Cylinder, Sphere, Polygon} <= kinds
    z = scn.default_altitude()
    lo = [o for o in scn.obstacles if not isinstance(o, Sphere) and o.z[1] < z and o.z[0] >= 0.0]
    hi = [o for o in scn.obstacles if (o.center[2] - o.radius if isinstance(o, Sphere) else o.z[0]) > z]
    assert len(lo) >= 2 and len(hi) >= 2  # needs 3-D motion: obstacles only below, only above the start
    assert scn.spawn_positions(np.random.default_rng(0)).shape == (30, 3)


def test_planar_slice_cuts_the_right_discs_and_boxes():
    scn = load_scenario("sph_cluttered_3d")
    s15, s22 = scn.planar_slice(1.5), scn.planar_slice(2.2)
    assert s15.dim == 2 and s15.goal == (29.0, 0.0) and s15.swarm.spawn == (-7.0, -3.0, -3.0, 3.0)
    # the boulder at z = 2.2 (r = 1): a disc of radius sqrt(1 - 0.7^2) at 1.5 m, its full radius at 2.2 m
    def boulder(sl):
        (r,) = [o.radius for o in sl.obstacles if isinstance(o, Circle) and o.center == (5.5, 0.5)]
        return r

    assert boulder(s15) == pytest.approx(math.sqrt(1.0 - 0.7**2), abs=1e-12) and boulder(s22) == 1.0
    # the beam (z in [1.9, 2.6]) only at 2.2 m; the low block (z <= 1) and the hanging block (z >= 3) in neither
    beam = Box((19.0, -9.0), (19.6, 9.0))
    assert beam in s22.obstacles and beam not in s15.obstacles
    for o in (Box((1.5, -1.5), (3.5, 1.0)), Box((4.5, -7.0), (6.5, -2.0))):
        assert o not in s15.obstacles and o not in s22.obstacles
    # the mullion (a cylinder over z in [0.8, 2.6]) becomes its disc; the 4.5 m prism its footprint
    assert Circle((10.3, 0.0), 0.3) in s15.obstacles
    assert Polygon(((5.0, 4.0), (7.0, 6.5), (4.0, 7.0))) in s15.obstacles


@pytest.mark.parametrize("z", [0.5, 1.5, 2.2, 4.0])
def test_planar_slice_agrees_with_the_3d_world_at_its_altitude(z):
    """Oracle: a point of the plane is inside the slice exactly when it is inside the 3-D world."""
    for scn in (load_scenario("sph_cluttered_3d"), random_forest_3d(density=0.2, seed=5, box_share=0.5)):
        sl = scn.planar_slice(z)
        rng = np.random.default_rng(0)
        xy = np.column_stack([rng.uniform(scn.bounds[0], scn.bounds[3], 4000),
                              rng.uniform(scn.bounds[1], scn.bounds[4], 4000)])
        inside3 = points_inside(scn.geometry, np.column_stack([xy, np.full(len(xy), z)]))
        np.testing.assert_array_equal(points_inside(sl.geometry, xy), inside3)


def test_forest_slice_keeps_exactly_the_trunks_taller_than_the_altitude():
    scn = random_forest_3d(density=0.15, seed=6)
    z = scn.default_altitude()
    tall = sorted(o.center for o in _trunks(scn) if o.z[1] >= z)
    discs = sorted(o.center for o in scn.planar_slice(z).obstacles if isinstance(o, Circle))
    assert discs == tall and 0 < len(tall) < len(_trunks(scn))


def test_docs_example_3d_scene_loads():
    from pathlib import Path

    from swarmnav.world.scenario import loads

    text = (Path(__file__).resolve().parents[2] / "docs" / "scenarios.md").read_text()
    block = text.split("A small 3-D scene", 1)[1].split("```toml\n", 1)[1].split("```", 1)[0]
    scn = loads(block, "docs/scenarios.md")
    assert scn.dim == 3 and {type(o) for o in scn.obstacles} == {Box, Cylinder, Sphere, Polygon}


@pytest.mark.parametrize("density", [0.15, 0.45])
def test_overlapping_forest_fills_the_requested_volume_fraction_of_the_union(density):
    # the released generator's trunks overlap; V_obs is then the volume of their union, measured
    # here independently of the generator's floor grid: the share of random points of the forest
    # box inside a trunk (2e5 points: standard error 0.0011)
    scn = random_forest_3d(density=density, seed=5, h_min=3.0, length=12.0, overlap=True)
    rng = np.random.default_rng(0)
    pts = rng.uniform([0.0, -W / 2, 0.0], [12.0, W / 2, H], size=(200_000, 3))
    share = points_inside(scn.geometry, pts).mean()
    assert abs(share - density) < 0.006
    trunks = _trunks(scn)
    c = np.array([o.center for o in trunks])
    r = np.array([o.radius for o in trunks])
    gap = np.linalg.norm(c[:, None] - c[None], axis=2) - (r[:, None] + r[None])
    np.fill_diagonal(gap, np.inf)
    assert gap.min() < 0.0  # some trunks do overlap
    assert all(3.0 - 1e-12 <= o.z[1] <= H and 0.6 - 1e-12 <= 2 * o.radius <= 1.5 + 1e-12 for o in trunks)


def test_only_overlapping_trunks_reach_the_densest_table_ii_forest():
    with pytest.raises(ScenarioError, match="raise h_min"):
        random_forest_3d(density=0.45, seed=1, h_min=3.0, length=12.0)
    a = random_forest_3d(density=0.45, seed=1, h_min=3.0, length=12.0, overlap=True)
    b = random_forest_3d(density=0.45, seed=1, h_min=3.0, length=12.0, overlap=True)
    assert a.to_dict()["obstacles"] == b.to_dict()["obstacles"]


def test_extruded_forest_is_the_planar_forest_as_full_height_trunks():
    spec = "random_forest:density=0.35,seed=4,length=12,r_min=1.0,r_max=2.0,min_passage=1.0"
    flat, tall = load_scenario(spec), load_scenario(spec + ",height=6")
    assert (flat.dim, tall.dim) == (2, 3)
    discs = [o for o in flat.obstacles if isinstance(o, Circle)]
    trunks = [o for o in tall.obstacles if isinstance(o, Cylinder)]
    assert [(d.center, d.radius) for d in discs] == [(t.center, t.radius) for t in trunks]
    assert all(t.z == (0.0, 6.0) for t in trunks)
    # V_obs / V_total of the forest box is the planar area fraction
    volume = sum(_volume(t) for t in trunks)
    assert volume / (12.0 * 20.0 * 6.0) == pytest.approx(sum(math.pi * d.radius**2 for d in discs) / (12.0 * 20.0))
    assert 0.35 <= volume / (12.0 * 20.0 * 6.0) < 0.35 + math.pi * 2.0**2 / (12.0 * 20.0)
    # closed: side walls, ground and ceiling; spawn and goal in a layer at 1.5 m
    xs = np.linspace(-10.0, 22.0, 40)
    for y, z in ((10.25, 1.5), (-10.25, 3.0), (0.0, -0.25), (0.0, 6.25)):
        assert points_inside(tall.geometry, np.column_stack([xs, np.full(40, y), np.full(40, z)])).all()
    assert tall.swarm.spawn[2::3] == (1.0, 2.0) and tall.goal_array[2] == 1.5
    assert tall.goal_array[:2].tolist() == flat.goal_array.tolist()
    with pytest.raises(ScenarioError, match="altitude must be in"):
        load_scenario(spec + ",height=6,altitude=5.5")
    with pytest.raises(ScenarioError, match=r"height must be in \[0, 100\] m \(0: the planar forest\)"):
        load_scenario(spec + ",height=-6")
