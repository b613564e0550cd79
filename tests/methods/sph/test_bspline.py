"""B-spline planning of Section III-B: eq. (12) boundary conditions, analytic cost gradients,
the compiled cost against the numpy one, and the optimiser against SciPy's L-BFGS-B."""

import numpy as np
import pytest
from scipy.optimize import minimize

from swarmnav.methods.sph.bspline import (
    SplineCosts, _cost_grad, boundary_matrix, boundary_points, evaluate, optimize, total_cost,
)
from swarmnav.world import Circle, Geometry
from swarmnav.world.esdf import Esdf

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
                      np.ascontiguousarray(esdf.values), esdf.origin[0], esdf.origin[1], esdf.resolution,
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
