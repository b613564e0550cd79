"""B-spline planning of Section III-B: eq. (12) boundary conditions, analytic cost gradients,
the compiled cost against the numpy one, and the optimiser against SciPy's L-BFGS-B."""

import numpy as np
import pytest
from scipy.optimize import minimize

from swarmnav.planning.bspline import (
    SplineCosts, _cost_grad, boundary_matrix, boundary_points, evaluate, optimize, total_cost,
)
from swarmnav.world import Circle, Geometry
from swarmnav.sensing.esdf import Esdf

W = SplineCosts(lambda_s=5.0, lambda_c=1000.0, lambda_f=1.0, d_thr=0.5, v_max=1.0, a_max=1.5)
DT = 0.5


@pytest.fixture(scope="module")
def esdf():
    return Esdf.build(Geometry.from_obstacles([Circle((3.0, 0.2), 1.0)]), (-2.0, -4.0, 8.0, 4.0), 0.1)


def test_boundary_points_invert_eq_12_and_evaluate_reproduces_the_state():
    q, v, a = np.array([1.0, -2.0]), np.array([0.5, 0.3]), np.array([-0.4, 1.1])
    C = boundary_points(q, v, a, DT)
    np.testing.assert_allclose(boundary_matrix(DT) @ C, np.stack([q, v, a]), atol=1e-12)
    ctrl = np.vstack([C, [[3.0, 0.0], [4.0, 1.0], [5.0, 1.0]]])
    qs, vs, as_ = evaluate(ctrl, DT, np.array([0.0]))
    np.testing.assert_allclose([qs[0], vs[0], as_[0]], [q, v, a], atol=1e-12)


def test_evaluated_velocity_and_acceleration_are_derivatives():
    ctrl = np.random.default_rng(1).normal(size=(9, 2))
    t = np.linspace(0.1, 2.9, 40)
    e = 1e-6
    q1, v, a = evaluate(ctrl, DT, t)
    q2, v2, _ = evaluate(ctrl, DT, t + e)
    q0, v0, _ = evaluate(ctrl, DT, t - e)
    np.testing.assert_allclose((q2 - q0) / (2 * e), v, atol=1e-6)
    np.testing.assert_allclose((v2 - v0) / (2 * e), a, atol=1e-5)


def test_cost_gradient_matches_finite_differences(esdf):
    rng = np.random.default_rng(2)
    ctrl = np.column_stack([np.linspace(0, 6, 12), 0.3 * rng.normal(size=12)])  # crosses the disc
    ctrl[5] += [0.0, 0.4]
    _, g = total_cost(ctrl, 0.3, esdf.query, W)  # dt 0.3: the feasibility terms are active
    num = np.zeros_like(ctrl)
    e = 1e-6
    for k in range(ctrl.shape[0]):
        for d in range(2):
            cp, cm = ctrl.copy(), ctrl.copy()
            cp[k, d] += e
            cm[k, d] -= e
            num[k, d] = (total_cost(cp, 0.3, esdf.query, W)[0] - total_cost(cm, 0.3, esdf.query, W)[0]) / (2 * e)
    np.testing.assert_allclose(g, num, rtol=1e-4, atol=1e-3)


def test_compiled_cost_equals_numpy_cost(esdf):
    ctrl = np.column_stack([np.linspace(0, 6, 12), np.sin(np.arange(12.0))])
    f_np, g_np = total_cost(ctrl, 0.3, esdf.query, W)
    m = ctrl.shape[0] - 6
    G = np.empty_like(ctrl)
    f_nb = _cost_grad(ctrl, 0.3, W.lambda_s, W.lambda_c, W.lambda_f, W.d_thr, W.v_max, W.a_max,
                      np.ascontiguousarray(esdf.values), esdf.origin, esdf.resolution,
                      np.empty((m, 2)), np.empty(m), np.empty((m, 2)), G)
    assert f_nb == pytest.approx(f_np, rel=1e-12)
    np.testing.assert_allclose(G, g_np, rtol=1e-10, atol=1e-10)


def test_optimiser_reaches_scipy_minimum_and_clears_the_obstacle(esdf):
    """Oracle: SciPy's L-BFGS-B on the numpy cost; the tolerance (1 %) covers the different
    stopping rules (ours stops when no control point moves 0.1 mm)."""
    start = (np.array([0.0, 0.0]), np.array([1.0, 0.0]), np.zeros(2))
    end = (np.array([6.0, 0.0]), np.array([1.0, 0.0]), np.zeros(2))
    guide = np.column_stack([np.linspace(0.5, 5.5, 11), np.zeros(11)])  # straight through the disc
    plan = optimize(start, end, guide, DT, esdf, W, max_iter=500)
    head, tail = boundary_points(*start, DT), boundary_points(*end, DT)

    def fun(x):
        c = np.vstack([head, x.reshape(-1, 2), tail])
        f, g = total_cost(c, DT, esdf.query, W)
        return f, g[3:-3].ravel()

    ref = minimize(fun, guide.ravel(), jac=True, method="L-BFGS-B", options={"maxiter": 2000})
    f_ours = fun(plan.ctrl[3:-3].ravel())[0]
    assert f_ours == pytest.approx(ref.fun, rel=0.01)
    d, _ = esdf.query(plan.ctrl[3:-3])
    assert d.min() > 0.3  # pushed out of the disc towards d_thr = 0.5 m
    np.testing.assert_allclose(plan.ctrl[:3], head)  # boundary control points untouched
    np.testing.assert_allclose(plan.ctrl[-3:], tail)


# ----------------------------------------------------------------------------- 3-D

BALL_C, BALL_R = np.array([3.0, 0.2, 1.1]), 1.0


@pytest.fixture(scope="module")
def esdf3():
    """The exact signed distance of a ball sampled on a 0.1 m grid (nodes ``values[iz, iy, ix]`` at
    ``origin + 0.1 (ix, iy, iz)``), so the test does not depend on how the field is built."""
    origin, res = np.array([-2.0, -3.0, -2.0]), 0.1
    ax = [o + res * np.arange(n) for o, n in zip(origin, (101, 61, 61))]
    z, y, x = np.meshgrid(ax[2], ax[1], ax[0], indexing="ij")
    values = np.sqrt((x - BALL_C[0]) ** 2 + (y - BALL_C[1]) ** 2 + (z - BALL_C[2]) ** 2) - BALL_R
    return Esdf(origin=origin, resolution=res, values=values)


def _compiled(ctrl, dt, esdf):
    m = ctrl.shape[0] - 6
    G = np.empty_like(ctrl)
    f = _cost_grad(ctrl, dt, W.lambda_s, W.lambda_c, W.lambda_f, W.d_thr, W.v_max, W.a_max,
                   np.ascontiguousarray(esdf.values), esdf.origin, esdf.resolution,
                   np.empty((m, 3)), np.empty(m), np.empty((m, 3)), G)
    return f, G


def test_3d_cost_gradient_matches_finite_differences(esdf3):
    """Eq. (8) in d = 3 (smoothness, trilinear ESDF collision, per-axis feasibility): the analytic
    gradient against central differences of the cost (step 1e-6 m; the tolerance covers the
    kinks of the trilinear field at cell faces, which no sampled point sits on)."""
    rng = np.random.default_rng(3)
    ctrl = np.column_stack([np.linspace(0, 6, 12), 0.3 * rng.normal(size=12), 1.0 + 0.3 * rng.normal(size=12)])
    ctrl[5] += [0.0, 0.4, 0.2]
    f, g = _compiled(ctrl, 0.3, esdf3)  # dt 0.3: the feasibility terms are active
    num = np.zeros_like(ctrl)
    e = 1e-6
    for k in range(ctrl.shape[0]):
        for d in range(3):
            cp, cm = ctrl.copy(), ctrl.copy()
            cp[k, d] += e
            cm[k, d] -= e
            num[k, d] = (_compiled(cp, 0.3, esdf3)[0] - _compiled(cm, 0.3, esdf3)[0]) / (2 * e)
    assert np.abs(g[3:-3]).max() > 100.0  # the collision term is active (lambda_c = 1000)
    np.testing.assert_allclose(g, num, rtol=1e-4, atol=1e-3)
    # the 3-D cost restricted to z = const equals the planar cost of the same points' x, y
    flat = ctrl.copy()
    flat[:, 2] = 5.0  # far above the ball: no collision term
    f3, g3 = _compiled(flat, 0.3, esdf3)
    f2, g2 = total_cost(flat[:, :2], 0.3, lambda p: (np.full(len(p), np.inf), np.zeros_like(p)), W)
    assert f3 == pytest.approx(f2, rel=1e-12)
    np.testing.assert_allclose(g3[:, :2], g2, rtol=1e-10, atol=1e-10)


def test_3d_field_is_exact_at_nodes_and_points_away_from_the_ball(esdf3):
    m = 200
    rng = np.random.default_rng(4)
    idx = np.column_stack([rng.integers(0, n, m) for n in (101, 61, 61)])  # ix, iy, iz
    pts = esdf3.origin + esdf3.resolution * idx
    d, g = esdf3.query(pts)
    np.testing.assert_allclose(d, np.linalg.norm(pts - BALL_C, axis=1) - BALL_R, atol=1e-12)
    off = pts + 0.05  # cell centres: the gradient is the SDF's unit normal within the grid error
    d, g = esdf3.query(off)
    normal = (off - BALL_C) / np.linalg.norm(off - BALL_C, axis=1)[:, None]
    far = np.linalg.norm(off - BALL_C, axis=1) > 0.3  # away from the centre, where the SDF has a kink
    assert np.einsum("md,md->m", g[far], normal[far]).min() > 0.98


def test_3d_optimiser_lifts_the_path_out_of_the_ball(esdf3):
    start = (np.array([0.0, 0.0, 1.0]), np.array([1.0, 0.0, 0.0]), np.zeros(3))
    end = (np.array([6.0, 0.0, 1.0]), np.array([1.0, 0.0, 0.0]), np.zeros(3))
    guide = np.column_stack([np.linspace(0.5, 5.5, 11), np.zeros(11), np.ones(11)])  # through the ball
    plan = optimize(start, end, guide, DT, esdf3, W, max_iter=500)
    d = np.linalg.norm(plan.ctrl[3:-3] - BALL_C, axis=1) - BALL_R
    assert d.min() > 0.3  # pushed out towards d_thr = 0.5 m
    np.testing.assert_allclose(plan.ctrl[:3], boundary_points(*start, DT))
    np.testing.assert_allclose(plan.ctrl[-3:], boundary_points(*end, DT))
    q, _, _ = evaluate(plan.ctrl, DT, np.linspace(0.0, plan.duration, 400))
    assert (np.linalg.norm(q - BALL_C, axis=1) - BALL_R).min() > 0.0  # the flown curve misses the ball


def test_3d_compiled_cost_equals_numpy_cost(esdf3):
    ctrl = np.column_stack([np.linspace(0, 6, 12), np.sin(np.arange(12.0)), 1.0 + np.cos(np.arange(12.0))])
    f_np, g_np = total_cost(ctrl, 0.3, esdf3.query, W)
    f_nb, g_nb = _compiled(ctrl, 0.3, esdf3)
    assert f_nb == pytest.approx(f_np, rel=1e-12)
    np.testing.assert_allclose(g_nb, g_np, rtol=1e-10, atol=1e-10)
