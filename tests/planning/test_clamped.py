"""Clamped uniform cubic B-splines (planning/clamped.py): the derivative control points against
SciPy's own derivative splines, the start state, the ends, and the hull property."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.interpolate import BSpline

from swarmnav.planning import clamped


@given(st.integers(3, 10), st.floats(0.05, 5.0), st.integers(0, 2**31 - 1))
@settings(max_examples=40, deadline=None)
def test_derivative_control_points_match_scipy(num_seg, dt, seed):
    C = np.random.default_rng(seed).standard_normal((num_seg + 3, 2))
    Mv, Ma, Mj = clamped.derivative_matrices(num_seg)
    spl = BSpline(clamped.knots(num_seg, dt), C, 3)
    np.testing.assert_allclose(spl.derivative(1).c[: len(Mv)], Mv @ C / dt, atol=1e-9 / dt)
    np.testing.assert_allclose(spl.derivative(2).c[: len(Ma)], Ma @ C / dt**2, atol=1e-9 / dt**2)
    mids = dt * (np.arange(num_seg) + 0.5)
    np.testing.assert_allclose(spl.derivative(3)(mids), Mj @ C / dt**3, atol=1e-8 / dt**3)


@given(st.integers(3, 10), st.floats(0.05, 5.0), st.integers(0, 2**31 - 1))
@settings(max_examples=40, deadline=None)
def test_boundary_points_give_the_start_state_and_stay_near_it(num_seg, dt, seed):
    rng = np.random.default_rng(seed)
    q, v, a = rng.standard_normal((3, 3))
    C = rng.standard_normal((num_seg + 3, 3))
    C[:3] = clamped.boundary_points(q, v, a, dt, num_seg)
    q0, v0, a0 = clamped.evaluate(C, dt, np.array([0.0]))
    np.testing.assert_allclose(q0[0], q, atol=1e-12)
    np.testing.assert_allclose(v0[0], v, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(a0[0], a, rtol=1e-9, atol=1e-9)
    assert np.array_equal(C[0], q)
    assert np.linalg.norm(C[1] - q) == pytest.approx(np.linalg.norm(v) * dt / 3, rel=1e-12)


def test_ends_are_held_at_rest_and_each_segment_stays_in_its_hull():
    rng = np.random.default_rng(4)
    C = rng.standard_normal((7, 2)) * 3
    C[-3:] = C[-1]
    dt = 0.8
    q, v, a = clamped.evaluate(C, dt, np.array([-1.0, 4 * dt, 4 * dt + 2.0]))
    np.testing.assert_allclose(q[0], C[0])
    np.testing.assert_allclose(q[1:], np.repeat(C[-1:], 2, axis=0), atol=1e-12)
    assert np.all(v[1:] == 0) and np.all(a[1:] == 0)
    for s in range(4):  # samples of segment s are convex combinations of C_s .. C_s+3
        tau = dt * (s + np.linspace(0.0, 1.0, 9))
        pts = clamped.evaluate(C, dt, tau)[0]
        hull = C[s: s + 4]
        # a point outside the hull is separated by some edge direction: check against each edge normal
        for i in range(4):
            for j in range(i + 1, 4):
                n = np.array([-(hull[j] - hull[i])[1], (hull[j] - hull[i])[0]])
                side = (hull - hull[i]) @ n
                if np.all(side >= -1e-12) or np.all(side <= 1e-12):  # a hull edge
                    sgn = 1.0 if np.all(side >= -1e-12) else -1.0
                    assert np.all(sgn * ((pts - hull[i]) @ n) >= -1e-9)
