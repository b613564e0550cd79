"""Rotor downwash (swarmnav.dynamics.downwash): the analytic values of the model, its invariants,
momentum conservation, and the vectorised kernel against a plain double loop."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from scipy.integrate import quad

from swarmnav.dynamics.downwash import (DownwashParams, descent_time, downwash_air, downwash_params,
                                         induced_velocity)
from swarmnav.errors import ConfigError

R_ROT = 0.0231  # [m] Crazyflie 2.x rotor radius
T_HOVER = 0.027 * 9.81  # [N] a 27 g vehicle in hover
R_EQ = 2.0 * R_ROT  # equivalent disc of four rotors: sqrt(4) r
V_H = math.sqrt(T_HOVER / (2 * 1.225 * 4 * math.pi * R_ROT**2))  # momentum theory [m/s]


def below(depth: float, radial: float = 0.0, thrust: float = T_HOVER, **kw) -> float:
    """Vertical air velocity [m/s] at a vehicle ``depth`` below and ``radial`` beside one source."""
    pos = np.array([[0.3, -0.2, 2.0], [0.3 + radial, -0.2, 2.0 - depth]])
    return float(downwash_air(pos, np.array([thrust, T_HOVER]), R_ROT, **kw)[1, 2])


def centreline(z, vh, R, decay=5.8):
    """U_c(z) [m/s]: the smaller of the vortex-cylinder near wake and the round jet."""
    return min(vh * (1 + z / math.sqrt(z * z + R * R)), 2 * vh * decay * math.sqrt(2) * R / z)


def oracle(pos, thrust, r, n_rot=4, p=DownwashParams(), carry=None):
    """The model's equations pair by pair (module docstring of downwash), in plain Python; the
    carried wake's descent time by numerical quadrature of dz / U_c."""
    R = math.sqrt(n_rot) * r
    out = np.zeros_like(pos)
    for i in range(len(pos)):
        for j in range(len(pos)):
            z = pos[j][2] - pos[i][2]
            if i == j or z <= 0 or z > p.cutoff or thrust[j] <= 0:
                continue
            vh = math.sqrt(thrust[j] / (2 * p.rho * n_rot * math.pi * r * r))
            near = vh * (1 + z / math.sqrt(z * z + R * R))
            uc = centreline(z, vh, R, p.decay)
            half2 = 2 * math.log(2) * R * R * vh * near / (uc * uc)
            cx, cy = pos[j][0], pos[j][1]
            if carry is not None:
                tau = quad(lambda q: 1 / centreline(q, vh, R, p.decay), 0, z, points=[8.2325 * R], limit=200,
                           epsabs=0, epsrel=1e-12)[0]
                cx, cy = cx + carry[j][0] * tau, cy + carry[j][1] * tau
            rr = (pos[i][0] - cx) ** 2 + (pos[i][1] - cy) ** 2
            out[i][2] -= uc * math.exp(-math.log(2) * rr / half2)
    return out


def test_centreline_at_the_disc_is_the_momentum_theory_value():
    assert induced_velocity(T_HOVER, R_ROT) == pytest.approx(V_H, rel=1e-14)
    assert below(1e-9) == pytest.approx(-V_H, rel=1e-6)


def test_near_wake_accelerates_to_twice_the_disc_value_then_the_jet_decays():
    # vortex cylinder on the axis: v_h (1 + z / sqrt(z^2 + R^2)); at z = R: 1.7071 v_h
    assert below(R_EQ) == pytest.approx(-V_H * (1 + 1 / math.sqrt(2)), rel=1e-12)
    # far wake: the round jet, 2 v_h B D_j / z with D_j = sqrt(2) R, B = 5.8
    assert below(30 * R_EQ) == pytest.approx(-2 * V_H * 5.8 * math.sqrt(2) * R_EQ / (30 * R_EQ), rel=1e-12)
    depths = np.linspace(0.01, 30, 300) * R_EQ
    w = -np.array([below(z) for z in depths])
    peak = int(np.argmax(w))
    assert 8.0 * R_EQ < depths[peak] < 8.5 * R_EQ  # the two laws meet at 8.2 R
    assert np.all(np.diff(w[: peak + 1]) > 0) and np.all(np.diff(w[peak:]) < 0)
    assert w.max() < 2 * V_H


def test_nothing_level_with_or_above_a_source_nor_beyond_the_cutoff():
    assert below(0.0) == 0.0
    assert below(-0.5) == 0.0
    assert below(10.0) != 0.0 and below(10.0 + 1e-9) == 0.0  # the default cutoff, 10 m
    assert below(2.0, params=DownwashParams(cutoff=1.5)) == 0.0 and below(1.4, params=DownwashParams(cutoff=1.5)) < 0.0


def test_zero_thrust_is_no_downwash():
    pos = np.random.default_rng(1).uniform(0, 2, (30, 3))
    np.testing.assert_array_equal(downwash_air(pos, np.zeros(30), R_ROT), np.zeros((30, 3)))
    assert below(0.3, thrust=0.0) == 0.0


def test_wake_is_symmetric_about_the_axis_and_falls_off_across_it():
    depth, radial = 0.2, 0.05
    angles = np.linspace(0, 2 * np.pi, 12, endpoint=False)
    src = np.array([0.0, 0.0, 1.0])
    targets = np.column_stack([radial * np.cos(angles), radial * np.sin(angles), np.full(12, 1.0 - depth)])
    w = np.array([downwash_air(np.array([src, t]), np.array([T_HOVER, 0.0]), R_ROT)[1] for t in targets])
    np.testing.assert_allclose(w[:, 2], w[0, 2], rtol=1e-12)
    np.testing.assert_array_equal(w[:, :2], 0.0)
    profile = -np.array([below(depth, r) for r in np.linspace(0, 0.3, 20)])
    assert np.all(np.diff(profile) < 0)


@pytest.mark.parametrize("zeta", [1.0, 8.0, 20.0, 60.0])
def test_wake_carries_the_momentum_flux_of_momentum_theory(zeta):
    # integral of rho u^2 over the plane at depth z = rho A v_h U_near(z): T / 2 at the disc, T far
    # below; computed from the public kernel on a radial grid (trapezoid, 1e-4 relative)
    z = zeta * R_EQ
    r = np.linspace(0, 2.0 * z + 4 * R_EQ, 4001)
    u = -np.array([below(z, ri) for ri in r])
    flux = np.trapezoid(1.225 * u**2 * 2 * np.pi * r, r)
    u_near = V_H * (1 + zeta / math.sqrt(zeta**2 + 1))
    assert flux == pytest.approx(1.225 * 4 * math.pi * R_ROT**2 * V_H * u_near, rel=1e-4)
    if zeta >= 20:
        assert flux == pytest.approx(T_HOVER, rel=2e-3)


def test_wakes_of_a_stack_add_up_and_the_top_feels_nothing():
    pos = np.array([[0.0, 0.0, 3.0], [0.0, 0.0, 2.5], [0.0, 0.0, 2.0]])
    thrust = np.array([0.3, 0.4, 0.5])
    w = downwash_air(pos, thrust, R_ROT)
    assert w[0, 2] == 0.0
    one = lambda a, b: downwash_air(pos[[a, b]], thrust[[a, b]], R_ROT)[1, 2]  # noqa: E731
    assert w[1, 2] == pytest.approx(one(0, 1), rel=1e-14)
    assert w[2, 2] == pytest.approx(one(0, 2) + one(1, 2), rel=1e-14)


def test_vectorised_kernel_equals_the_double_loop():
    rng = np.random.default_rng(4)
    n = 60
    pos = np.column_stack([rng.uniform(0, 1.0, (n, 2)), rng.uniform(0, 3.0, n)])
    pos[5, 2] = pos[6, 2]  # a level pair
    thrust = rng.uniform(0.0, 0.6, n)
    thrust[3] = 0.0
    p = DownwashParams(cutoff=2.0)
    got = downwash_air(pos, thrust, R_ROT, 4, p)
    want = oracle(pos, thrust, R_ROT, 4, p)
    assert np.count_nonzero(want[:, 2]) > n / 2  # the check covers many washed vehicles
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-15)
    # a hexarotor of a 1 kg class, with its own disc
    np.testing.assert_allclose(downwash_air(pos, 10 * thrust, 0.12, 6), oracle(pos, 10 * thrust, 0.12, 6),
                               rtol=1e-12, atol=1e-15)


def test_carried_wake_lies_where_the_air_took_it():
    # descent time: the integral of dz / U_c, against quadrature of the kernel's own centreline
    for z in (0.02, 0.3, 1.0, 4.0):
        want = quad(lambda q: -1 / below(q), 0, z, points=[8.2325 * R_EQ], limit=200, epsrel=1e-12)[0]
        assert descent_time(z, V_H, R_ROT) == pytest.approx(want, rel=1e-8)
    # a 3 m/s wind toward +x: at 1 m below the wake's axis is 3 tau downwind, with the centreline value
    z, wind = 1.0, np.array([3.0, 0.0, 0.0])
    shift = 3.0 * descent_time(z, V_H, R_ROT)
    src = np.array([0.0, 0.0, 2.0])
    xs = np.linspace(0.0, 2 * shift, 201)
    w = np.array([downwash_air(np.array([src, [x, 0.0, 2.0 - z]]), np.array([T_HOVER, 0.0]), R_ROT,
                               carry=wind)[1, 2] for x in xs])
    assert xs[np.argmin(w)] == pytest.approx(shift, abs=xs[1])
    assert w.min() == pytest.approx(below(z), rel=1e-4)
    # zero relative air: the vertical wake, bit for bit
    pos = np.random.default_rng(2).uniform(0, 1, (20, 3))
    np.testing.assert_array_equal(downwash_air(pos, np.full(20, T_HOVER), R_ROT, carry=np.zeros(3)),
                                  downwash_air(pos, np.full(20, T_HOVER), R_ROT))


def test_carried_wake_equals_the_double_loop():
    rng = np.random.default_rng(8)
    n = 20
    pos = np.column_stack([rng.uniform(0, 1.0, (n, 2)), rng.uniform(0, 2.0, n)])
    thrust = rng.uniform(0.1, 0.6, n)
    carry = rng.normal(0, 1.0, (n, 3))
    got = downwash_air(pos, thrust, R_ROT, carry=carry)
    want = oracle(pos, thrust, R_ROT, carry=carry)
    assert np.count_nonzero(np.abs(want[:, 2]) > 1e-3) > 5
    np.testing.assert_allclose(got, want, rtol=1e-7, atol=1e-12)


coords = st.integers(-300, 300).map(lambda k: k / 100)  # [m], a 1 cm grid: level stays level when shifted


@given(pts=st.lists(st.tuples(coords, coords, coords), min_size=2, max_size=8),
       shift=st.tuples(coords, coords, coords), seed=st.integers(0, 2**32 - 1))
@settings(max_examples=60, deadline=None)
def test_translation_and_relabelling_change_nothing(pts, shift, seed):
    pos = np.array(pts)
    thrust = np.random.default_rng(seed).uniform(0.0, 1.0, len(pts))
    w = downwash_air(pos, thrust, R_ROT)
    assert np.all(np.isfinite(w)) and np.all(w[:, 2] <= 0) and np.all(w[:, :2] == 0)
    np.testing.assert_allclose(downwash_air(pos + np.array(shift), thrust, R_ROT), w, rtol=1e-6, atol=1e-9)
    perm = np.random.default_rng(seed).permutation(len(pts))
    np.testing.assert_allclose(downwash_air(pos[perm], thrust[perm], R_ROT), w[perm], rtol=1e-12, atol=1e-15)
    np.testing.assert_array_equal(w[pos[:, 2] == pos[:, 2].max(), 2], 0.0)  # the highest are washed by none


def test_planar_positions_have_no_downwash():
    np.testing.assert_array_equal(downwash_air(np.ones((4, 2)), np.ones(4), R_ROT), np.zeros((4, 2)))


@pytest.mark.parametrize("values", [{"rho": 0.0}, {"rho": float("nan")}, {"decay": -1.0}, {"cutoff": 0.0},
                                    {"cutof": 3.0}, {"rho": "thick"}])
def test_bad_constants_are_one_line_config_errors(values):
    with pytest.raises(ConfigError) as e:
        downwash_params(**values)
    assert "\n" not in str(e.value) and str(e.value).startswith("downwash")
