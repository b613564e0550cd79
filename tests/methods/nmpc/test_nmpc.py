"""NMPC (``nmpc``): the compiled problem against a plain NumPy reference, the limits of the first
control, a two-robot swap, determinism, counted communication and fallbacks, bad input. Short
horizons keep each solve to milliseconds."""

import numpy as np
import pytest

import swarmnav
from swarmnav.errors import ConfigError
from swarmnav.methods.base import Observation
from swarmnav.methods.nmpc import NmpcMethod
from swarmnav.methods.nmpc import solver as S
from swarmnav.planning.messages import trajectory_bytes
from swarmnav.world.generators import random_forest
from tests._helpers.cli import run_cli


def _random_problem(rng, D=2, H=8, K=3, M=4, v0_scale=0.5, feasible=False):
    """A problem with K neighbours (the first two in the cost), M obstacle slots mixing discs (or
    cylinders / balls in 3-D), half-spaces and one empty slot; ``feasible``: the start keeps
    every clearance with room to spare (it may still be unable to keep them all ahead)."""
    p0 = rng.uniform(-1, 1, D)
    q = p0 + rng.uniform(-4, 4, (K, 1, D)) + 0.1 * np.cumsum(rng.normal(size=(K, H, D)), axis=1)
    c_cost = np.array([0.5, 0.5] + [0.0] * (K - 2))
    rho_col = rng.uniform(0.0, 0.5, K)
    oc = p0 + rng.uniform(-5, 5, (M, D))
    os_ = np.ones((M, D))
    if D == 3:
        os_[0, 2] = 0.0  # a cylinder
    on = rng.normal(size=(M, D))
    on /= np.linalg.norm(on, axis=1, keepdims=True)
    alpha = np.array([1.0, 0.0] * (M // 2))
    rho = rng.uniform(0.2, 1.0, M)
    alpha[-1], on[-1], rho[-1] = 0.0, 0.0, -1.0  # an empty slot
    if feasible:
        rho_col = np.minimum(rho_col, 0.5 * np.linalg.norm(q - p0, axis=2).min(axis=1))
        for m in range(M - 1):
            if alpha[m] == 1.0:
                rho[m] = min(rho[m], 0.5 * np.linalg.norm(os_[m] * (p0 - oc[m])))
            else:
                oc[m] = p0 - (rho[m] + 1.0) * on[m]
    u = rng.normal(size=D)
    reach_c = p0 + rng.uniform(-1, 1, (K, D))
    reach_rho = rng.uniform(0.0, 0.3, K)
    reach_rho[-1] = 0.0  # an unguarded neighbour
    if feasible:
        reach_rho = np.minimum(reach_rho, 0.5 * np.linalg.norm(reach_c - p0, axis=1))
    return S.Problem(p0, v0_scale * rng.normal(size=D), 0.1, 1.0, 1.5, u / np.linalg.norm(u), 0.8, q, c_cost,
                     rho_col, oc, os_, on, rho, alpha, reach_c, reach_rho)


@pytest.mark.parametrize("D", [2, 3])
@pytest.mark.parametrize("signed", [False, True])
def test_compiled_cost_and_constraints_match_the_numpy_reference(D, signed):
    rng = np.random.default_rng(10 + D)
    w = S.Weights(1.0, 0.7, 5.0, 5.0, 0.4, 1.2, 0.01, signed)
    for _ in range(5):
        pb = _random_problem(rng, D)
        U = rng.normal(size=(8, D))
        f_ref, g_ref = S.reference(pb, w, U)
        f, g = S.evaluate(pb, w, U)
        assert f == pytest.approx(f_ref, rel=1e-10)
        np.testing.assert_allclose(g, g_ref, rtol=1e-10, atol=1e-10)
        assert np.isfinite(f) and g.shape == (8 * (3 + 4 + 2) + 3,)  # + the reach guard's 3 rows


def test_separation_and_cohesion_split_the_papers_spring_term():
    """w_sep = w_coh = 1 is the paper's single term sum_j c_j (|p_ij|^2 - d_ref^2)^2; the two parts
    add up to it, and each is zero on the other side of d_ref."""
    rng = np.random.default_rng(3)
    pb = _random_problem(rng)
    U = rng.normal(size=(8, 2))
    zero = dict(w_dir=0.0, w_nav=0.0, w_u=0.0, d_ref=1.2, eps_v=0.01)
    both = S.reference(pb, S.Weights(1.0, 1.0, **zero), U)[0]
    sep = S.reference(pb, S.Weights(1.0, 0.0, **zero), U)[0]
    coh = S.reference(pb, S.Weights(0.0, 1.0, **zero), U)[0]
    ps, _ = S.rollout(pb.p0, pb.v0, U, pb.h)
    spring = np.mean([sum(pb.c_cost[j] * (np.sum((ps[k] - pb.q[j, k]) ** 2) - 1.44) ** 2 for j in range(3))
                      for k in range(8)])
    assert both == pytest.approx(sep + coh) and both == pytest.approx(spring)


@pytest.mark.parametrize("D", [2, 3])
def test_solution_respects_every_limit_and_constraint(D):
    """A solved problem's first control is within a_max, its predicted speeds within v_max, and its
    predicted positions keep every neighbour and obstacle clearance (by the NumPy reference)."""
    rng = np.random.default_rng(20 + D)
    w = S.Weights(1.0, 1.0, 5.0, 5.0, 0.4, 1.2, 0.01, True)
    solved = 0
    for _ in range(6):
        pb = _random_problem(rng, D, v0_scale=0.3, feasible=True)
        res = S.solve(pb, w, np.zeros((8, D)), 100, 1e-4)
        if res.U is None:
            continue
        solved += 1
        assert np.linalg.norm(res.U[0]) <= 1.5 + 1e-4
        _, vs = S.rollout(pb.p0, pb.v0, res.U, pb.h)
        assert np.all(np.linalg.norm(vs, axis=1) <= 1.0 + 1e-4)
        assert S.reference(pb, w, res.U)[1].min() >= -1e-4
        np.testing.assert_allclose(res.positions, S.rollout(pb.p0, pb.v0, res.U, pb.h)[0], atol=1e-6)
    assert solved >= 5


def test_two_robots_swapping_places_stay_separated():
    """Two robots fly head-on to each other's start (a 5 cm offset breaks the symmetry), each
    with the other's broadcast prediction as a constraint: they pass, never nearer than
    2 body radii + col_margin (0.5 m), and both make progress."""
    h, H = 0.1, 15
    w = S.Weights(0.0, 0.0, 5.0, 5.0, 0.4, 1.2, 0.01, True)  # no cohesion: only the constraint keeps them apart
    x = np.array([[-3.0, 0.05], [3.0, -0.05]])
    v = np.zeros((2, 2))
    goals = x[::-1].copy()
    pred = x[:, None, :] + np.zeros((2, H, 2))
    U = np.zeros((2, H, 2))
    empty = (np.zeros((1, 2)), np.zeros((1, 2)), np.zeros((1, 2)), np.array([-1.0]), np.zeros(1))
    dmin = np.inf
    for _ in range(80):
        new = pred.copy()
        for i in range(2):
            j = 1 - i
            q = np.concatenate([pred[j, 1:], pred[j, -1:]])[None]
            g = goals[i] - x[i]
            pb = S.Problem(x[i], v[i], h, 1.0, 1.5, g / np.linalg.norm(g), 0.8 * min(1.0, np.linalg.norm(g) / 2), q,
                           np.zeros(1), np.array([0.5]), *empty)
            res = S.solve(pb, w, np.concatenate([U[i, 1:], U[i, -1:]]), 100, 1e-4)
            assert res.U is not None
            U[i], new[i] = res.U, res.positions
        pred = new
        for i in range(2):  # the plant: the same double integrator, the first control held
            x[i], v[i] = x[i] + h * v[i] + 0.5 * h * h * U[i, 0], v[i] + h * U[i, 0]
        dmin = min(dmin, float(np.linalg.norm(x[0] - x[1])))
    assert dmin >= 0.5 - 0.02  # 2 cm: the neighbour's prediction is one step old
    assert np.all(np.linalg.norm(x - goals, axis=1) < 3.0)  # each is past the midpoint, towards its goal


def _fly(m, scene, steps, seed=3):
    rng = np.random.default_rng(seed)
    x = scene.spawn_positions(rng)
    v = np.zeros_like(x)
    m.reset(scene, x, v, rng)
    amax = 0.0
    for k in range(steps):
        a, _ = m.act(Observation(k, k * m.dt, x, v), rng)
        amax = max(amax, float(np.linalg.norm(a, axis=1).max()))
        x, v = m.dynamics.step(x, v, a, m.dt)
    return x, v, amax


def test_commands_within_limits_and_every_broadcast_counted():
    scene = random_forest(density=0.25, seed=2, length=12, r_min=1.0, r_max=2.0, min_passage=1.0)
    m = NmpcMethod(prediction_horizon=1.0)
    x, v, amax = _fly(m, scene, 30)
    s = m.summary()
    n = scene.n
    assert amax <= 1.5 + 1e-9 and np.all(np.isfinite(x))
    assert s["nmpc_solves"] == len(range(0, 30, m.every)) * n  # one solve per robot per control step
    assert s["comm_messages"] == s["nmpc_solves"]
    assert s["comm_bytes"] == s["comm_messages"] * trajectory_bytes(m.H + 1)
    t = m.timings()
    assert 0 < t["plan_ms_median"] <= t["plan_ms_p95"] <= t["plan_ms_max"]
    plans = m.plans()
    assert len(plans["step"]) == s["nmpc_solves"] and np.all(np.diff(plans["offsets"]) == m.H + 1)


def test_infeasible_problems_are_counted_fallbacks_that_brake():
    """Every robot starts inside its obstacles' clearance (obs_margin 30 m) with the crowd rule
    off: no solve is feasible, each is a counted fallback, the robots brake and stay finite (the
    reach guard off: it would steer a fallback out of the violated clearances)."""
    scene = random_forest(density=0.45, seed=1, length=12, r_min=1.0, r_max=2.0, min_passage=1.0)
    m = NmpcMethod(prediction_horizon=1.0, obs_margin=30.0, sensing_range=50.0, crowd_shrink=0.0, reach_guard="off")
    x, v, _ = _fly(m, scene, 25)
    s = m.summary()
    assert s["nmpc_fallbacks"] == s["nmpc_solves"] > 0
    assert np.all(np.isfinite(x)) and np.all(np.isfinite(v))
    assert np.abs(v).max() < 1e-9  # from rest, a brake is no acceleration at all


def test_same_seed_same_flight():
    a = swarmnav.run(NmpcMethod(prediction_horizon=1.0), "random_forest:density=0.15,seed=1", seed=4, steps=30)
    b = swarmnav.run(NmpcMethod(prediction_horizon=1.0), "random_forest:density=0.15,seed=1", seed=4, steps=30)
    np.testing.assert_array_equal(a.positions, b.positions)
    assert a.metrics == b.metrics


def test_bad_input_refused():
    with pytest.raises(ConfigError):
        NmpcMethod(control_dt=0.015)  # not a whole number of dt
    with pytest.raises(ConfigError):
        NmpcMethod(prediction_horizon=30.0)
    with pytest.raises(ConfigError):
        NmpcMethod(direction="both")
    with pytest.raises(ConfigError):
        NmpcMethod(max_neig=0)
    r = run_cli("run", "--method", "nmpc", "--scenario", "random_forest:density=0.15,seed=1", "--steps", "3",
                "--set", "v_ref=-1", "--out", "/tmp/nmpc-bad-test", "--quiet", "--force")
    assert r.returncode == 2 and "Traceback" not in r.stderr and "v_ref" in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1
    r = run_cli("run", "--method", "nmpc", "--scenario", "periodic_box:n=4,rho=1.0", "--steps", "3",
                "--out", "/tmp/nmpc-bad-test", "--quiet", "--force")
    assert r.returncode == 2 and "Traceback" not in r.stderr


def test_non_finite_problem_is_a_failed_solve_not_a_nan():
    rng = np.random.default_rng(1)
    pb = _random_problem(rng)
    bad = S.Problem(pb.p0 * np.nan, *[getattr(pb, f) for f in S.Problem.__slots__[1:]])
    res = S.solve(bad, S.Weights(1, 1, 5, 5, 0.4, 1.2, 0.01), np.zeros((8, 2)))
    assert res.U is None and res.status == "non-finite input"


@pytest.mark.parametrize("D", [2, 3])
def test_primal_dual_warm_start_reaches_the_cold_solution(D):
    """The fast path (multipliers of the previous solve, shifted, as IPOPT's warm start) solves the
    next problem to the same optimum as a cold primal start, and its point meets every constraint
    of the NumPy reference (reach guard included)."""
    rng = np.random.default_rng(40 + D)
    w = S.Weights(1.0, 1.0, 5.0, 5.0, 0.4, 1.2, 0.01, True)
    cold, fast = S.Options(100, 1e-8), S.Options(100, 1e-8, warm_dual=True)
    compared = 0
    for _ in range(6):
        pb = _random_problem(rng, D, v0_scale=0.3, feasible=True)
        first = S.solve(pb, w, np.zeros((8, D)), options=fast)
        if first.U is None:
            continue
        # the same problem one control step on: the robot flew the first control
        ps, vs = S.rollout(pb.p0, pb.v0, first.U[:1], pb.h)
        nxt = S.Problem(ps[0], vs[0], *[getattr(pb, f) for f in S.Problem.__slots__[2:]])
        U0 = np.concatenate([first.U[1:], first.U[-1:]])
        a = S.solve(nxt, w, U0, options=cold)
        b = S.solve(nxt, w, U0, options=fast, duals=S.shift_duals(first, 8, 3, D))
        if a.U is None or b.U is None:
            continue
        compared += 1
        assert b.cost == pytest.approx(a.cost, rel=1e-5, abs=1e-7)
        assert S.reference(nxt, w, b.U)[1].min() >= -1e-6
        assert S.reference(nxt, w, b.U)[0] == pytest.approx(b.cost, rel=1e-9)
    assert compared >= 3


def test_reach_guard_keeps_contact_away_whatever_the_neighbour_does():
    """The guard's invariant: a robot that solves with a neighbour's reach guard is, one control step
    later in the plant (semi-implicit Euler at dt, acceleration held), more than 2 body radii + 5 mm
    from that neighbour, whatever acceleration within a_max the neighbour holds meanwhile."""
    from swarmnav.dynamics import SaturatedDoubleIntegrator

    m = NmpcMethod(prediction_horizon=1.0)
    p, h, body = m.params, m.params.control_dt, 0.2
    plant = SaturatedDoubleIntegrator(p.v_max, p.a_max)
    w = m.weights
    rng = np.random.default_rng(7)
    H = m.H
    empty = (np.zeros((1, 2)), np.zeros((1, 2)), np.zeros((1, 2)), np.array([-1.0]), np.zeros(1))
    checked = 0
    for _ in range(40):
        # a squeezed pair: i heads at j (its goal is beyond j), j drifts towards i
        xi, xj = np.zeros(2), rng.uniform(0.55, 0.8) * np.array([1.0, 0.0]) + rng.normal(0, 0.05, 2)
        vi, vj = rng.uniform(0, 0.5) * np.array([1.0, 0.0]), rng.uniform(-0.3, 0.1) * np.array([1.0, 0.0])
        q = (xj + h * np.arange(1, H + 1)[:, None] * vj)[None]
        R = 2 * body + m.reach_extra
        pb = S.Problem(xi, vi, h, p.v_max, p.a_max, np.array([1.0, 0.0]), 0.9, q, np.zeros(1),
                       np.array([2 * body + 0.005]), *empty, (xj + h * vj)[None], np.array([R]))
        res = S.solve(pb, w, np.zeros((H, 2)), options=m.options)
        if res.U is None:
            continue
        checked += 1
        for ang in np.linspace(0, 2 * np.pi, 16, endpoint=False):  # the neighbour's acceleration: any direction
            aj = p.a_max * np.array([np.cos(ang), np.sin(ang)])
            x, v = np.array([xi, xj]), np.array([vi, vj])
            for _ in range(m.every):
                x, v = plant.step(x, v, np.array([res.U[0], aj]), p.dt)
            assert np.linalg.norm(x[0] - x[1]) >= 2 * body + 0.005 - 1e-4
    assert checked >= 20


def test_identical_flights_across_processes():
    """The same seed gives bit-identical positions in two fresh processes (no wall clock, no
    process-dependent state in the solver's warm starts)."""
    import hashlib
    import subprocess
    import sys

    code = ("import hashlib, swarmnav; from swarmnav.methods.nmpc import NmpcMethod; "
            "r = swarmnav.run(NmpcMethod(prediction_horizon=1.0), "
            "'random_forest:density=0.35,seed=1,length=12,r_min=1.0,r_max=2.0,min_passage=1.0', seed=2, steps=60); "
            "print(hashlib.sha256(r.positions.tobytes()).hexdigest())")
    out = [subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.strip()
           for _ in range(2)]
    assert out[0] == out[1] and len(out[0]) == 64


def test_guarded_fallback_brakes_when_safe_and_steers_clear_otherwise():
    """A failed solve's acceleration under the reach guard: the plain brake when its first step keeps
    every guard; otherwise an acceleration within a_max whose first step does, when one exists."""
    from swarmnav.methods.nmpc.method import guarded_fallback

    rng = np.random.default_rng(11)
    h, amax = 0.2, 1.5
    empty = (np.zeros((1, 2)), np.zeros((1, 2)), np.zeros((1, 2)), np.array([-1.0]), np.zeros(1))
    kinds = {"brake": 0, "steered": 0}
    for _ in range(400):
        p0, v0 = np.zeros(2), rng.normal(0, 0.4, 2)
        c = rng.uniform(-0.8, 0.8, (2, 2))
        R = np.array([0.44, 0.44])
        pb = S.Problem(p0, v0, h, 1.0, amax, np.array([1.0, 0.0]), 0.9, np.zeros((2, 3, 2)), np.zeros(2),
                       np.zeros(2), *empty, c, R)
        brake = _clip(-v0 / h, amax)
        u = guarded_fallback(pb, brake)
        assert np.linalg.norm(u) <= amax + 1e-12
        first = lambda a: p0 + h * v0 + 0.5 * h * h * a  # noqa: E731
        if np.all(np.linalg.norm(first(brake) - c, axis=1) >= R):
            np.testing.assert_array_equal(u, brake)
            kinds["brake"] += 1
        else:
            # is any acceleration safe? (a fine grid, finer than the filter's)
            a = np.linspace(0, 2 * np.pi, 720, endpoint=False)
            grid = np.concatenate([f * amax * np.stack([np.cos(a), np.sin(a)], 1) for f in (1.0, 2 / 3, 1 / 3)])
            safe = np.all(np.linalg.norm(first(grid)[:, None] - c[None], axis=2) >= R + 0.01, axis=1)
            if safe.any():
                assert np.all(np.linalg.norm(first(u) - c, axis=1) >= R)
                kinds["steered"] += 1
    assert kinds["brake"] >= 20 and kinds["steered"] >= 10


def _clip(a, bound):
    n = np.linalg.norm(a)
    return a if n <= bound else a * bound / n


def test_guarded_fallback_never_trades_an_obstacle_for_a_neighbours_worst_case():
    """When no acceleration keeps every guard, the fallback still keeps the obstacle clearances if
    some acceleration does: a neighbour's reach is a possible contact, an obstacle a sure one."""
    from swarmnav.methods.nmpc.method import guarded_fallback

    h = 0.2
    # a wall (half-space) 2 cm below the robot's reach, a neighbour right above it: no step keeps the
    # guard, and the step that comes closest to it (straight down at a_max, 3 cm) crosses the wall
    obs = (np.array([[0.0, -0.02]]), np.zeros((1, 2)), np.array([[0.0, 1.0]]), np.array([0.0]), np.zeros(1))
    pb = S.Problem(np.zeros(2), np.zeros(2), h, 1.0, 1.5, np.array([1.0, 0.0]), 0.9, np.zeros((1, 3, 2)),
                   np.zeros(1), np.zeros(1), *obs, np.array([[0.0, 0.3]]), np.array([0.44]))
    u = guarded_fallback(pb, np.zeros(2))
    p1 = 0.5 * h * h * u
    assert p1[1] >= -0.02 - 1e-12  # the wall kept
    assert np.linalg.norm(p1 - [0.0, 0.3]) > 0.31  # and away from the neighbour as far as the wall lets it
