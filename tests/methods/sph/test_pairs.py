"""The pair guard of SPH (ours, parts/pairs.py; docs/methods/sph-crowd.md): safety barrier
certificates for double integrators, half of each pair's constraint per robot."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import minimize

import swarmnav
from swarmnav.methods.sph.parts.pairs import bound_rows, obstacle_constraints, pair_constraints, pair_guard, pair_reach
from swarmnav.sensing import nearest_obstacle, surfaces_within
from swarmnav.world.obstacles import Box, Circle, Geometry
from swarmnav.world import from_dict

D_SAFE, DECEL, GAMMA, V_MAX, DT = 0.42, 0.75, 2.0, 1.0, 0.01


def _rows(a, x, v, a_max):
    """Each robot's half-space constraints ``g . a_r <= c`` as the module states them."""
    pairs, n, b = pair_constraints(x, v, D_SAFE, DECEL, GAMMA, a_max, V_MAX, DT)
    rows = [[] for _ in range(len(a))]
    for (i, j), nn, bb in zip(pairs, n, b):
        rows[i].append((-nn, bb / 2))
        rows[j].append((nn, bb / 2))
    return rows


def _nearest(a0, rows):
    """The nearest command to ``a0`` meeting ``rows``, by SciPy's SLSQP."""
    cons = [{"type": "ineq", "fun": (lambda a, g=g, c=c: c - g @ a), "jac": (lambda a, g=g: -g)} for g, c in rows]
    res = minimize(lambda a: np.sum((a - a0) ** 2), a0, jac=lambda a: 2 * (a - a0), constraints=cons,
                   method="SLSQP", options={"ftol": 1e-14, "maxiter": 500})
    return res.x, res.success


crowds = st.integers(2, 7).flatmap(lambda n: st.tuples(
    st.lists(st.tuples(st.floats(-1.2, 1.2), st.floats(-1.2, 1.2)), min_size=n, max_size=n),
    st.lists(st.tuples(st.floats(-0.7, 0.7), st.floats(-0.7, 0.7)), min_size=n, max_size=n),
    st.lists(st.tuples(st.floats(-1.0, 1.0), st.floats(-1.0, 1.0)), min_size=n, max_size=n)))


@settings(max_examples=60, deadline=None)
@given(crowds)
def test_guard_gives_each_robot_the_nearest_command_meeting_its_constraints(crowd):
    x, v, a0 = (np.array(c, dtype=float) for c in crowd)
    d = np.linalg.norm(x[:, None] - x[None], axis=2) + 10 * np.eye(len(x))
    if d.min() < D_SAFE + 0.01:  # a pair already inside d_safe may have no feasible command
        return
    a_max = 1.5
    out, changed, infeasible = pair_guard(a0, x, v, D_SAFE, DECEL, GAMMA, a_max, V_MAX, DT)
    rows = _rows(a0, x, v, a_max)
    moved = 0
    for r in range(len(x)):
        cut = a0[r] * min(1.0, a_max / max(np.linalg.norm(a0[r]), 1e-300))  # as the dynamics cut it
        if not rows[r] or all(g @ cut <= c + 1e-9 for g, c in rows[r]):
            assert np.array_equal(out[r], a0[r])  # a robot whose command breaks nothing keeps it
            continue
        moved += 1
        ref, success = _nearest(cut, rows[r])
        feasible = success and all(g @ ref <= c + 1e-7 for g, c in rows[r])
        if feasible:  # the exact solution is SLSQP's, and meets every constraint
            assert np.allclose(out[r], ref, atol=1e-6), (r, out[r], ref)
            assert all(g @ out[r] <= c + 1e-8 for g, c in rows[r])
    assert changed == moved


@settings(max_examples=60, deadline=None)
@given(crowds)
def test_bound_keeps_each_moved_command_within_a_max_and_nearest_there(crowd):
    x, v, a0 = (3.0 * np.array(c, dtype=float) if k == 2 else np.array(c, dtype=float) for k, c in enumerate(crowd))
    d = np.linalg.norm(x[:, None] - x[None], axis=2) + 10 * np.eye(len(x))
    if d.min() < D_SAFE + 0.01:
        return
    a_max = 1.5
    g_box, c_box = bound_rows(2, a_max)
    out, changed, infeasible = pair_guard(a0, x, v, D_SAFE, DECEL, GAMMA, a_max, V_MAX, DT, bound=(g_box, c_box))
    free, _, _ = pair_guard(a0, x, v, D_SAFE, DECEL, GAMMA, a_max, V_MAX, DT)
    rows = _rows(a0, x, v, a_max)
    for r in range(len(x)):
        if np.linalg.norm(free[r]) <= a_max * np.cos(np.pi / 16) or np.array_equal(free[r], a0[r]):
            assert np.array_equal(out[r], free[r])  # inside the polygon (or untouched): the bound changes nothing
            continue
        cut = a0[r] * min(1.0, a_max / max(np.linalg.norm(a0[r]), 1e-300))
        both = rows[r] + list(zip(g_box, c_box))
        ref, success = _nearest(cut, both)
        if success and all(g @ ref <= c + 1e-7 for g, c in both):  # feasible within the bound
            assert np.linalg.norm(out[r]) <= a_max + 1e-9  # what the dynamics fly unchanged
            assert np.allclose(out[r], ref, atol=1e-6), (r, out[r], ref)


def test_bound_rows_lie_inside_the_dynamics_bound():
    for dim in (2, 3):
        g, c = bound_rows(dim, 1.5)
        assert np.allclose(np.linalg.norm(g, axis=1), 1.0)
        # the polytope's extreme point in any direction u lies within the ball: c / max_k g_k . u <= a_max
        u = np.random.default_rng(0).normal(size=(5000, dim))
        u /= np.linalg.norm(u, axis=1, keepdims=True)
        assert np.max(c[0] / np.max(u @ g.T, axis=1)) <= 1.5 + 1e-12
        assert c[0] > 0.9 * 1.5  # and does not give much of it away
    g, c = bound_rows(2, 1.5, "axis")
    assert np.array_equal(c, np.full(4, 1.5))


def test_bound_stops_a_pressed_robot_the_dynamics_would_have_cut_into_its_neighbour():
    """Robot 0 closes on robot 1 (0.64 m away, closing at 1.09 m/s along their line); the nearest
    command meeting the pair's constraint lies beyond a_max, and the dynamics' cut toward 0 breaks
    it; with the bound the command meets it within a_max. (Found by a random search.)"""
    x = np.array([[-0.1, 0.3], [-0.5, -0.2], [-0.8, -0.7]])
    v = np.array([[-0.6, -0.2], [-0.1, 0.8], [-0.4, -1.0]])
    a0 = np.array([[1.0, -1.3], [-1.2, 1.4], [0.8, -0.5]])
    rows = _rows(a0, x, v, 1.5)
    free, _, _ = pair_guard(a0, x, v, D_SAFE, DECEL, GAMMA, 1.5, V_MAX, DT)
    assert np.linalg.norm(free[0]) > 1.5  # beyond what the dynamics fly
    cut = free[0] * 1.5 / np.linalg.norm(free[0])
    assert any(g @ cut > c + 1e-9 for g, c in rows[0])  # and the cut breaks the constraint
    out, _, infeasible = pair_guard(a0, x, v, D_SAFE, DECEL, GAMMA, 1.5, V_MAX, DT, bound=bound_rows(2, 1.5))
    assert infeasible == 0 and np.linalg.norm(out[0]) <= 1.5
    assert all(g @ out[0] <= c + 1e-9 for g, c in rows[0])


def _close_in(guard: bool, n: int = 40, seconds: float = 12.0, dt: float = 0.01) -> float:
    """Closest distance [m] of ``n`` double integrators (|v| <= 1, |a| <= 1.5) that all steer for
    one point with a PD law, from a ring of radius 3 m."""
    ang = np.linspace(0, 2 * np.pi, n, endpoint=False)
    x = 3.0 * np.c_[np.cos(ang), np.sin(ang)]
    v = np.zeros_like(x)
    closest = np.inf
    for _ in range(int(seconds / dt)):
        a = 2.0 * (0.0 - x) - 2.0 * v
        if guard:
            a, _, _ = pair_guard(a, x, v, D_SAFE, DECEL, GAMMA, 1.5, V_MAX, dt)
        norm = np.linalg.norm(a, axis=1, keepdims=True)
        a = a * np.minimum(1.0, 1.5 / np.maximum(norm, 1e-12))
        v = v + a * dt
        speed = np.linalg.norm(v, axis=1, keepdims=True)
        v = v * np.minimum(1.0, V_MAX / np.maximum(speed, 1e-12))
        x = x + v * dt
        d = np.linalg.norm(x[:, None] - x[None], axis=2) + 10 * np.eye(n)
        closest = min(closest, float(d.min()))
    return closest


def test_guard_keeps_robots_that_all_head_for_one_point_out_of_contact():
    assert _close_in(False) < 0.1  # unguarded they pile onto the point
    assert _close_in(True) >= 0.4  # guarded none comes within the contact distance


def _into_wall(walls: bool, dt: float = 0.01) -> float:
    """Closest clearance [m] of a robot (body 0.2 m) driven at full thrust (1.5 m/s^2) into a wall
    at x = 0 from x = 3 m, 1 m/s towards it, with a neighbour beside it; obstacle rows or not."""
    x = np.array([[3.0, 0.0], [3.0, 1.0]])
    v = np.array([[-1.0, 0.0], [0.0, 0.0]])
    closest = np.inf
    for _ in range(int(6.0 / dt)):
        a = np.array([[-1.5, 0.0], [0.0, 0.0]])
        clearance, away = x[:, 0].copy(), np.tile([1.0, 0.0], (2, 1))
        a, _, _ = pair_guard(a, x, v, D_SAFE, DECEL, GAMMA, 1.5, V_MAX, dt,
                             (clearance, away, 0.2 + 0.02) if walls else None)
        v = v + a * dt
        v = v * np.minimum(1.0, V_MAX / np.maximum(np.linalg.norm(v, axis=1, keepdims=True), 1e-12))
        x = x + v * dt
        closest = min(closest, float(x[0, 0]))
    return closest


def test_obstacle_rows_stop_a_robot_driven_into_a_wall_short_of_contact():
    assert _into_wall(False) < 0.0  # the pair guard alone lets it through the wall
    closest = _into_wall(True)
    assert 0.2 <= closest <= 0.3  # it stops past contact (body radius 0.2 m), near the 0.22 m asked


def test_obstacle_rows_leave_robots_that_cannot_reach_their_obstacle():
    v = np.array([[1.0, 0.0], [0.0, 0.0], [0.0, -1.0]])
    clearance = np.array([20.0, np.inf, 0.25])
    away = np.array([[1.0, 0.0], [0.0, 0.0], [0.0, 1.0]])
    robots, n, b = obstacle_constraints(v, clearance, away, 0.22, DECEL, GAMMA, 1.5, 0.01)
    assert robots.tolist() == [2]  # far away or in an empty world: no row
    assert np.allclose(n, [[0.0, 1.0]]) and b[0] < 0.0  # closing at 1 m/s 3 cm out: it must brake


def test_default_build_guards_pairs_on_crowds_only_and_paper_never():
    # 30 robots gather at one goal in an open plane: the default build (crowd parts on from 30
    # robots) guards pairs as they pack, and no pair comes within 2 body radii + pair_margin
    scn = {"name": "gather", "world": {"bounds": [-12.0, -14.0, 28.0, 14.0]},
           "swarm": {"n": 30, "spawn": [-8.0, -4.0, 0.0, 4.0]}, "goal": {"position": [14.0, 0.0]}}
    crowd = swarmnav.run("sph", from_dict(scn), seed=1, horizon=40.0)
    assert 0.0 < crowd.metrics["sph_pair_guarded_fraction"] < 1.0
    assert crowd.metrics["min_inter_robot_distance"] >= 0.42 - 1e-3
    assert crowd.metrics["sph_swarm_success"] == 1.0
    small = swarmnav.run("sph", from_dict({**scn, "swarm": {**scn["swarm"], "n": 15}}), seed=1, steps=200)
    assert "sph_pair_guarded_fraction" not in small.metrics
    paper = swarmnav.run("sph", from_dict(scn), seed=1, steps=200, preset="paper")
    assert "sph_pair_guarded_fraction" not in paper.metrics


def _between_trunks(every: bool, dt: float = 0.01) -> float:
    """Closest clearance [m] to trunk B of a robot driven at full thrust along +x beside a wall
    A, 0.25 m from its path (the nearest obstacle until too late), towards a trunk B ahead."""
    geom = Geometry.from_obstacles([Box((-1.0, 0.25), (6.0, 1.0)), Circle((3.0, -0.1), 0.3)])
    x = np.array([[0.0, 0.0], [0.0, 3.0]])
    v = np.array([[1.0, 0.0], [0.0, 0.0]])
    closest = np.inf
    for _ in range(int(4.0 / dt)):
        a = np.array([[1.5, 0.0], [0.0, 0.0]])
        if every:
            robots, gap, toward = surfaces_within(geom, x, pair_reach(0.22, DECEL, GAMMA, 1.5, V_MAX))
            walls = (gap, -toward, 0.22, robots)
        else:
            d, toward = nearest_obstacle(geom, x)
            walls = (d, -toward, 0.22)
        a, _, _ = pair_guard(a, x, v, D_SAFE, DECEL, GAMMA, 1.5, V_MAX, dt, walls)
        v = v + a * dt
        v = v * np.minimum(1.0, V_MAX / np.maximum(np.linalg.norm(v, axis=1, keepdims=True), 1e-12))
        x = x + v * dt
        closest = min(closest, float(np.hypot(*(x[0] - (3.0, -0.1))) - 0.3))
    return closest


def test_a_row_per_obstacle_stops_a_robot_at_a_trunk_that_is_not_its_nearest():
    assert _between_trunks(False) < 0.2  # the nearest obstacle's row alone lets it into B
    assert 0.2 <= _between_trunks(True) <= 0.3  # every trunk's row stops it near the 0.22 m asked
