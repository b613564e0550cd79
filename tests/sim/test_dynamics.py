"""Dynamics models: inverse model cancels drag; saturation bounds; periodic wrap."""

import numpy as np
import pytest

from swarmnav.dynamics import DampedDoubleIntegrator, Kinematic, SaturatedDoubleIntegrator, clip_norm


def test_inverse_model_gives_commanded_acceleration():
    rng = np.random.default_rng(0)
    p, v, a = rng.normal(size=(3, 50, 2))
    dyn = DampedDoubleIntegrator()
    p1, v1 = dyn.step(p, v, a, 0.1)
    np.testing.assert_allclose(v1, v + 0.1 * a)
    np.testing.assert_allclose(p1, p + 0.1 * v1)


def test_plain_damping_without_input_decays_velocity():
    dyn = DampedDoubleIntegrator()
    v = np.array([[2.0, 0.0]])
    u = np.zeros((1, 2))
    # with u = 0 the plant decays at rate c_d: v' = -c_d v
    v_next = v + 0.1 * (u / dyn.mass - dyn.drag * v)
    assert v_next[0, 0] == pytest.approx(2.0 * (1 - 0.05))


def test_saturated_integrator_bounds():
    rng = np.random.default_rng(1)
    p, v = rng.normal(size=(2, 100, 2))
    a = 100 * rng.normal(size=(100, 2))
    dyn = SaturatedDoubleIntegrator(v_max=1.0, a_max=1.5)
    _, v1 = dyn.step(p, clip_norm(v, 1.0), a, 0.2)
    assert np.linalg.norm(v1, axis=1).max() <= 1.0 + 1e-12
    dv = np.linalg.norm(v1 - clip_norm(v, 1.0), axis=1)
    assert dv.max() <= 1.5 * 0.2 + 1e-12


def test_kinematic_wraps_in_periodic_box():
    dyn = Kinematic(v_max=0.5, box=10.0)
    p1, v1 = dyn.step(np.array([[9.9, 0.1]]), np.zeros((1, 2)), np.array([[3.0, -4.0]]), 1.0)
    np.testing.assert_allclose(v1, [[0.3, -0.4]])
    np.testing.assert_allclose(p1, [[0.2, 9.7]])


def test_damped_step_matches_its_numpy_form_bit_for_bit():
    """The compiled step gives the bits of u = m (a + c v), v' = v + dt (u / m - c v), p' = p + dt v'."""
    rng = np.random.default_rng(7)
    for d in (2, 3):
        for _ in range(200):
            n = int(rng.integers(1, 40))
            p, v, a = (rng.normal(0, s, (n, d)) for s in (50.0, 3.0, 8.0))
            dt, m, c = float(rng.uniform(0.01, 0.2)), float(rng.uniform(0.5, 9.0)), float(rng.uniform(0.0, 2.0))
            dyn = DampedDoubleIntegrator(mass=m, drag=c)
            u = m * (a + c * v)
            v_ref = v + dt * (u / m - c * v)
            p_new, v_new = dyn.step(p, v, a, dt)
            assert np.array_equal(v_new, v_ref) and np.array_equal(p_new, p + dt * v_ref)
