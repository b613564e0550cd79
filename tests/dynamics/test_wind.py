"""The wind (swarmnav.dynamics.wind): mean wind, Dryden turbulence against its closed forms,
the exact discretisation, seeding and validation.

Statistical checks draw many independent vehicles (``coherence=0`` gives each its own process, so
the rows at one time are independent samples of the stationary process) and compare with the
closed form within 5 standard errors of the estimate: the variance estimate of n samples has
relative standard error sqrt(2 / n), a correlation estimate at most 1 / sqrt(n).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from swarmnav.dynamics.wind import W20, Wind, WindParams, intensities, scale_lengths, standard_gust, wind_params
from swarmnav.errors import ConfigError

N = 20_000  # independent vehicles of a statistical check
SE_VAR = math.sqrt(2.0 / N)  # relative standard error of a variance estimate
SE_COR = 1.0 / math.sqrt(N)  # bound on the standard error of a correlation estimate


def draws(params: WindParams, n: int, dt: float, steps: list[int], seed: int = 1) -> dict[int, np.ndarray]:
    """The air velocity (n, 3) at each of the (increasing) step indices ``steps``."""
    wind = Wind(params, n, dt, seed)
    pos = np.zeros((n, 3))
    return {k: wind.air(k * dt, pos) for k in steps}


def r_long(tau, T):
    """Dryden longitudinal autocorrelation coefficient, MIL-F-8785C."""
    return math.exp(-tau / T)


def r_lat(tau, T):
    """Dryden lateral / vertical autocorrelation coefficient, MIL-F-8785C."""
    return math.exp(-tau / T) * (1.0 - tau / (2.0 * T))


def test_scale_lengths_and_intensities_follow_the_standard():
    # at 1000 ft every scale length is 1000 ft and sigma_u = sigma_w (0.177 + 0.000823 * 1000 = 1)
    assert scale_lengths(304.8) == pytest.approx((304.8, 304.8, 304.8), rel=1e-12)
    assert intensities(2.0, 304.8) == pytest.approx((2.0, 2.0, 2.0), rel=1e-12)
    # at 10 m = 32.81 ft: L_w = h, L_u = L_v = h / 0.20400^1.2 = 221.0 ft
    h = 10.0 / 0.3048
    lu = h / (0.177 + 0.000823 * h) ** 1.2
    assert scale_lengths(10.0) == pytest.approx((lu * 0.3048, lu * 0.3048, 10.0), rel=1e-12)
    assert lu == pytest.approx(221.0, abs=0.1)
    # below 10 ft the standard's 10 ft values
    assert scale_lengths(1.0) == scale_lengths(3.048)
    # sigma_w = 0.1 W20: moderate (30 kt) at 1000 ft gives 1.543 m/s
    assert standard_gust(W20["moderate"], 304.8) == pytest.approx(0.1 * 30 * 0.514444, rel=1e-12)
    assert intensities(standard_gust(W20["severe"], 10.0), 10.0)[2] == pytest.approx(0.1 * W20["severe"], rel=1e-12)


@pytest.mark.parametrize("dt", [0.002, 0.05, 2.0])
def test_gust_variance_is_the_standard_at_any_step(dt):
    p = wind_params(speed=4.0, gust=1.5, altitude=10.0, coherence=0.0)
    sigma = np.array(intensities(1.5, 10.0))
    for k, air in draws(p, N, dt, [0, 7]).items():
        gust = air - np.array([4.0, 0.0, 0.0])  # the wind blows toward +x
        var = (gust**2).mean(axis=0)  # zero-mean process: the mean-square is the variance estimate
        np.testing.assert_allclose(var, sigma**2, rtol=5 * SE_VAR, err_msg=f"step {k}, dt {dt}")


@pytest.mark.parametrize("dt", [0.05, 0.5])
def test_autocorrelation_matches_dryden(dt):
    # wind toward +y: x is the lateral component (v), y the longitudinal (u), z the vertical (w)
    speed = 10.0
    p = wind_params(speed=speed, direction=90.0, gust=1.0, altitude=10.0, coherence=0.0)
    Lu, Lv, Lw = scale_lengths(10.0)
    Tu, Tv, Tw = Lu / speed, Lv / speed, Lw / speed
    sig = np.array(intensities(1.0, 10.0))
    mean = np.array([0.0, speed, 0.0])
    lags = sorted({round(Tw * f / dt) for f in (0.5, 1.0, 2.0)} | {round(Tu * f / dt) for f in (0.5, 1.0)})
    got = draws(p, N, dt, [0, *lags])
    g0 = (got[0] - mean) / sig
    for k in lags:
        tau = k * dt
        gk = (got[k] - mean) / sig
        rho = (g0 * gk).mean(axis=0)
        want = [r_lat(tau, Tv), r_long(tau, Tu), r_lat(tau, Tw)]
        np.testing.assert_allclose(rho, want, atol=5 * SE_COR, err_msg=f"lag {tau} s")
    # the lateral and longitudinal forms differ where it shows: at tau = 2 T_w the vertical
    # correlation is 0, the longitudinal form would give exp(-2) = 0.135
    k = round(2 * Tw / dt)
    rho_w = ((got[0] - mean)[:, 2] * (got[k] - mean)[:, 2]).mean() / sig[2] ** 2
    assert abs(rho_w) < 5 * SE_COR < r_long(k * dt, Tw)


def test_zero_gust_is_the_constant_mean_wind_exactly():
    p = wind_params(speed=6.0, direction=30.0)
    wind = Wind(p, 5, 0.1, seed=3)
    want = np.tile([6.0 * math.cos(math.radians(30.0)), 6.0 * math.sin(math.radians(30.0)), 0.0], (5, 1))
    for k in range(50):
        np.testing.assert_array_equal(wind.air(k * 0.1, np.zeros((5, 3))), want)
        np.testing.assert_array_equal(wind.gust(), np.zeros((5, 3)))


@given(speed=st.floats(0.0, 30.0), direction=st.floats(-360.0, 360.0), dt=st.floats(1e-3, 1.0),
       steps=st.lists(st.integers(0, 5), min_size=1, max_size=5))
@settings(max_examples=50, deadline=None)
def test_calm_air_turbulence_off_is_the_mean_at_any_times(speed, direction, dt, steps):
    wind = Wind(wind_params(speed=speed, direction=direction), 3, dt, seed=0)
    k = 0
    for s in steps:
        k += s
        air = wind.air(k * dt, np.zeros((3, 3)))
        assert np.all(air == air[0])
        assert air[0, 2] == 0.0
        assert math.hypot(air[0, 0], air[0, 1]) == pytest.approx(speed, rel=1e-12, abs=1e-12)
        if speed > 1e-6:  # blowing toward `direction`, counter-clockwise from +x
            np.testing.assert_allclose(air[0, :2] / speed, [math.cos(math.radians(direction)),
                                                            math.sin(math.radians(direction))], atol=1e-12)


def test_direction_is_where_the_wind_blows_toward():
    air = Wind(wind_params(speed=5.0, direction=90.0), 1, 0.1, 0).air(0.0, np.zeros((1, 3)))
    np.testing.assert_allclose(air, [[0.0, 5.0, 0.0]], atol=1e-12)
    air = Wind(wind_params(speed=5.0, direction=180.0), 1, 0.1, 0).air(0.0, np.zeros((1, 2)))
    np.testing.assert_allclose(air, [[-5.0, 0.0]], atol=1e-12)


def test_gusts_are_aligned_with_the_mean_wind():
    # along-wind variance sigma_u^2, across sigma_v^2, vertical sigma_w^2 < sigma_u^2: rotating the
    # wind by 90 deg moves the along-wind statistics from x to y (correlation shapes differ: lag test)
    for direction, along in ((0.0, 0), (90.0, 1)):
        p = wind_params(speed=10.0, direction=direction, gust=2.0, coherence=0.0)
        g = draws(p, N, 0.1, [0])[0] - np.array([10.0 * math.cos(math.radians(direction)),
                                                10.0 * math.sin(math.radians(direction)), 0.0])
        cov = g.T @ g / N
        assert abs(cov[0, 1]) < 5 * SE_COR * 4.0  # u and v independent
        assert cov[2, 2] == pytest.approx(intensities(2.0, 10.0)[2] ** 2, rel=5 * SE_VAR)
        assert cov[along, along] == pytest.approx(4.0, rel=5 * SE_VAR)


def test_same_seed_same_gusts_other_seed_differs():
    p = wind_params(speed=3.0, gust=1.0, coherence=0.3)
    a, b, c = (draws(p, 4, 0.02, list(range(0, 200, 10)), seed=s) for s in (7, 7, 8))
    for k in a:
        np.testing.assert_array_equal(a[k], b[k])
    assert all(np.abs(a[k] - c[k]).max() > 1e-3 for k in a)


def test_wind_draws_are_a_stream_of_their_own():
    # the gusts are the same whatever else draws from generators of the same seed in between, and
    # a generator of the run's seed gives the same numbers whether or not the wind drew
    p = wind_params(speed=3.0, gust=1.0)
    ref = draws(p, 3, 0.05, list(range(20)), seed=5)
    method = np.random.default_rng(5)
    before = method.standard_normal(20)
    wind, other = Wind(p, 3, 0.05, 5), Wind(p, 3, 0.05, 6)
    method = np.random.default_rng(5)
    for k in range(20):
        assert method.standard_normal() == before[k]
        other.air(k * 0.05, np.zeros((3, 3)))
        np.testing.assert_array_equal(wind.air(k * 0.05, np.zeros((3, 3))), ref[k])


def test_shared_gust_does_not_depend_on_swarm_size():
    p = wind_params(speed=2.0, gust=1.0, coherence=1.0)
    one, many = draws(p, 1, 0.05, list(range(30)), 9), draws(p, 40, 0.05, list(range(30)), 9)
    for k in one:
        np.testing.assert_array_equal(many[k], np.repeat(one[k], 40, axis=0))


@pytest.mark.parametrize("c", [0.0, 0.4, 1.0])
def test_coherence_is_the_gust_correlation_between_vehicles(c):
    # steps of 200 s against T_u = 67 m / 10 m/s: consecutive samples are independent
    p = wind_params(speed=10.0, gust=1.0, coherence=c)
    wind, pos, n = Wind(p, 2, 200.0, 2), np.zeros((2, 3)), 4000
    g = np.array([wind.air(k * 200.0, pos) for k in range(n)]) - np.array([10.0, 0.0, 0.0])
    rho = (g[:, 0, :] * g[:, 1, :]).mean(axis=0) / np.array(intensities(1.0, 10.0)) ** 2
    np.testing.assert_allclose(rho, c, atol=5 / math.sqrt(n) + 5 * math.sqrt(2 / n))
    var = (g[:, 0, :] ** 2).mean(axis=0)
    np.testing.assert_allclose(var, np.array(intensities(1.0, 10.0)) ** 2, rtol=5 * math.sqrt(2 / n))


def test_repeated_time_holds_the_gust_and_time_may_not_go_back():
    wind = Wind(wind_params(speed=1.0, gust=1.0), 2, 0.1, 0)
    pos = np.zeros((2, 3))
    a = wind.air(0.3, pos)
    np.testing.assert_array_equal(wind.air(0.3, pos), a)
    assert not np.array_equal(wind.air(0.4, pos), a)
    with pytest.raises(ValueError):
        wind.air(0.2, pos)


@pytest.mark.parametrize("values", [
    {"speed": -1.0}, {"speed": float("nan")}, {"speed": float("inf")}, {"gust": -0.1}, {"gust": 11.0},
    {"direction": 400.0}, {"altitude": 0.0}, {"altitude": 400.0}, {"coherence": 1.5}, {"v_min": 0.0},
    {"speed": "fast"}, {"sped": 3.0},
])
def test_bad_values_are_one_line_config_errors(values):
    with pytest.raises(ConfigError) as e:
        wind_params(**values)
    assert "\n" not in str(e.value) and str(e.value).startswith("wind")


def test_strings_from_the_command_line_are_coerced():
    assert wind_params(speed="6", direction="45", gust="1.5") == WindParams(speed=6.0, direction=45.0, gust=1.5)
    assert WindParams().calm and not wind_params(speed=0.1).calm
