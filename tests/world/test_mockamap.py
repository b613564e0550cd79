"""mockamap worlds (the released simulators of SPH and EGO-Swarm) as generated scenes: the noise,
the fill rule, the exact merge into boxes, the free spawn and goal, seeds, and bad options."""

from __future__ import annotations

import contextlib
import io

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from swarmnav.cli import main
from swarmnav.errors import ScenarioError
from swarmnav.sensing import points_inside, signed_distance
from swarmnav.world import load_scenario
from swarmnav.world import mockamap as mk
from swarmnav.world.generators import OPTIONS
from swarmnav.world.obstacles import Geometry

#: A small world for the exactness tests: 32 x 32 x 12 voxels of 0.25 m.
SMALL = dict(resolution=0.25, x_length=8.0, y_length=8.0, z_length=3.0)
SMALL_SPEC = "resolution=0.25,x_length=8,y_length=8,z_length=3"
TYPE_OPTS = {1: {}, 2: {"obstacle_number": 12}, 3: {"road_width": 0.5}, 4: {"numNodes": 12, "roadRad": 4}}


def _centres(grid) -> np.ndarray:
    """Cell centres of a grid in the occupied array's order ([iz,] iy, ix)."""
    axes = [o + grid.cell * (np.arange(s) + 0.5) for o, s in zip(grid.origin, grid.shape_xyz)]
    mesh = np.meshgrid(*reversed(axes), indexing="ij")  # ([z,] y, x)
    return np.column_stack([m.ravel() for m in reversed(mesh)])


# --------------------------------------------------------------------------- the noise

def test_perlin_noise_is_half_at_lattice_points_continuous_and_in_range():
    rng = np.random.default_rng(0)
    perm = np.tile(rng.permutation(256), 2)
    lattice = rng.integers(-300, 300, (3, 500)).astype(float)
    assert np.all(mk.perlin_noise(perm, *lattice) == 0.5)  # gradient noise vanishes at integer points
    p = rng.uniform(-50, 50, (3, 5000))
    v = mk.perlin_noise(perm, *p)
    assert v.min() >= 0.0 and v.max() <= 1.0 and v.std() > 0.05
    # across a cell face (x = 7): the fade curve makes the two cells' blends agree
    face = np.vstack([np.full(2000, 7.0), rng.uniform(0, 9, (2, 2000))])
    eps = np.array([[1e-9], [0.0], [0.0]])
    assert np.max(np.abs(mk.perlin_noise(perm, *(face - eps)) - mk.perlin_noise(perm, *(face + eps)))) < 1e-7


@pytest.mark.parametrize("fill", [0.05, 0.15, 0.38, 0.7])
def test_perlin_map_fills_the_requested_fraction(fill):
    """mockamap's rule: the voxels above the value at rank int(N (1 - fill)) are occupied, so the
    fill is short of the requested one by that voxel (and by any voxel tied with it: noise values
    tie only at lattice points): within 2 / N."""
    g = mk.generate(type=1, seed=3, fill=fill, **SMALL)
    n = g.occupied.size
    assert abs(g.occupied.mean() - fill) <= 2.0 / n


def test_sph_released_world_size_and_fill():
    g = mk.generate()  # SPH's launch file: 20 x 20 x 4 m at 0.1 m, seed 511, complexity 0.03, fill 0.15
    assert g.occupied.shape == (40, 200, 200)
    assert g.bounds == (-10.0, -10.0, 0.0, 10.0, 10.0, 4.0)
    assert abs(g.occupied.mean() - 0.15) <= 2.0 / g.occupied.size


# --------------------------------------------------------------------------- exact merge, free spawn and goal

@pytest.mark.parametrize("dim", [3, 2])
@pytest.mark.parametrize("kind", [1, 2, 3, 4])
def test_scene_boxes_hold_exactly_the_generated_voxels(kind, dim):
    opts = {**SMALL, **TYPE_OPTS[kind]}
    grid = mk.generate(type=kind, seed=5, **opts)
    occ = grid.occupied if dim == 3 else grid.occupied[int(1.5 / 0.25)]
    spec = f"mockamap:type={kind},seed=5,{SMALL_SPEC},dim={dim}," + ",".join(f"{k}={v}" for k, v in TYPE_OPTS[kind].items())
    scn = load_scenario(spec.rstrip(","))
    assert scn.dim == dim
    assert occ.any() and not occ.all()
    sub = type(grid)(occ, grid.origin[:dim], grid.cell, grid.source)
    inside = points_inside(Geometry.from_obstacles(scn.obstacles, dim=dim), _centres(sub))
    assert np.array_equal(inside.reshape(occ.shape), occ)
    # the boxes' volume is the voxels' volume: no voxel is covered twice and none outside the set
    vol = sum(np.prod(np.subtract(b.max, b.min)) for b in scn.obstacles)
    assert vol == pytest.approx(occ.sum() * grid.cell**dim, rel=1e-12)
    # spawn area and goal lie before and past the map, clear of every obstacle
    geom = scn.geometry
    assert signed_distance(geom, scn.goal_array[None, :])[0] > 0.5
    lo, hi = np.array(scn.swarm.spawn[:dim]), np.array(scn.swarm.spawn[dim:])
    corners = np.array(np.meshgrid(*zip(lo, hi), indexing="ij")).reshape(dim, -1).T
    assert np.all(corners[:, 0] < grid.origin[0] - 0.5) and np.all(signed_distance(geom, corners) > 0.4)


def test_maze2d_every_layer_is_the_maze_and_the_planar_reading_is_it():
    g = mk.generate(type=3, seed=2, **SMALL, road_width=0.5)
    assert all(np.array_equal(g.occupied[k], g.occupied[0]) for k in range(g.occupied.shape[0]))
    cells = g.occupied[0][::2, ::2]  # one voxel per 0.5 m maze cell
    assert np.array_equal(np.kron(cells, np.ones((2, 2), dtype=bool)), g.occupied[0])
    scn = load_scenario(f"mockamap:type=3,seed=2,{SMALL_SPEC},road_width=0.5,dim=2")
    assert scn.dim == 2 and len(scn.obstacles) >= 4


def test_same_seed_same_world_and_another_seed_another():
    a = load_scenario(f"mockamap:seed=7,{SMALL_SPEC}")
    b = load_scenario(f"mockamap:seed=7,{SMALL_SPEC}")
    c = load_scenario(f"mockamap:seed=8,{SMALL_SPEC}")
    assert a.obstacles == b.obstacles and a.obstacles != c.obstacles
    for kind in (2, 3, 4):
        g1, g2 = (mk.generate(type=kind, seed=s, **SMALL, **TYPE_OPTS[kind]) for s in (4, 4))
        g3 = mk.generate(type=kind, seed=9, **SMALL, **TYPE_OPTS[kind])
        assert np.array_equal(g1.occupied, g2.occupied) and not np.array_equal(g1.occupied, g3.occupied)


@pytest.mark.parametrize("dim", [3, 2])
def test_scene_round_trips_through_a_toml_scene(dim):
    from swarmnav.world import loads

    scn = load_scenario(f"mockamap:type=2,seed=4,{SMALL_SPEC},obstacle_number=12,dim={dim}")
    back = loads(scn.to_toml(), source="back.toml")
    assert back.obstacles == scn.obstacles and back.bounds == scn.bounds and back.boundary == scn.boundary
    assert back.goal == scn.goal and back.swarm == scn.swarm


def test_the_name_rebuilds_the_scene():
    spec = f"mockamap:type=4,seed=3,{SMALL_SPEC},numNodes=12,dim=2"
    scn = load_scenario(spec)
    assert load_scenario(scn.name).obstacles == scn.obstacles


# --------------------------------------------------------------------------- bad options

def _cli(*args: str) -> tuple[int, str]:
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        code = main(list(args))
    return code, err.getvalue()


@pytest.mark.parametrize(("spec", "message"), [
    ("mockamap:type=5", "mockamap: type must be in [1, 4] (1 Perlin 3-D, 2 random posts, 3 2-D maze, 4 3-D maze), got 5"),
    ("mockamap:fill=1", "mockamap: fill must be in (0, 1) (the occupied fraction of the Perlin map), got 1.0"),
    ("mockamap:fill=nan", "mockamap: fill must be in (0, 1)"),
    ("mockamap:resolution=0.001", "mockamap: resolution must be in [0.02, 2] m"),
    ("mockamap:resolution=0.02,x_length=100,y_length=100", "voxels is more than 4194304"),
    ("mockamap:width_min=2,width_max=1", "need width_min <= width_max"),
    ("mockamap:type=3,road_width=0.25", "road_width (0.25 m) must be a whole number of voxels (0.1 m each)"),
    ("mockamap:type=3,add_wall_y=1", "no way across the map"),
    ("mockamap:altitude=3.5", "mockamap: altitude must be in [1, z_length - 1] = [1, 3] m"),
    ("mockamap:dim=4", "mockamap: dim must be in [2, 3]"),
    ("mockamap:numNodes=1", "mockamap: numNodes must be in [2, 1000]"),
    ("mockamap:nodeRad=3", "unknown parameter 'nodeRad' for mockamap"),
    ("mockamap:seed=x", "mockamap: seed must be an integer in [0, inf), got 'x'"),
])
def test_bad_mockamap_option_is_one_line_and_exit_2(spec, message):
    with pytest.raises(ScenarioError) as e:
        load_scenario(spec)
    assert message in str(e.value) and "\n" not in str(e.value), str(e.value)
    code, err = _cli("scenarios", "show", spec)
    assert code == 2 and err.count("\n") == 1 and message in err, err


VALUES = st.one_of(
    st.sampled_from(["", "x", "nan", "inf", "-1", "0", "1", "2", "3", "4", "5", "0.5", "1.5", "2.5", "1e9", "true"]),
    st.integers(-5, 60).map(str),
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.floats(0.0, 12.0).map(lambda v: f"{v:.3g}"),
)


@st.composite
def mockamap_specs(draw):
    keys = sorted(set(OPTIONS["mockamap"]) - {"resolution"}) + ["bogus", "nodeRad", ""]
    items = [f"{draw(st.sampled_from(keys))}={draw(VALUES)}" for _ in range(draw(st.integers(0, 4)))]
    # a coarse voxel keeps every map small (at most 100 x 100 x 40 voxels); resolution's own range
    # is checked in the named cases above
    items.append("resolution=1")
    return "mockamap:" + ",".join(items)


@settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(mockamap_specs())
def test_any_mockamap_option_string_gives_a_scene_or_one_scenario_error(spec):
    try:
        scn = load_scenario(spec)
    except ScenarioError as e:
        msg = str(e)
        assert msg and "\n" not in msg and "\r" not in msg, msg
        return
    d = scn.dim
    assert d in (2, 3)
    assert all(scn.bounds[a] <= scn.goal[a] <= scn.bounds[d + a] for a in range(d))
    assert signed_distance(scn.geometry, scn.goal_array[None, :])[0] > 0.0
