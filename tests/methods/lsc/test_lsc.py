"""LSC (``lsc``): the Bernstein matrices against plain polynomial evaluation, the QP's solution
against every constraint, the linear safe corridor's guarantee in a closed loop, counted
fallbacks, counted communication, and the contract's refusals."""

import math

import numpy as np
import pytest

import swarmnav
from swarmnav.errors import ConfigError
from swarmnav.methods.base import Observation
from swarmnav.methods.lsc import LscMethod
from swarmnav.methods.lsc import solver as S
from swarmnav.methods.lsc.method import shift
from swarmnav.planning.messages import trajectory_bytes
from tests._helpers.cli import run_cli

FOREST = "random_forest:density=0.15,seed=1,length=12,r_min=1.0,r_max=2.0,min_passage=1.0"


def _plain(ctrl, h, t):
    """Position of a piecewise Bernstein plan at time t, summed term by term (the reference)."""
    M, n1, D = ctrl.shape
    n = n1 - 1
    m = min(int(t // h), M - 1)
    s = t / h - m
    return sum(math.comb(n, k) * s**k * (1 - s) ** (n - k) * ctrl[m, k] for k in range(n1))


def _poly(ctrl, h, m):
    """Segment m as a power-basis polynomial in t - m h (one per axis), fitted through n + 1 plain
    evaluations: exact, since the segment is a polynomial of degree n."""
    n = ctrl.shape[1] - 1
    t = m * h + h * np.linspace(0.0, 1.0, n + 1)
    vals = np.array([_plain(ctrl[m:m + 1], h, ti - m * h) for ti in t])
    return [np.polynomial.Polynomial.fit(t - m * h, vals[:, d], n, domain=[0, h], window=[0, h])
            for d in range(ctrl.shape[2])]


def _fd(ctrl, h, t, order):
    """The order-th derivative at time t from the fitted polynomial of its segment."""
    m = min(int(t // h), ctrl.shape[0] - 1)
    return np.array([p.deriv(order)(t - m * h) if order else p(t - m * h) for p in _poly(ctrl, h, m)])


def _problem(D=2, limits="axis", seg=(), nrm=None, rhs=None, goal=None, boxes=None, v0=None):
    M, n, h = 5, 5, 0.2
    box = np.array([[-5.0] * D, [5.0] * D])
    return S.Problem(M, n, h, np.zeros(D), np.zeros(D) if v0 is None else v0, np.zeros(D),
                     np.array([6.0, 2.0, 1.0][:D]) if goal is None else goal,
                     np.tile(box[None], (M, 1, 1)) if boxes is None else boxes, np.array(seg, dtype=np.int64),
                     np.zeros((0, D)) if nrm is None else nrm, np.zeros((0, n + 1)) if rhs is None else rhs,
                     1.0, 1.5, limits)


def test_evaluate_matches_the_plain_polynomial_and_its_derivatives():
    rng = np.random.default_rng(0)
    ctrl = rng.standard_normal((3, 6, 2))
    h = 0.3
    for t in (0.05, 0.31, 0.62, 0.85):
        for order in (0, 1, 2):
            got = S.evaluate(ctrl, h, np.array([t]), order)[0]
            np.testing.assert_allclose(got, _fd(ctrl, h, t, order), rtol=1e-8, atol=1e-8)


def test_constraint_rows_are_the_polynomial_at_its_boundaries():
    """assemble(): the initial-state rows give p, v, a at t = 0; each continuity row gives the jump
    of that derivative between two segments (plain evaluation on either side); the rest rows give
    v and a at the end; the velocity rows (per axis) bound the sampled velocity (hull property)."""
    rng = np.random.default_rng(1)
    pb = _problem()
    P, q, A, l, u, kinds = S.assemble(pb)
    x = rng.standard_normal(pb.nvar)
    ctrl = x.reshape(pb.M, pb.n + 1, pb.dim)
    Ax = A @ x
    h, D = pb.h, pb.dim
    init = Ax[kinds == 0].reshape(3, D)
    for r in range(3):
        np.testing.assert_allclose(init[r], _fd(ctrl, h, 0.0, r), rtol=1e-8, atol=1e-8)
        np.testing.assert_allclose(init[r], S.evaluate(ctrl, h, np.zeros(1), r)[0], rtol=1e-12, atol=1e-9)
    cont = Ax[kinds == 1].reshape(pb.M - 1, pb.continuity + 1, D)
    for m in range(pb.M - 1):
        t = (m + 1) * h
        for r in range(pb.continuity + 1):
            left = S.derivative_basis(pb.n, r, np.array([1.0]), h)[0] @ ctrl[m]
            right = S.derivative_basis(pb.n, r, np.array([0.0]), h)[0] @ ctrl[m + 1]
            np.testing.assert_allclose(cont[m, r], left - right, atol=1e-9)
            if r == 0:
                np.testing.assert_allclose(left, _plain(ctrl[m:m + 1], h, h), atol=1e-12)
                np.testing.assert_allclose(right, _plain(ctrl, h, t + 1e-12), atol=1e-9)
    rest = Ax[kinds == 2].reshape(2, D)
    np.testing.assert_allclose(rest[0], _fd(ctrl, h, pb.M * h - 1e-12, 1), rtol=1e-8, atol=1e-8)
    np.testing.assert_allclose(rest[1], _fd(ctrl, h, pb.M * h - 1e-12, 2), rtol=1e-8, atol=1e-6)
    vel_rows = Ax[kinds == 4]
    tt = np.linspace(0, pb.M * h - 1e-9, 400)
    v = S.evaluate(ctrl, h, tt, 1)
    assert np.abs(v).max() <= np.abs(vel_rows).max() + 1e-9
    # the cost: x^T P x / 2 + q^T x is w_jerk * integral |jerk|^2 + w_goal |end - g|^2 - w_goal |g|^2
    integral = 0.0
    for m in range(pb.M):
        for p in _poly(ctrl, h, m):
            sq = p.deriv(3) ** 2
            integral += sq.integ()(h) - sq.integ()(0.0)
    Pd = P.toarray()
    Pd = Pd + np.triu(Pd, 1).T
    cost = 0.5 * x @ Pd @ x + q @ x + pb.w_goal * pb.goal @ pb.goal
    expect = pb.w_jerk * integral + pb.w_goal * np.sum((ctrl[-1, -1] - pb.goal) ** 2)
    assert cost == pytest.approx(expect, rel=1e-8)


@pytest.mark.parametrize("D, limits", [(2, "axis"), (2, "norm"), (3, "axis"), (3, "norm")])
def test_solution_satisfies_every_constraint_at_sampled_times(D, limits):
    """One plane (a time-varying half-space through the segments 1-4) and a box per segment:
    the solution, sampled every 2 ms, keeps the initial state, rests at the end, stays in each
    segment's box and on its side of each plane, and within the speed and acceleration bounds
    (per axis, or in norm)."""
    M, n = 5, 5
    boxes = np.tile(np.array([[-0.5] * D, [3.0] * D])[None], (M, 1, 1))
    boxes[:, 0, 0] = -0.2
    nrm = np.zeros((4, D))
    nrm[:, 0], nrm[:, 1] = 0.6, 0.8
    rhs = np.tile(np.linspace(0.1, 0.6, n + 1)[None], (4, 1))
    v0 = np.zeros(D)
    v0[0] = 0.5
    pb = _problem(D, limits, seg=(1, 2, 3, 4), nrm=nrm, rhs=rhs, boxes=boxes, v0=v0)
    res = S.solve(pb, tol=1e-4)
    assert res.ctrl is not None, res.status
    c, h = res.ctrl, pb.h
    t = np.arange(0.0, M * h + 1e-9, 0.002)
    p, v, a = (S.evaluate(c, h, t, r) for r in range(3))
    np.testing.assert_allclose(p[0], pb.q0, atol=1e-6)
    np.testing.assert_allclose(v[0], pb.v0, atol=1e-5)
    np.testing.assert_allclose(v[-1], 0.0, atol=1e-5)
    np.testing.assert_allclose(a[-1], 0.0, atol=1e-4)
    seg = np.minimum((t / h).astype(int), M - 1)
    assert np.all(p >= boxes[seg, 0] - 1e-4) and np.all(p <= boxes[seg, 1] + 1e-4)
    s = t / h - seg
    for j, m in enumerate((1, 2, 3, 4)):
        on = seg == m
        bound = S.bernstein(n, s[on]) @ rhs[j]  # the plane's offset at each time
        assert np.all(p[on] @ nrm[j] <= bound + 1e-4)
    if limits == "axis":
        assert np.abs(v).max() <= 1.0 + 1e-4 and np.abs(a).max() <= 1.5 + 1e-4
    else:
        assert np.linalg.norm(v, axis=1).max() <= 1.0 + 1e-4 and np.linalg.norm(a, axis=1).max() <= 1.5 + 1e-4
    assert p[-1, 0] > 0.3  # it moved towards the goal (6, 2, ...), along the plane, not stayed put


def test_lsc_plane_separates_any_two_plans_that_keep_their_sides():
    """For random previous segments, both keep their sides (the previous plans are feasible) and
    any points on the two sides are 2 d apart along the normal."""
    rng = np.random.default_rng(2)
    for _ in range(50):
        D = int(rng.integers(2, 4))
        pi = rng.standard_normal((6, D)) * 0.3
        pj = pi + rng.standard_normal(D) * 2.0 + rng.standard_normal((6, D)) * 0.2
        nrm, rhs, gap = S.lsc_plane(pi, pj, 0.25, np.eye(D)[0])
        d = min(0.25, gap / 2)
        assert np.all(pi @ nrm <= rhs + 1e-9)
        mid = 0.5 * (pi + pj) @ nrm
        assert np.all(-(pj @ nrm) <= -mid - d + 1e-9)  # j's side
        # the normal is the direction of the relative hull's nearest point: no other unit vector does better
        other = rng.standard_normal((200, D))
        other /= np.linalg.norm(other, axis=1, keepdims=True)
        assert gap >= np.max(np.min((pj - pi) @ other.T, axis=0)) - 1e-6


def test_two_robots_swapping_head_on_stay_apart_in_closed_loop():
    """Two robots replan synchronously with each other's previous plans (perfect tracking), their
    goals swapped through each other: by the LSC guarantee they never come closer than 2 r at any
    sampled time, every QP is feasible, and they pass (a 0.1 m offset breaks the symmetry)."""
    r, h = 0.25, 0.2
    starts = np.array([[-2.0, 0.05], [2.0, -0.05]])
    goals = starts[::-1] * np.array([1.0, -1.0])
    prev = np.repeat(starts[:, None, None, :], 30, axis=1).reshape(2, 5, 6, 2)
    min_gap = np.inf
    for step in range(60):
        planes = []
        for m in range(5):
            nrm, rhs, _ = S.lsc_plane(prev[0, m], prev[1, m], r, np.array([1.0, 0.0]))
            mid = 0.5 * (prev[0, m] + prev[1, m]) @ nrm
            planes.append((m, nrm, rhs, -mid - (mid - rhs)))
        new = []
        for i in range(2):
            sign = 1 if i == 0 else -1
            pb = S.Problem(5, 5, h, prev[i, 0, 0], S.evaluate(prev[i], h, np.zeros(1), 1)[0],
                           S.evaluate(prev[i], h, np.zeros(1), 2)[0], goals[i],
                           np.tile(np.array([[-10.0, -10.0], [10.0, 10.0]])[None], (5, 1, 1)),
                           np.arange(5), np.array([sign * p[1] for p in planes]),
                           np.array([p[2] if i == 0 else p[3] for p in planes]), 1.0, 1.5, "norm")
            res = S.solve(pb, tol=1e-4)
            assert res.ctrl is not None, (step, res.status)
            new.append(res.ctrl)
        t = np.linspace(0, 1.0, 201)
        gap = np.linalg.norm(S.evaluate(new[0], h, t) - S.evaluate(new[1], h, t), axis=1).min()
        min_gap = min(min_gap, gap)
        prev = np.stack([shift(c, 1) for c in new])
    assert min_gap >= 2 * r - 2e-3, min_gap
    assert prev[0, 0, 0, 0] > 1.0 and prev[1, 0, 0, 0] < -1.0  # swapped past each other


def _fly(m, scene, steps, seed=3):
    rng = np.random.default_rng(seed)
    x = scene.spawn_positions(rng)
    v = np.zeros_like(x)
    m.reset(scene, x, v, rng)
    for k in range(steps):
        a, _ = m.act(Observation(k, k * m.dt, x, v), rng)
        x, v = m.dynamics.step(x, v, a, m.dt)
    return x, v


def test_failed_solves_are_counted_fallbacks_and_the_swarm_stays_finite():
    """Every QP made to fail: each replan is a counted fallback, nothing is committed, the robots
    hold their hover plans (no motion) and stay finite."""
    from swarmnav.world.generators import random_forest
    scene = random_forest(density=0.45, seed=1, length=12, r_min=1.0, r_max=2.0, min_passage=1.0)
    m = LscMethod()
    m._force_fail = True
    x0 = scene.spawn_positions(np.random.default_rng(3))
    x, v = _fly(m, scene, 60)
    s = m.summary()
    assert s["lsc_fallbacks"] == s["lsc_plans"] == 3 * scene.n and s["lsc_commits"] == 0
    assert np.all(np.isfinite(x)) and np.abs(x - x0).max() < 1e-9


def test_an_infeasible_qp_returns_no_plan():
    """A start outside its own SFC box: OSQP reports it infeasible, solve() returns no plan."""
    boxes = np.tile(np.array([[1.0, 1.0], [2.0, 2.0]])[None], (5, 1, 1))
    res = S.solve(_problem(boxes=boxes))
    assert res.ctrl is None and "infeasible" in res.status


@pytest.mark.parametrize("sfc", ["grown", "shifted"])
def test_comm_counts_every_commit_and_the_forest_run_keeps_apart(sfc):
    """Both corridor schemes keep the initial trajectory inside the boxes, so nearly every QP is
    feasible (measured: no fallback in 300 steps), and every commit is one broadcast."""
    from swarmnav.world.generators import random_forest
    scene = random_forest(density=0.15, seed=1, length=12, r_min=1.0, r_max=2.0, min_passage=1.0)
    m = LscMethod(sfc=sfc)
    _fly(m, scene, 300)
    s = m.summary()
    assert s["comm_messages"] == scene.n + s["lsc_commits"] and s["lsc_commits"] >= 10 * scene.n
    assert s["comm_bytes"] == s["comm_messages"] * trajectory_bytes(5 * 6)
    assert s["lsc_fallbacks"] <= 0.1 * s["lsc_plans"]


def test_plans_hook_and_run_metrics():
    """plans(): one record per broadcast, each starting where the robot is (it tracks its plan
    within centimetres); the run keeps the robots apart (the LSC radius is 0.25 m per robot)."""
    res = swarmnav.run("lsc", FOREST, seed=3, steps=300)
    pl, m = res.plans, res.metrics
    n = res.positions.shape[1]
    assert len(pl) == n + m["lsc_commits"]
    gaps = [np.linalg.norm(pl.trajectory(j)[0][0] - res.positions[pl.step[j], pl.robot[j]]) for j in range(len(pl))]
    assert np.median(gaps) < 0.01 and max(gaps) < 0.1, (np.median(gaps), max(gaps))
    assert m["min_inter_robot_distance"] >= 0.4 and m["crashes"] == 0
    assert set(res.timings) >= {"plan_ms_median", "plan_ms_p95"}


def test_bad_input_is_refused_in_one_line():
    with pytest.raises(ConfigError):
        LscMethod(segments=1)
    with pytest.raises(ConfigError):
        LscMethod(phi=5, degree=4)
    with pytest.raises(ConfigError):
        LscMethod(continuity=5, degree=5)
    with pytest.raises(ConfigError):
        LscMethod(limits="ball")
    r = run_cli("run", "--method", "lsc", "--scenario", FOREST, "--steps", "3", "--set", "segment_time=-1",
                "--out", "/tmp/lsc-bad-test", "--quiet", "--force")
    assert r.returncode == 2 and "Traceback" not in r.stderr and len(r.stderr.strip().splitlines()) == 1
    r = run_cli("run", "--method", "lsc", "--scenario", "periodic_box:n=4,rho=1.0", "--steps", "5",
                "--out", "/tmp/lsc-periodic-test", "--quiet", "--force")
    assert r.returncode == 2 and "Traceback" not in r.stderr and len(r.stderr.strip().splitlines()) == 1
