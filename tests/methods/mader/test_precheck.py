"""MADER's infeasibility certificate (``precheck``): it fires only on problems IPOPT cannot solve,
its threshold is the clearance, and a closed-loop run is bit-identical with it on or off."""

import numpy as np
import pytest

import swarmnav
from swarmnav.errors import ConfigError
from swarmnav.methods.mader import MaderMethod
from swarmnav.methods.mader import solver as S
from swarmnav.planning import clamped
from swarmnav.planning.hulls import obstacle_vertices, pad, segment_points, seed_planes
from swarmnav.world.obstacles import Box, Circle

TOL, BOUND, R = 1e-6, 100.0, 0.3  # eps_tol, plane_bound [1/m], clearance [m]: the defaults


def _problem(q, v, obstacles, segs, dtk=0.8):
    """A 2-D clamped problem from state (q, v, 0), local goal 3 m along +x, ball clearance R."""
    start = clamped.boundary_points(np.asarray(q, float), np.asarray(v, float), np.zeros(2), dtk, 4)
    verts = pad([obstacle_vertices(o, 2, 0.0) for o in obstacles], 2, 4)
    pb = S.Problem(start, start[0] + np.array([3.0, 0.0]), dtk, 4, np.asarray(segs, np.int64), verts, 1000.0, 1.0,
                   1.5, np.full(len(segs), R), True)
    free0 = np.array([start[0] + [1.5, 0.0], start[0] + [3.0, 0.0]])
    C0 = np.vstack([start, free0[:1], np.repeat(free0[1:], 3, axis=0)])
    n0, d0, _ = seed_planes(segment_points(C0)[pb.seg], pb.verts)
    return pb, free0, n0, d0


def _solve(pb, free0, n0, d0, precheck):
    return S.solve_ipopt(pb, free0, n0, d0, 200, TOL, "bspline", 8.0, BOUND, "clamped", precheck=precheck)


@pytest.mark.parametrize("gap, proved", [(R - 0.01, True), (R + 0.01, False)])
def test_threshold_is_the_clearance(gap, proved):
    """A fixed start point ``gap`` from a box's face: certified infeasible just inside the clearance
    R (IPOPT agrees), not just outside it (where the problem is solvable)."""
    box = Box((gap, -1.0), (gap + 1.0, 1.0))  # its face at x = gap, the robot at the origin at rest
    pb, free0, n0, d0 = _problem([0.0, 0.0], [0.0, 0.0], [box], [0])
    assert S.infeasible_start(pb, TOL, BOUND) is proved
    res = _solve(pb, free0, n0, d0, precheck=False)
    assert (res.ctrl is None) is proved
    if proved:
        skipped = _solve(pb, free0, n0, d0, precheck=True)
        assert skipped.ctrl is None and skipped.evaluations == 0 and skipped.status == "infeasible-start"


def test_threshold_follows_the_cap_of_the_plane_normals():
    """Without a ball (box clearance: radius None) the bound on |n| is plane_bound sqrt(D), so only
    a point within 2 / (plane_bound sqrt 2) = 0.0141 m of (or inside) the hull is certified."""
    for gap, proved in ((0.013, True), (0.016, False), (-0.2, True)):
        box = Box((gap, -1.0), (gap + 1.0, 1.0))
        pb, *_ = _problem([0.0, 0.0], [0.0, 0.0], [box], [0])
        pb = S.Problem(pb.start, pb.goal, pb.dt_knot, 4, pb.seg, pb.verts, 1000.0, 1.0, 1.5, None, False)
        assert S.infeasible_start(pb, TOL, BOUND) is proved, gap


def test_certificate_never_contradicts_ipopt_on_random_problems():
    """Oracle: on random crowded starts (discs 0.1-0.8 m from the robot, on any segment) every
    problem the certificate proves infeasible is one IPOPT fails on; both outcomes occur."""
    rng = np.random.default_rng(7)
    proved = solved = 0
    for _ in range(24):
        k = int(rng.integers(1, 4))
        ang = rng.uniform(0, 2 * np.pi, k)
        r_o = rng.uniform(0.2, 0.6, k)
        dist = r_o + rng.uniform(0.1, 0.8, k)
        discs = [Circle((d * np.cos(a), d * np.sin(a)), ro) for d, a, ro in zip(dist, ang, r_o)]
        pb, free0, n0, d0 = _problem([0.0, 0.0], rng.uniform(-0.5, 0.5, 2), discs, rng.integers(0, 4, k))
        cert = S.infeasible_start(pb, TOL, BOUND)
        res = _solve(pb, free0, n0, d0, precheck=False)
        if cert:
            assert res.ctrl is None
        proved += cert
        solved += res.ctrl is not None
    assert proved > 0 and solved > 0


def test_closed_loop_is_bit_identical_with_and_without_the_precheck():
    """The certificate only skips solves that would fail: same positions, same commits and
    fallbacks, fewer IPOPT iterations (1.5 s of training forest 1 at d_obs 0.35)."""
    scene = "random_forest:density=0.35,seed=1,length=12,r_min=1.0,r_max=2.0,min_passage=1.0"
    on = swarmnav.run(MaderMethod(precheck=True), scene, seed=1, steps=150)
    off = swarmnav.run(MaderMethod(precheck=False), scene, seed=1, steps=150)
    np.testing.assert_array_equal(on.positions, off.positions)
    for key in ("mader_plans", "mader_commits", "mader_fallbacks"):
        assert on.metrics[key] == off.metrics[key]
    assert on.metrics["mader_infeasible_starts"] > 0 == off.metrics["mader_infeasible_starts"]
    assert on.metrics["mader_evals_mean"] < off.metrics["mader_evals_mean"]


def test_precheck_takes_a_boolean_only():
    with pytest.raises(ConfigError):
        MaderMethod(precheck="sometimes")
