"""Grid search on each robot's own map, and Algorithm 2's visibility structure."""

import math

import numpy as np
import pytest

from swarmnav.planning.maps import OccupancyMaps, resample
from swarmnav.methods.sph.visibility import components, link_changes, structural_events, visible_pairs
from swarmnav.world import Box, Circle, Geometry

BOUNDS = (-5.0, -5.0, 15.0, 5.0)


def test_astar_is_optimal_in_free_space_and_goes_round_a_wall():
    maps = OccupancyMaps((Box((4.0, -3.0), (5.0, 5.0)),), BOUNDS, 1, 0.1, 0.3, 100.0, margin=0.5)
    free = maps.search(0, np.array([0.0, 0.0]), np.array([3.0, 2.0]), 10**6)
    length = np.linalg.norm(np.diff(free, axis=0), axis=1).sum()
    assert length == pytest.approx(1.0 + 2.0 * math.sqrt(2), abs=0.05)  # octile optimum
    assert maps.observe(0, np.zeros(2)) == 1
    path = maps.search(0, np.array([0.0, 0.0]), np.array([9.0, 0.0]), 10**6)
    assert path is not None
    g = Geometry.from_obstacles([Box((4.0, -3.0), (5.0, 5.0))])
    from swarmnav.sensing import signed_distance

    assert signed_distance(g, path).min() >= 0.5 - 0.08  # keeps the d_thr tier where it can
    assert path[:, 1].min() < -3.0  # went round the bottom end of the wall


def test_wide_clearance_is_kept_when_the_detour_is_short_and_dropped_when_it_is_not():
    # two posts 1.4 m apart (a 1.4 m gap): the d_thr tier fits through (0.5 m each side),
    # the wide 0.9 m clearance does not; the way round the posts is open
    posts = (Circle((4.0, 1.2), 0.5), Circle((4.0, -1.2), 0.5))
    g = Geometry.from_obstacles(list(posts))
    from swarmnav.sensing import signed_distance

    def clearance(wide, cost, bounds):
        maps = OccupancyMaps(posts, bounds, 1, 0.1, 0.3, 100.0, margin=0.5, wide=wide, wide_cost=cost)
        maps.observe(0, np.zeros(2))
        path = maps.search(0, np.array([0.0, 0.0]), np.array([8.0, 0.0]), 10**6)
        return signed_distance(g, path[1:-1]).min(), np.abs(path[:, 1]).max()

    d, _ = clearance(0.0, 0.0, BOUNDS)
    assert 0.5 - 0.08 <= d < 0.9 - 0.1  # the paper-only tiers go through the gap
    d, y = clearance(0.9, 2.0, BOUNDS)
    assert d >= 0.9 - 0.08 and y > 2.0  # round the posts: a ~1 m detour beats 1 m of gap at cost 3
    d, _ = clearance(0.9, 0.01, BOUNDS)
    assert d < 0.9 - 0.1  # nearly free band: straight through again


def test_neighbours_bend_the_seed_path_but_never_block_it():
    maps = OccupancyMaps((Circle((20.0, 0.0), 0.5),), (-5.0, -5.0, 25.0, 5.0), 1, 0.1, 0.3, 100.0, margin=0.5,
                         wide=0.9, wide_cost=2.0)
    start, goal = np.array([0.0, 0.0]), np.array([8.0, 0.0])
    ahead = np.array([[3.0, 0.0]])
    plain = maps.search(0, start, goal, 10**6)
    assert np.abs(plain[:, 1]).max() <= 0.05 + 1e-9  # straight along a row of cell centres
    bent = maps.search(0, start, goal, 10**6, ahead, 0.6)
    assert np.linalg.norm(bent - ahead, axis=1).min() >= 0.6 - 0.08  # round the robot ahead
    assert maps.grids[0].max() <= 3 and not (maps.grids[0] == 1).any()  # the map itself is untouched
    # a neighbour sitting on the goal costs, it does not block: the path still ends there
    on_goal = maps.search(0, start, goal, 10**6, goal[None], 0.6)
    np.testing.assert_allclose(on_goal[-1], goal)


def test_map_only_holds_obstacles_within_sensing_range():
    maps = OccupancyMaps((Circle((2.0, 0.0), 0.5), Circle((14.0, 0.0), 0.5)), BOUNDS, 2, 0.1, 0.3, 5.0)
    assert maps.observe(0, np.array([0.0, 0.0])) == 1
    assert maps.known[0].tolist() == [True, False] and not maps.known[1].any()
    assert maps.grids[1].max() == 0  # robot 1 has seen nothing


def test_resample_spacing():
    path = np.array([[0.0, 0.0], [2.2, 0.0], [2.2, 1.0]])
    pts = resample(path, 0.5)
    np.testing.assert_allclose(pts[0], path[0])
    np.testing.assert_allclose(pts[-1], path[-1])
    steps = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    assert np.all(steps[:-1] <= 0.5 + 1e-9)  # chords of 0.5 m arcs
    assert steps[-1] <= 0.75 + 1e-9  # a short remainder stretches the last interval


def test_wall_splits_the_swarm_and_labels_partition_it():
    geom = Geometry.from_obstacles([Box((-0.1, -10.0), (0.1, 10.0))])
    x = np.array([[-2.0, 0.0], [-1.0, 1.0], [1.0, 0.0], [2.0, 1.0], [30.0, 0.0]])
    i, j, vis = visible_pairs(geom, x, 20.0)
    lab = components(len(x), i[vis], j[vis])
    assert lab.tolist() == [0, 0, 2, 2, 4]  # the agent beyond R is its own sub-swarm
    # every agent in exactly one sub-swarm, labelled by its smallest member
    for lab_id in np.unique(lab):
        assert lab_id == np.flatnonzero(lab == lab_id).min()


def test_split_and_merge_events_and_pair_transitions():
    one = np.array([0, 0, 0, 0])
    two = np.array([0, 0, 2, 2])
    ev = structural_events(one, two)
    assert [e["action"] for e in ev] == ["split"] and all(e["source"] == "visibility" for e in ev)
    assert [e["action"] for e in structural_events(two, one)] == ["merge"]
    assert structural_events(two, two) == []
    n = 4
    prev = np.array([0 * n + 1, 0 * n + 2])  # 0-1 and 0-2 were visible
    in_range = np.array([0 * n + 1, 0 * n + 2, 2 * n + 3])
    vis = np.array([True, False, True])  # 0-2 now occluded, 2-3 newly visible
    assert link_changes(prev, in_range, vis) == (1, 1)


# ----------------------------------------------------------------------------- 3-D

BOUNDS3 = (-5.0, -5.0, 0.0, 15.0, 5.0, 6.0)
# a wall across the whole world at x in [4, 5] with one window, y in [1, 5], z in [2, 3.5]
WALL3 = (
    Box((4.0, -5.0, 0.0), (5.0, 5.0, 2.0)),
    Box((4.0, -5.0, 3.5), (5.0, 5.0, 6.0)),
    Box((4.0, -5.0, 2.0), (5.0, 1.0, 3.5)),
)


def test_3d_astar_is_octile_optimal_in_free_space():
    maps = OccupancyMaps((), BOUNDS3, 1, 0.1, 0.3, 100.0, margin=0.5)
    start, goal = np.array([0.0, 0.0, 1.0]), np.array([3.0, 2.0, 2.0])
    path = maps.search(0, start, goal, 10**6)
    np.testing.assert_allclose(path[[0, -1]], [start, goal])
    s, g = np.array(maps.cell(start)), np.array(maps.cell(goal))
    path[0], path[-1] = maps.center(*s[:, None]), maps.center(*g[:, None])  # the cell path itself
    length = np.linalg.norm(np.diff(path, axis=0), axis=1).sum()
    d3, d2, d1 = np.sort(np.abs(g - s))  # the 26-connected optimum: body, face, then straight steps
    octile = 0.1 * (math.sqrt(3) * d3 + math.sqrt(2) * (d2 - d3) + (d1 - d2))
    assert length == pytest.approx(octile, rel=1e-9)
    assert octile == pytest.approx(1.0 + math.sqrt(2) + math.sqrt(3), abs=0.1)


def test_3d_astar_goes_through_the_window_and_never_through_an_obstacle():
    from swarmnav.sensing import segments_blocked, signed_distance

    g = Geometry.from_obstacles(list(WALL3), dim=3)
    start, goal = np.array([0.0, 0.0, 1.0]), np.array([10.0, 0.0, 1.0])
    assert segments_blocked(g, start[None], goal[None])[0]  # the straight line is blocked
    maps = OccupancyMaps(WALL3, BOUNDS3, 1, 0.1, 0.3, 100.0, margin=0.5, wide=0.9, wide_cost=2.0)
    assert maps.search(0, start, goal, 10**6)[:, 0].max() == pytest.approx(10.0)  # unseen wall: straight
    assert maps.observe(0, start) == 3
    path = maps.search(0, start, goal, 10**6)
    np.testing.assert_allclose(path[[0, -1]], [start, goal])
    # every cell centre keeps the d_thr tier (0.5 m less half a cell diagonal) ...
    assert signed_distance(g, path).min() >= 0.5 - 0.09
    # ... and no step of the path crosses an obstacle
    assert not segments_blocked(g, path[:-1], path[1:]).any()
    at_wall = path[(path[:, 0] > 3.9) & (path[:, 0] < 5.1)]
    assert at_wall[:, 1].min() > 1.0 and 2.0 < at_wall[:, 2].min() and at_wall[:, 2].max() < 3.5  # the window


def test_3d_map_holds_only_seen_obstacles_and_has_the_2d_classes():
    """A vertical prism seen from the side: its voxel classes at one altitude are the planar
    map's classes of its footprint (the same clearance bands in 2-D and 3-D)."""
    post3 = Box((4.0, -0.5, 0.0), (5.0, 0.5, 6.0))
    maps3 = OccupancyMaps((post3,), BOUNDS3, 2, 0.1, 0.3, 5.0, margin=0.5, wide=0.9)
    maps2 = OccupancyMaps((Box((4.0, -0.5), (5.0, 0.5)),), BOUNDS3[:2] + BOUNDS3[3:5], 1, 0.1, 0.3, 5.0,
                          margin=0.5, wide=0.9)
    assert maps3.observe(0, np.array([0.0, 0.0, 3.0])) == 1 and maps3.observe(1, np.array([-5.0, 4.0, 3.0])) == 0
    maps2.observe(0, np.zeros(2))
    assert maps3.grids[1].max() == 0
    np.testing.assert_array_equal(maps3.grids[0][30], maps2.grids[0])  # z = 3.05 m, far from the ends


def _path_cost(maps, robot, path):
    """The search's cost of a cell path: step length [cells] times the class cost of the entered voxel."""
    cells = np.array([maps.cell(p) for p in path])
    steps = np.abs(np.diff(cells, axis=0)).sum(axis=1)
    return float((np.sqrt(steps) * maps.cost[maps.grids[robot][tuple(cells[1:].T)]]).sum())


@pytest.mark.parametrize("goal", [(10.0, 0.0, 1.0), (12.0, -3.0, 4.5), (6.0, 4.0, 2.5)])
def test_3d_field_search_finds_a_path_as_cheap_as_exact_astar(goal):
    """Oracle: the path down the cost-to-go field costs what A* with an admissible heuristic
    (weight 1) finds, in the windowed wall with two posts that put the wide band in the way."""
    obstacles = WALL3 + (Box((2.0, -1.0, 0.0), (2.6, -0.4, 6.0)), Box((7.0, 0.5, 0.0), (7.5, 1.2, 4.0)))
    start, goal = np.array([0.0, 0.0, 1.0]), np.array(goal)
    paths = {}
    for field in (True, False):
        maps = OccupancyMaps(obstacles, BOUNDS3, 1, 0.1, 0.3, 100.0, margin=0.5, wide=0.9, wide_cost=2.0,
                             weight_3d=1.0, field_3d=field)
        maps.observe(0, start)
        paths[field] = (maps, maps.search(0, start, goal, 10**7))
    (mf, pf), (ma, pa) = paths[True], paths[False]
    assert mf.fields_built == 1 and ma.fields_built == 0
    np.testing.assert_allclose(pf[[0, -1]], [start, goal])
    assert _path_cost(mf, 0, pf) == pytest.approx(_path_cost(ma, 0, pa), rel=1e-12)
    cells = np.array([mf.cell(p) for p in pf])
    assert np.abs(np.diff(cells, axis=0)).max() == 1  # 26-connected steps, no jumps


def test_3d_field_is_shared_by_equal_maps_and_guides_the_search_of_a_grown_map():
    obstacles = (Box((4.0, -0.5, 0.0), (5.0, 0.5, 6.0)), Box((11.0, -1.5, 0.0), (12.0, 1.5, 6.0)))
    kw = dict(margin=0.5, wide=0.9, wide_cost=2.0)
    maps = OccupancyMaps(obstacles, BOUNDS3, 3, 0.1, 0.3, 6.0, field_3d=True, **kw)
    goal = np.array([14.0, 0.0, 3.0])
    for r, y in enumerate((-1.0, 0.0, 1.0)):
        assert maps.observe(r, np.array([0.0, y, 3.0])) == 1  # the first post only (range 6 m)
        assert maps.search(r, np.array([0.0, y, 3.0]), goal, 10**6) is not None
    assert maps.fields_built == 1  # three robots, one map, one goal: one field
    start = np.array([8.0, 0.0, 3.0])
    assert maps.observe(1, start) == 1  # robot 1 sees the second post: its map grew
    path = maps.search(1, start, goal, 10**6)
    assert maps.fields_built == 1  # searched with the older field as heuristic, no new field
    # oracle: as cheap as exact A* on the grown map, and through free space
    exact = OccupancyMaps(obstacles, BOUNDS3, 1, 0.1, 0.3, 6.0, weight_3d=1.0, **kw)
    exact.observe(0, np.array([0.0, 0.0, 3.0]))
    exact.observe(0, start)
    ref = exact.search(0, start, goal, 10**7)
    assert _path_cost(maps, 1, path) == pytest.approx(_path_cost(exact, 0, ref), rel=1e-5)
    from swarmnav.sensing import segments_blocked, signed_distance

    g = Geometry.from_obstacles(list(obstacles), dim=3)
    assert not segments_blocked(g, path[:-1], path[1:]).any()
    assert signed_distance(g, path).min() >= 0.5 - 0.09  # the d_thr tier, less half a cell diagonal


def test_3d_search_falls_back_to_the_body_clearance_through_a_window_too_narrow_for_d_thr():
    """A 0.9 m window: no voxel in it keeps d_thr = 0.5 m from the frame, so the first tier's free
    space is split in two and the search falls back to the 0.3 m body clearance, through it."""
    wall = (Box((4.0, -5.0, 0.0), (5.0, 5.0, 2.0)), Box((4.0, -5.0, 2.9), (5.0, 5.0, 6.0)),
            Box((4.0, -5.0, 2.0), (5.0, -0.45, 2.9)), Box((4.0, 0.45, 2.0), (5.0, 5.0, 2.9)))
    maps = OccupancyMaps(wall, BOUNDS3, 1, 0.1, 0.3, 100.0, margin=0.5, wide=0.9, wide_cost=2.0, weight_3d=10.0)
    start, goal = np.array([0.0, 0.0, 1.0]), np.array([10.0, 0.0, 1.0])
    maps.observe(0, start)
    path = maps.search(0, start, goal, 10**7)
    from swarmnav.sensing import segments_blocked, signed_distance

    g = Geometry.from_obstacles(list(wall), dim=3)
    assert not segments_blocked(g, path[:-1], path[1:]).any()
    at_wall = path[(path[:, 0] > 3.9) & (path[:, 0] < 5.1)]
    assert np.abs(at_wall[:, 1]).max() < 0.45 and 2.0 < at_wall[:, 2].min() and at_wall[:, 2].max() < 2.9
    assert 0.3 - 0.09 <= signed_distance(g, path).min() < 0.5  # the body clearance, not d_thr
    closed = OccupancyMaps(wall[:2] + (Box((4.0, -5.0, 2.0), (5.0, 5.0, 2.9)),), BOUNDS3, 1, 0.1, 0.3, 100.0,
                           margin=0.5, wide=0.9, wide_cost=2.0, weight_3d=10.0)
    closed.observe(0, start)
    assert closed.search(0, start, goal, 10**7) is None  # no window: no path in either tier
