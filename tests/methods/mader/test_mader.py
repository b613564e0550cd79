"""MADER (``mader``): the optimisation's derivatives, the hulls, the contract's refusals, fallbacks
and counted communication. Short horizons: a replan costs NLopt ~0.1-1 s here."""

import numpy as np
import pytest

import swarmnav
from swarmnav.errors import ConfigError
from swarmnav.methods.base import Observation
from swarmnav.methods.mader import MaderMethod
from swarmnav.methods.mader import solver as S
from swarmnav.planning import clamped
from swarmnav.planning.hulls import obstacle_vertices, seed_planes
from swarmnav.planning.messages import trajectory_bytes
from swarmnav.world.obstacles import Box, Circle
from tests._helpers.cli import run_cli


def _problem(rng):
    start = np.array([[0.0, 0.0], [0.1, 0.0], [0.2, 0.0]])
    verts = np.stack([obstacle_vertices(Circle((2.0, 0.3), 0.5), 2, 0.3), obstacle_vertices(Circle((3.0, -1.0), 0.4), 2, 0.3)])
    return S.Problem(start, np.array([5.0, 0.0]), 1.5, 4, np.array([1, 2]), verts, 1000.0, 1.0, 1.5)


def test_jacobian_and_gradient_match_finite_differences():
    rng = np.random.default_rng(0)
    pr = S.Mader(_problem(rng))
    x = rng.standard_normal(pr.nvar)
    out, J = np.empty(pr.m), np.empty((pr.m, pr.nvar))
    pr.constraints(out, x, J)
    g = np.empty(pr.nvar)
    pr.cost(x, g)
    h = 1e-6
    for i in range(pr.nvar):
        e = np.zeros(pr.nvar)
        e[i] = h
        a, b = np.empty(pr.m), np.empty(pr.m)
        pr.constraints(a, x + e, np.zeros(0))
        pr.constraints(b, x - e, np.zeros(0))
        np.testing.assert_allclose(J[:, i], (a - b) / (2 * h), atol=1e-5)
        fd = (pr.cost(x + e, np.zeros(0)) - pr.cost(x - e, np.zeros(0))) / (2 * h)
        assert g[i] == pytest.approx(fd, rel=1e-5, abs=1e-4)


def test_solution_separates_segments_from_obstacles():
    pb = _problem(None)
    free0 = np.array([[2.5, 0.0], [5.0, 0.0]])
    C0 = np.vstack([pb.start, free0[:1], np.repeat(free0[1:], 3, axis=0)])
    cps = C0[np.array([1, 2])[:, None] + np.arange(4)]
    n0, d0, _ = seed_planes(cps, pb.verts)
    res = S.solve(pb, free0, n0, d0, 300, 1e-6, 1e-13, 1e-10)
    assert res.ctrl is not None and res.violation <= 1e-6
    # every returned control point of a constrained segment lies outside the obstacle's polygon side
    for s, v, r in zip(pb.seg, pb.verts, (0.5, 0.4)):  # inflated disc radii r + 0.3 (inside their polygons)
        seg = res.ctrl[s: s + 4]
        assert np.all(np.linalg.norm(seg - v.mean(axis=0), axis=1) > r + 0.3 - 1e-6)


def test_disc_polygon_contains_the_inflated_disc():
    v = obstacle_vertices(Circle((1.0, 2.0), 0.5), 2, 0.2)
    ang = np.linspace(0, 2 * np.pi, 100)
    pts = np.array([1.0, 2.0]) + 0.7 * np.stack([np.cos(ang), np.sin(ang)], axis=1)
    # inside the convex polygon: every point on the same side of all edges
    edges = np.roll(v, -1, axis=0) - v
    cross = edges[None, :, 0] * (pts[:, None, 1] - v[None, :, 1]) - edges[None, :, 1] * (pts[:, None, 0] - v[None, :, 0])
    assert np.all(cross >= -1e-9)
    box = obstacle_vertices(Box((0.0, 0.0), (1.0, 2.0)), 3, 0.1, (0.0, 3.0))
    assert box.shape == (8, 3) and box.min() == pytest.approx(-0.1) and box.max() == pytest.approx(3.1)


def test_periodic_box_refused():
    with pytest.raises(ConfigError):
        swarmnav.run("mader", "periodic_box:n=4,rho=1.0", seed=1, steps=5)
    r = run_cli("run", "--method", "mader", "--scenario", "periodic_box:n=4,rho=1.0", "--steps", "5",
                "--out", "/tmp/mader-periodic-test", "--quiet", "--force")
    assert r.returncode == 2 and "Traceback" not in r.stderr and len(r.stderr.strip().splitlines()) == 1


def test_out_of_range_parameter_refused():
    with pytest.raises(ConfigError):
        MaderMethod(num_pol=2)
    with pytest.raises(ConfigError):
        MaderMethod(replan_time=-1.0)
    with pytest.raises(ConfigError):
        MaderMethod(knots="open")


_NLOPT = {"algorithm": "LD_SLSQP", "preset": "paper"}  # box clearance, per-axis limits


@pytest.mark.parametrize("over, says", [(_NLOPT, "knots=uniform"),
                                        ({"algorithm": "LD_SLSQP"}, "limits=axis"),
                                        ({**_NLOPT, "knots": "uniform", "clearance": "ball"}, "clearance=box"),
                                        ({**_NLOPT, "knots": "uniform", "basis": "bezier"}, "algorithm=ipopt")])
def test_combinations_the_solver_cannot_do_are_refused_in_one_line(over, says):
    """The NLopt path is uniform knots and B-spline hulls only: other combinations are refused at
    the CLI with exit 2 and a line that says what is needed."""
    args = [a for k, v in over.items() for a in ("--set", f"{k}={v}")]
    r = run_cli("run", "--method", "mader", "--scenario", "random_forest:density=0.15,seed=1", "--steps", "3",
                *args, "--out", "/tmp/mader-combo-test", "--quiet", "--force")
    assert r.returncode == 2 and "Traceback" not in r.stderr and says in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1


def _fly(m, scene, steps, seed=3):
    rng = np.random.default_rng(seed)
    x = scene.spawn_positions(rng)
    v = np.zeros_like(x)
    m.reset(scene, x, v, rng)
    for k in range(steps):
        a, _ = m.act(Observation(k, k * m.dt, x, v), rng)
        x, v = m.dynamics.step(x, v, a, m.dt)
    return x, v


def test_infeasible_problems_are_counted_fallbacks_and_the_swarm_stays_finite():
    """Obstacles grown by 20 m (and known from 50 m) swallow every robot's start, so no plane separates segment 0 from
    them: every replan is a counted fallback, nothing is committed, the robots hold their hover
    plans and stay finite."""
    from swarmnav.world.generators import random_forest
    scene = random_forest(density=0.45, seed=1, length=12, r_min=1.0, r_max=2.0, min_passage=1.0)
    m = MaderMethod(inflation=20.0, sensing_range=50.0)
    x0 = scene.spawn_positions(np.random.default_rng(3))
    x, v = _fly(m, scene, 60)
    s = m.summary()
    assert s["mader_fallbacks"] == s["mader_plans"] > 0 and s["mader_commits"] == 0
    assert np.all(np.isfinite(x)) and np.all(np.isfinite(v))
    assert np.abs(x - x0).max() < 1e-9  # hover plans: nobody moved


def test_comm_counts_every_commit():
    from swarmnav.world.generators import random_forest
    scene = random_forest(density=0.15, seed=1, length=12, r_min=1.0, r_max=2.0, min_passage=1.0)
    m = MaderMethod()
    _fly(m, scene, 45)
    s = m.summary()
    n = scene.n
    assert s["comm_messages"] == n + s["mader_commits"]  # the initial hover plans, then each commit
    assert s["comm_bytes"] == s["comm_messages"] * trajectory_bytes(m.params.num_pol + 3)


@pytest.mark.parametrize("basis, knots", [("bspline", "uniform"), ("bezier", "uniform"), ("bspline", "clamped")])
def test_ipopt_solution_is_certified_by_its_planes(basis, knots):
    """IPOPT's answer: every segment's hull points (B-spline or Bezier) lie outside each inflated
    obstacle polygon, the velocity / acceleration control points within their bounds, and the same
    problem gives the same bits twice."""
    pb = _problem(None)
    free0 = np.array([[2.5, 0.0], [5.0, 0.0]])
    C0 = np.vstack([pb.start, free0[:1], np.repeat(free0[1:], 3, axis=0)])
    cps = C0[np.array([1, 2])[:, None] + np.arange(4)]
    n0, d0, _ = seed_planes(cps, pb.verts)
    if knots == "clamped":
        pb = S.Problem(clamped.boundary_points(pb.start[1], np.array([0.1, 0.0]), np.zeros(2), pb.dt_knot, 4),
                       pb.goal, pb.dt_knot, pb.num_pol, pb.seg, pb.verts, pb.weight, pb.v_max, pb.a_max)
    res = S.solve_ipopt(pb, free0, n0, d0, 200, 1e-6, basis, knots=knots)
    again = S.solve_ipopt(pb, free0, n0, d0, 200, 1e-6, basis, knots=knots)
    assert res.ctrl is not None and res.violation <= 1e-6
    np.testing.assert_array_equal(res.ctrl, again.ctrl)
    M = S.BEZIER if basis == "bezier" else np.eye(4)
    for s, v in zip(pb.seg, pb.verts):
        hull = M @ res.ctrl[s: s + 4]
        # no hull point inside the polygon: each is beyond at least one edge
        edges = np.roll(v, -1, axis=0) - v
        cross = edges[None, :, 0] * (hull[:, None, 1] - v[None, :, 1]) - edges[None, :, 1] * (hull[:, None, 0] - v[None, :, 0])
        assert np.all((cross < 0).any(axis=1))
    if knots == "clamped":
        Mv, Ma, _ = clamped.derivative_matrices(4)
        vel, acc = Mv @ res.ctrl / pb.dt_knot, Ma @ res.ctrl / pb.dt_knot**2
    else:
        vel = np.diff(res.ctrl, axis=0) / pb.dt_knot
        acc = np.diff(res.ctrl, n=2, axis=0) / pb.dt_knot**2
    assert np.abs(vel).max() <= pb.v_max * (1 + 1e-5) and np.abs(acc).max() <= pb.a_max * (1 + 1e-5)
    assert res.ctrl[-1, 0] > 2.0  # it makes progress towards the local goal (5, 0) between the two discs


def test_ipopt_infeasible_problem_returns_no_plan():
    """A start inside an obstacle cannot be separated from it: no plan (the method falls back)."""
    start = np.array([[2.0, 0.3], [2.0, 0.3], [2.0, 0.3]])
    verts = obstacle_vertices(Circle((2.0, 0.3), 0.5), 2, 0.3)[None]
    pb = S.Problem(start, np.array([5.0, 0.0]), 1.5, 4, np.array([0]), verts, 1000.0, 1.0, 1.5)
    free0 = np.array([[3.0, 0.3], [5.0, 0.0]])
    res = S.solve_ipopt(pb, free0, np.array([[1.0, 0.0]]), np.array([0.0]), 200, 1e-6)
    assert res.ctrl is None and res.violation > 1e-6


def test_ipopt_ball_clearance_keeps_the_euclidean_distance():
    """clearance=ball: the obstacle polygons are not grown; each plane's normal bound keeps every
    constrained segment's control points at least the plane's radius from the polygon (so from the
    disc it circumscribes), in Euclidean distance, and the plan still makes progress."""
    discs = [((2.0, 0.3), 0.5), ((3.0, -1.0), 0.4)]
    verts = np.stack([obstacle_vertices(Circle(c, r), 2, 0.0) for c, r in discs])
    start = np.array([[0.0, 0.0], [0.1, 0.0], [0.2, 0.0]])
    rad = np.array([0.3, 0.45])
    pb = S.Problem(start, np.array([5.0, 0.0]), 1.5, 4, np.array([1, 2]), verts, 1000.0, 1.0, 1.5, rad)
    free0 = np.array([[2.5, 0.0], [5.0, 0.0]])
    C0 = np.vstack([pb.start, free0[:1], np.repeat(free0[1:], 3, axis=0)])
    n0, d0, _ = seed_planes(C0[np.array([1, 2])[:, None] + np.arange(4)], pb.verts)
    res = S.solve_ipopt(pb, free0, n0, d0, 200, 1e-6)
    assert res.ctrl is not None and res.violation <= 1e-6
    for s, (c, r), rr in zip(pb.seg, discs, rad):
        seg = res.ctrl[s: s + 4]
        assert np.all(np.linalg.norm(seg - np.array(c), axis=1) >= r + rr - 1e-5)
    assert res.ctrl[-1, 0] > 2.0
    # the same problem without the radii lets the hull touch the bare polygon: the bound is what keeps the gap
    bare = S.solve_ipopt(S.Problem(*[getattr(pb, f) for f in ("start", "goal", "dt_knot", "num_pol", "seg", "verts",
                                                               "weight", "v_max", "a_max")]), free0, n0, d0, 200, 1e-6)
    gaps = [np.linalg.norm(bare.ctrl[s: s + 4] - np.array(c), axis=1).min() - r for s, (c, r) in zip(pb.seg, discs)]
    assert min(gaps) < 0.3


def test_ipopt_norm_limits_bound_the_derivative_control_points_in_norm():
    """limits=norm: every velocity and acceleration control point (so, by the hull property, the
    whole curve) within v_max and a_max in Euclidean norm, the dynamics' own bound; a diagonal
    local goal makes the per-axis build exceed it."""
    start = np.array([[0.0, 0.0], [0.0, 0.0], [0.0, 0.0]])
    out = {}
    for norm in (False, True):
        pb = S.Problem(start, np.array([4.0, 4.0]), 0.6, 4, np.zeros(0, dtype=np.int64), np.zeros((0, 1, 2)), 1000.0,
                       1.0, 1.5, None, norm)
        res = S.solve_ipopt(pb, np.array([[2.0, 2.0], [4.0, 4.0]]), np.zeros((0, 2)), np.zeros(0), 200, 1e-6)
        assert res.ctrl is not None
        out[norm] = (np.linalg.norm(np.diff(res.ctrl, axis=0) / 0.6, axis=1).max(),
                     np.linalg.norm(np.diff(res.ctrl, n=2, axis=0) / 0.36, axis=1).max())
    assert out[True][0] <= 1.0 + 1e-5 and out[True][1] <= 1.5 + 1e-5
    assert out[False][0] > 1.05 or out[False][1] > 1.55  # per axis: the diagonal exceeds the norm


def test_plans_hook_records_every_commit_from_point_a():
    """MADER's plans() (docs/methods/contract.md): one record per broadcast (the hover plans of
    the start and every commit), each starting at the point A the replan planned from: the
    committed trajectory at the commit step, which the robot tracks within centimetres."""
    res = swarmnav.run("mader", "random_forest:density=0.15,seed=1,length=12,r_min=1.0,r_max=2.0,min_passage=1.0",
                       seed=3, steps=150)
    pl, m = res.plans, res.metrics
    n = res.positions.shape[1]
    assert len(pl) == n + m["mader_commits"] and m["mader_commits"] > n
    assert sorted(pl.robot[pl.step == 0]) == list(range(n))
    gaps = []
    for j in range(len(pl)):
        pts, t = pl.trajectory(j)
        assert t[0] == pytest.approx(pl.step[j] * res.config["dt"], abs=1e-5)
        gaps.append(np.linalg.norm(pts[0] - res.positions[pl.step[j], pl.robot[j]]))
    assert np.median(gaps) < 0.005 and max(gaps) < 0.05, (np.median(gaps), max(gaps))  # measured: 0.1 mm, 1.4 mm
