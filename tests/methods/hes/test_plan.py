"""Stall planner (ours, ``stall_plan``; docs/methods/hes.md "Stall planner"): a map of the
returns the swarm's rings have seen, a clearance-weighted cost-to-go field from the goal, and a
route through it once the reactive corridor choice has stalled."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra

import swarmnav
from swarmnav.methods.hes.parts.plan import clearance, cost_to_go, descend, lookahead, mark_hits
from swarmnav.sensing import ray_table

FOREST = "random_forest:density=0.25,seed=2,length=12,r_min=1.0,r_max=2.0,min_passage=1.0"


def _reference_cost_to_go(clr, gi, gj, cell, clear_min, d_pref, weight):
    """The same field with scipy's Dijkstra on an explicit 8-connected graph (plain reference)."""
    ny, nx = clr.shape
    c = 1.0 + weight * np.maximum(0.0, d_pref - clr) / np.maximum(clr, clear_min)
    ok = clr >= clear_min
    rows, cols, w = [], [], []
    for i in range(ny):
        for j in range(nx):
            if not ok[i, j]:
                continue
            for di in (-1, 0, 1):
                for dj in (-1, 0, 1):
                    a, b = i + di, j + dj
                    if (di or dj) and 0 <= a < ny and 0 <= b < nx and ok[a, b]:
                        rows.append(i * nx + j)
                        cols.append(a * nx + b)
                        w.append(cell * math.hypot(di, dj) * 0.5 * (c[i, j] + c[a, b]))
    g = coo_matrix((w, (rows, cols)), shape=(ny * nx, ny * nx)).tocsr()
    out = dijkstra(g, directed=True, indices=gi * nx + gj).reshape(ny, nx)
    if not ok[gi, gj]:
        out[:] = np.inf
    return out


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_cost_to_go_matches_scipy_dijkstra(seed):
    rng = np.random.default_rng(seed)
    occ = rng.random((23, 31)) < 0.08
    gi, gj = 11, 29
    occ[gi - 2:gi + 3, gj - 2:] = False  # the goal is in the open
    clr = clearance(occ, 0.2)
    got = cost_to_go(clr, gi, gj, 0.2, 0.3, 1.5, 1.0)
    ref = _reference_cost_to_go(clr, gi, gj, 0.2, 0.3, 1.5, 1.0)
    assert np.array_equal(np.isfinite(got), np.isfinite(ref))
    fin = np.isfinite(ref)
    assert fin.sum() > 100
    np.testing.assert_allclose(got[fin], ref[fin], rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_cost_to_go_stopped_early_is_exact_where_it_is_finite_and_near_the_needed_cells(seed):
    rng = np.random.default_rng(10 + seed)
    occ = rng.random((60, 80)) < 0.05
    gi, gj = 30, 75
    occ[gi - 2:gi + 3, gj - 2:] = False
    clr = clearance(occ, 0.2)
    full = cost_to_go(clr, gi, gj, 0.2, 0.3, 1.5, 1.0)
    need = np.array([[30, 40], [35, 38], [28, 44]])
    need = need[np.isfinite(full[need[:, 0], need[:, 1]])]
    slack = 2.0
    part = cost_to_go(clr, gi, gj, 0.2, 0.3, 1.5, 1.0, need, slack)
    fin = np.isfinite(part)
    np.testing.assert_array_equal(part[fin], full[fin])  # every value it keeps is the full field's
    top = full[need[:, 0], need[:, 1]].max()
    np.testing.assert_array_equal(part[full <= top + slack], full[full <= top + slack])  # all within slack
    assert (np.isfinite(full) & ~fin).sum() > 0  # and it did stop early
    # a descent from a needed cell is the same path on either field
    for i, j in need:
        np.testing.assert_array_equal(descend(part, i, j, 10_000), descend(full, i, j, 10_000))
    # nothing open needed (or nothing reachable): the whole field
    blocked = np.argwhere(clr < 0.3)[:1]
    np.testing.assert_array_equal(cost_to_go(clr, gi, gj, 0.2, 0.3, 1.5, 1.0, blocked, slack), full)


def test_descend_and_lookahead_follow_the_field_to_the_goal_through_the_wide_gap():
    # a wall at x = 5 m with a 0.8 m gap (below clear_min 2 x 0.6 m) and a 2 m gap
    cell = 0.2
    occ = np.zeros((60, 60), dtype=bool)
    occ[:, 25] = True
    occ[10:14, 25] = False  # 0.8 m
    occ[40:50, 25] = False  # 2.0 m
    clr = clearance(occ, cell)
    dist = cost_to_go(clr, 20, 55, cell, 0.6, 1.5, 1.0)
    path = descend(dist, 12, 5, 10_000)
    assert tuple(path[-1]) == (20, 55)
    assert np.all(np.diff(dist[path[:, 0], path[:, 1]]) < 0)  # strictly down the field
    crossing = path[path[:, 1] == 25]
    assert np.all((crossing[:, 0] >= 40) & (crossing[:, 0] < 50))  # through the wide gap, not the near narrow one
    assert np.all(clr[path[:, 0], path[:, 1]] >= 0.6)
    # lookahead: the point `look` m of arc down the same descent, and the narrowest clearance near it
    start = np.array([[5 * cell + 0.1, 12 * cell + 0.1]])
    pt, half = lookahead(dist, clr, start, 0.0, 0.0, cell, 2.0, 2.0)
    arc = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(path, axis=0).T) * cell)])
    k = int(np.searchsorted(arc, 2.0 - 1e-9))  # the first cell at least 2 m of arc down
    np.testing.assert_allclose(pt[0], (path[k, ::-1] + 0.5) * cell)
    near = arc <= 2.0
    assert half[0] == pytest.approx(clr[path[near, 0], path[near, 1]].min())


def test_mark_hits_matches_a_plain_loop():
    rng = np.random.default_rng(3)
    cos, sin = ray_table(36)
    x = rng.uniform(-3.0, 3.0, (4, 2))
    ring = rng.uniform(0.5, 25.0, (4, 36))
    occ = np.zeros((40, 50), dtype=bool)
    mark_hits(occ, ring, x, cos, sin, 20.0, -5.0, -4.0, 0.25)
    ref = np.zeros_like(occ)
    for i in range(4):
        for r in range(36):
            if ring[i, r] < 20.0:
                jx = math.floor((x[i, 0] + ring[i, r] * cos[r] + 5.0) / 0.25)
                iy = math.floor((x[i, 1] + ring[i, r] * sin[r] + 4.0) / 0.25)
                if 0 <= iy < 40 and 0 <= jx < 50:
                    ref[iy, jx] = True
    assert ref.any() and np.array_equal(occ, ref)


def test_planner_never_engaged_leaves_the_run_identical():
    a = swarmnav.run("hes", "default_corridor", seed=1, steps=400)
    b = swarmnav.run("hes", "default_corridor", seed=1, steps=400, stall_plan=False)
    assert a.metrics["hes_plan_engaged"] == 0
    assert np.array_equal(a.positions, b.positions)


def test_swarm_crosses_a_forest_whose_visible_gaps_are_pockets():
    # density 0.25, seed 2: the widest way across is 1.5 m (below w_pass = 2 m); the corridors the
    # subleader reports are 4-5 m "gaps" between the first row of discs that close behind it.
    # Without the planner most of the swarm mills in front of the first row for the whole 90 s
    # (in the closed world 8 of 20 find the way; in an open one none did).
    on = swarmnav.run("hes", FOREST, seed=2, steps=900)
    off = swarmnav.run("hes", FOREST, seed=2, steps=900, stall_plan=False)
    assert off.metrics["Y"] == 0.0 and off.metrics["R_goal"] <= 0.5
    assert on.metrics["hes_plan_engaged"] >= 1
    assert on.metrics["R_goal"] >= 0.8 and on.metrics["Y"] == 1.0
    assert on.metrics["d_clr_min"] > 0.2  # never touched a disc (body radius 0.2 m)
