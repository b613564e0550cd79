"""Oracle tests of the planar grid search (planning/maps.py): the compiled A* with kept work arrays
and the remembered searches against a plain Python A* written the way the search was first
written (fresh arrays every search, a binary heap that swaps), on random forests.

The two must agree cell for cell: the search's ties between equal keys are broken by the heap's
arrangement, so a faster search is only acceptable if it returns the very same path (SPH's
reference runs are bit-identical, docs/determinism.md)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from swarmnav.planning.maps import OccupancyMaps
from swarmnav.world.obstacles import Box, Circle


# ---------------------------------------------------------------- the plain reference


def _push(keys: list, vals: list, key: float, val: int) -> None:
    keys.append(key)
    vals.append(val)
    k = len(keys) - 1
    while k > 0:
        p = (k - 1) // 2
        if keys[p] <= keys[k]:
            break
        keys[p], keys[k] = keys[k], keys[p]
        vals[p], vals[k] = vals[k], vals[p]
        k = p


def _pop(keys: list, vals: list) -> int:
    val = vals[0]
    keys[0], vals[0] = keys[-1], vals[-1]
    keys.pop()
    vals.pop()
    size, k = len(keys), 0
    while True:
        l = 2 * k + 1
        if l >= size:
            break
        c = l + 1 if l + 1 < size and keys[l + 1] < keys[l] else l
        if keys[k] <= keys[c]:
            break
        keys[c], keys[k] = keys[k], keys[c]
        vals[c], vals[k] = vals[k], vals[c]
        k = c
    return val


def _astar(occ: np.ndarray, s: tuple, goal: tuple, max_expand: int, blocked: int, cost: np.ndarray) -> list[int]:
    ny, nx = occ.shape
    g = [math.inf] * (ny * nx)
    parent = [-1] * (ny * nx)
    closed = [False] * (ny * nx)
    keys: list[float] = []
    vals: list[int] = []
    start, end = s[0] * nx + s[1], goal[0] * nx + goal[1]
    g[start] = 0.0
    _push(keys, vals, 0.0, start)
    expanded = 0
    while keys:
        cur = _pop(keys, vals)
        if closed[cur]:
            continue
        if cur == end:
            out = [cur]
            while out[-1] != start:
                out.append(parent[out[-1]])
            return out[::-1]
        closed[cur] = True
        expanded += 1
        if expanded > max_expand:
            return []
        cy, cx = divmod(cur, nx)
        for dy, dx in ((-1, -1), (-1, 0), (-1, 1), (0, -1), (0, 1), (1, -1), (1, 0), (1, 1)):
            y, x = cy + dy, cx + dx
            if not (0 <= y < ny and 0 <= x < nx) or occ[y, x] >= blocked:
                continue
            diag = dy != 0 and dx != 0
            if diag and (occ[cy, x] >= blocked or occ[y, cx] >= blocked):
                continue
            nb = y * nx + x
            if closed[nb]:
                continue
            ng = g[cur] + (1.4142135623730951 if diag else 1.0) * float(cost[occ[y, x]])
            if ng < g[nb]:
                g[nb] = ng
                parent[nb] = cur
                ady, adx = abs(goal[0] - y), abs(goal[1] - x)
                h = (ady + adx) + (1.4142135623730951 - 2.0) * min(ady, adx)
                _push(keys, vals, ng + h * 1.001, nb)
    return []


def _nearest_free(occ: np.ndarray, iy: int, ix: int, max_r: int, blocked: int) -> tuple[int, int]:
    ny, nx = occ.shape
    if occ[iy, ix] < blocked:
        return iy, ix
    for r in range(1, max_r + 1):
        best, by, bx = 1e18, -1, -1
        for dy in range(-r, r + 1):
            for dx in range(-r, r + 1):
                if max(abs(dy), abs(dx)) != r:
                    continue
                y, x = iy + dy, ix + dx
                if 0 <= y < ny and 0 <= x < nx and occ[y, x] < blocked and dy * dy + dx * dx < best:
                    best, by, bx = dy * dy + dx * dx, y, x
        if by >= 0:
            return by, bx
    return -1, -1


def _cell(maps: OccupancyMaps, p: np.ndarray) -> tuple[int, int]:
    return tuple(int(np.clip(round((p[k] - maps.origin[k]) / maps.resolution), 0, maps.shape[-1 - k] - 1))
                 for k in (1, 0))


def reference_search(maps: OccupancyMaps, robot: int, start: np.ndarray, goal: np.ndarray,
                     max_expand: int) -> np.ndarray | None:
    """OccupancyMaps.search on a planar map, as first written."""
    occ = maps.grids[robot]
    top = len(maps.levels) + 1
    gc = _cell(maps, goal)
    path: list[int] = []
    g = gc
    for blocked in (top - 1, top) if top > 1 else (1,):
        s = _nearest_free(occ, *_cell(maps, start), 40, blocked)
        g = _nearest_free(occ, *gc, 40, blocked)
        if s[0] >= 0 and g[0] >= 0:
            path = _astar(occ, s, g, max_expand, blocked, maps.cost)
            if path:
                break
    if not path:
        return None
    iy, ix = np.unravel_index(np.array(path, dtype=np.int64), maps.shape)
    out = maps.origin + maps.resolution * np.column_stack([ix, iy])
    out[0] = start
    if g == gc:
        out[-1] = goal
    return out


# ---------------------------------------------------------------- the tests

BOUNDS = (-2.0, -3.0, 7.0, 3.0)


def _forest(rng: np.random.Generator) -> tuple:
    obstacles = [Circle((float(rng.uniform(0.5, 5.5)), float(rng.uniform(-2.5, 2.5))), float(rng.uniform(0.2, 0.7)))
                 for _ in range(int(rng.integers(2, 9)))]
    if rng.random() < 0.3:
        obstacles.append(Box((2.0, -3.0), (2.4, float(rng.uniform(-1.5, 1.5)))))
    return tuple(obstacles)


@pytest.mark.parametrize("seed", range(6))
def test_search_matches_the_plain_reference_on_random_forests(seed):
    rng = np.random.default_rng(seed)
    wide_cost = float(rng.choice([0.0, 1.0, 2.0]))  # 0: many equal keys, so the heap breaks ties
    maps = OccupancyMaps(_forest(rng), BOUNDS, 3, 0.1, 0.3, float(rng.uniform(2.0, 8.0)), margin=0.5,
                         wide=0.9 if wide_cost else 0.0, wide_cost=wide_cost)
    for _ in range(12):
        robot = int(rng.integers(3))
        start = np.array([rng.uniform(-2.0, 1.0), rng.uniform(-3.0, 3.0)])
        goal = np.array([rng.uniform(4.0, 7.0), rng.uniform(-3.0, 3.0)])
        maps.observe(robot, start)
        cap = int(rng.choice([50, 100_000]))  # a cap that ends searches early, and none
        want = reference_search(maps, robot, start, goal, cap)
        for _ in range(2):  # the second time from the remembered searches
            got = maps.search(robot, start, goal, cap)
            if want is None:
                assert got is None
            else:
                assert got is not None and np.array_equal(got, want)


def test_a_remembered_search_is_not_reused_on_a_grown_map():
    """Two robots at the same cells with different maps, and one robot before and after it sees a
    wall: each search answers for the map it was made on."""
    wall = Box((2.0, -3.0), (2.4, 2.0))
    maps = OccupancyMaps((wall,), BOUNDS, 2, 0.1, 0.3, 3.0, margin=0.5)
    start, goal = np.array([-1.5, 0.0]), np.array([6.0, 0.0])
    maps.observe(0, np.array([1.0, 0.0]))  # robot 0 sees the wall, robot 1 does not
    seen, blind = maps.search(0, start, goal, 100_000), maps.search(1, start, goal, 100_000)
    assert np.all(np.abs(blind[:, 1]) <= 0.1)  # straight through the unknown wall
    assert seen[:, 1].max() > 2.0  # around its open end
    assert np.array_equal(seen, reference_search(maps, 0, start, goal, 100_000))
    maps.observe(1, np.array([1.0, 0.0]))
    assert np.array_equal(maps.search(1, start, goal, 100_000), seen)
