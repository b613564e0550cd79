"""The quadrotor kernel and its SE(3) controller: analytic cases, signs, batching, determinism,
bad input and flipped vehicles (the RotorPy comparison is in test_rotorpy_oracle.py)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from swarmnav.dynamics.airframes import AIRFRAMES, GRAVITY, airframe, check
from swarmnav.dynamics.quadrotor import Gains, QuadrotorFleet, default_gains
from swarmnav.errors import ConfigError


def still(n):
    return np.zeros((n, 3))


def test_hover_stays_put_and_costs_the_analytic_energy():
    af = airframe("crazyflie")
    f = QuadrotorFleet(af, 3)
    p = np.array([[0.0, 0.0, 1.0], [2.0, -1.0, 0.5], [5.0, 5.0, 3.0]])
    p0, v = p.copy(), still(3)
    f.reset(p, v)
    wh = np.full((3, 4), af.hover_speed)
    for _ in range(40):  # 2 s open loop at the hover speed
        p, v = f.fly_rotors(p, v, wh, 0.05)
    np.testing.assert_allclose(p, p0, atol=1e-12)
    np.testing.assert_allclose(v, 0.0, atol=1e-12)
    np.testing.assert_allclose(f.thrust, af.mass * GRAVITY, rtol=1e-12)
    np.testing.assert_allclose(f.attitude, np.broadcast_to(np.eye(3), (3, 3, 3)), atol=1e-15)
    # rotor power k_m w^3 per rotor, four rotors, 2 s
    np.testing.assert_allclose(f.energy_J, 4 * af.k_m * af.hover_speed**3 * 2.0, rtol=1e-12)
    assert (f.saturated_fraction == 0).all() and (f.tilt_max_deg < 1e-6).all()
    # closed loop, reference at the start point: the controller holds it too
    for _ in range(40):
        p, v = f.fly(p, v, p0, still(3), still(3), 0.05)
    np.testing.assert_allclose(p, p0, atol=1e-12)


@pytest.mark.parametrize("tau_m", [0.0, 0.05])
def test_free_fall_with_rotors_off_matches_the_analytic_motor_decay(tau_m):
    # x500 without body drag (it has no rotor drag): level, the thrust 4 k_eta w^2 decays as
    # m g exp(-2 t / tau) when the command drops to 0, so v_z = -g t + g tau (1 - exp(-2t/tau)) / 2.
    af = check(dataclasses.replace(AIRFRAMES["x500"], c_D=(0.0, 0.0, 0.0), tau_m=tau_m))
    f = QuadrotorFleet(af, 1)
    p, v = np.array([[0.0, 0.0, 50.0]]), np.array([[0.3, -0.2, 1.0]])
    f.reset(p, v)
    t = 0.0
    for _ in range(30):
        p, v = f.fly_rotors(p, v, np.zeros((1, 4)), 0.05)
        t += 0.05
    g = GRAVITY
    if tau_m == 0:
        vz, dz = 1.0 - g * t, 1.0 * t - g * t * t / 2
    else:
        e = math.exp(-2 * t / tau_m)
        vz = 1.0 - g * t + g * tau_m / 2 * (1 - e)
        dz = 1.0 * t - g * t * t / 2 + g * tau_m / 2 * (t - tau_m / 2 * (1 - e))
    # RK4 is exact for the polynomial fall (tau_m = 0); the exponential thrust decay leaves its
    # O(h^4) error, (2 h / tau_m)^4 g tau_m / 2 ~ 1e-6 m/s as a bound, ~3e-9 m/s measured.
    tol = 1e-12 if tau_m == 0 else 1e-7
    np.testing.assert_allclose(v[0], [0.3, -0.2, vz], rtol=0, atol=tol)
    np.testing.assert_allclose(p[0], [0.3 * t, -0.2 * t, 50.0 + dz], rtol=0, atol=tol)
    np.testing.assert_allclose(f.body_rates, 0.0, atol=1e-15)
    assert f.saturated_fraction[0] == 1.0  # every command at w_min = 0


def _rates_after(cmd_delta, t=0.02):
    """Body rates of a level Hummingbird after t [s] with rotor speeds hover + cmd_delta (no
    lag, and no rotor drag, which would damp the rates by ~1 % over t)."""
    af = check(dataclasses.replace(AIRFRAMES["hummingbird"], tau_m=0.0, k_d=0.0, k_z=0.0, k_h=0.0))
    f = QuadrotorFleet(af, 1)
    p, v = still(1), still(1)
    f.reset(p, v)
    w = af.hover_speed + np.asarray(cmd_delta, dtype=float)[None, :]
    f.fly_rotors(p, v, w, t)
    return af, w[0], f.body_rates[0]


def test_yaw_moment_sign_rotors_1_and_3_turn_the_body_positive_about_z():
    af, w, rates = _rates_after([20.0, -20.0, 20.0, -20.0])
    mz = af.k_m * (w[0] ** 2 - w[1] ** 2 + w[2] ** 2 - w[3] ** 2)
    assert mz > 0
    np.testing.assert_allclose(rates[2], mz / af.inertia[2] * 0.02, rtol=1e-6)
    np.testing.assert_allclose(rates[:2], 0.0, atol=1e-12)


def test_roll_and_pitch_step_signs():
    # left rotors (1, 4; +y) faster: positive moment about body x (left side up)
    af, w, rates = _rates_after([30.0, 0.0, 0.0, 30.0])
    d = af.arm_length / math.sqrt(2)
    mx = af.k_eta * d * (w[0] ** 2 - w[1] ** 2 - w[2] ** 2 + w[3] ** 2)
    assert rates[0] > 0 and abs(rates[1]) < 1e-9 * abs(rates[0])
    np.testing.assert_allclose(rates[0], mx / af.inertia[0] * 0.02, rtol=1e-3)
    # front rotors (1, 2; +x) faster: nose up, negative moment about body y
    _, _, rates = _rates_after([30.0, 30.0, 0.0, 0.0])
    assert rates[1] < 0 and abs(rates[0]) < 1e-9 * abs(rates[1])


@pytest.mark.parametrize("name", sorted(AIRFRAMES))
def test_controller_reaches_a_position_step(name):
    f = QuadrotorFleet(airframe(name), 1)
    p, v = still(1), still(1)
    f.reset(p, v)
    goal = np.array([[1.0, -0.5, 0.5]])
    for _ in range(80):  # 4 s
        p, v = f.fly(p, v, goal, still(1), still(1), 0.05)
    np.testing.assert_allclose(p, goal, atol=0.01)
    np.testing.assert_allclose(v, 0.0, atol=0.01)
    assert not f.flipped[0] and 5 < f.tilt_max_deg[0] < 60
    R = f.attitude[0]  # a rotation, level again with yaw 0 at rest
    np.testing.assert_allclose(R.T @ R, np.eye(3), atol=1e-12)
    np.testing.assert_allclose(R, np.eye(3), atol=1e-2)  # within ~0.6 deg
    np.testing.assert_allclose(f.thrust, f.airframe.mass * GRAVITY, rtol=1e-3)


def _scenario(n, rng):
    p = rng.uniform(-2, 2, (n, 3))
    return p, rng.uniform(-1, 1, (n, 3)), p + rng.uniform(-1, 1, (n, 3)), rng.uniform(-0.5, 0.5, (n, 3)), \
        rng.uniform(-1, 1, (n, 3)), rng.uniform(-3, 3, (n, 3))


def _fly(fleet, p, v, pr, vr, ar, air, steps=20):
    fleet.reset(p, v)
    for _ in range(steps):
        p, v = fleet.fly(p, v, pr, vr, ar, 0.05, air=air)
    return p, v


def test_batched_equals_one_by_one_and_is_deterministic():
    af = airframe("hummingbird")
    p, v, pr, vr, ar, air = _scenario(5, np.random.default_rng(3))
    fleet = QuadrotorFleet(af, 5)
    pb, vb = _fly(fleet, p, v, pr, vr, ar, air)
    for i in range(5):
        one = QuadrotorFleet(af, 1)
        pi, vi = _fly(one, *(a[i : i + 1] for a in (p, v, pr, vr, ar, air)))
        assert np.array_equal(pi[0], pb[i]) and np.array_equal(vi[0], vb[i])
        assert np.array_equal(one.quaternions[0], fleet.quaternions[i])
        assert np.array_equal(one.rotor_speeds[0], fleet.rotor_speeds[i])
        assert one.energy_J[0] == fleet.energy_J[i]
    again = QuadrotorFleet(af, 5)
    pa, va = _fly(again, p, v, pr, vr, ar, air)
    assert np.array_equal(pa, pb) and np.array_equal(va, vb)
    for prop in ("quaternions", "body_rates", "rotor_speeds", "energy_J", "tilt_max_deg", "saturated_fraction"):
        assert np.array_equal(getattr(again, prop), getattr(fleet, prop)), prop


def test_wind_is_felt_through_the_air_relative_drag():
    # hovering x500 (c_D = 0.01 N/(m/s)^2) in a 5 m/s wind along +x: the drag pushes it
    # downwind with |F| = c_D 25 N at the start, so a_x = 0.25 m/s^2 at first.
    af = airframe("x500")
    f = QuadrotorFleet(af, 1)
    p, v = still(1), still(1)
    f.reset(p, v)
    p, v = f.fly_rotors(p, v, np.full((1, 4), af.hover_speed), 0.002, air=np.array([[5.0, 0.0, 0.0]]))
    np.testing.assert_allclose(v[0, 0] / 0.002, 0.01 * 25 / af.mass, rtol=1e-3)
    # moving with the air is still air
    f.reset(p, v)
    _, v2 = f.fly_rotors(still(1), np.array([[5.0, 0, 0]]), np.full((1, 4), af.hover_speed), 0.1,
                         air=np.array([[5.0, 0.0, 0.0]]))
    np.testing.assert_allclose(v2, [[5.0, 0.0, 0.0]], atol=1e-12)


def test_bad_input_is_a_config_error():
    with pytest.raises(ConfigError, match="unknown airframe"):
        airframe("blimp")
    with pytest.raises(ConfigError, match="mass"):
        airframe("crazyflie", mass=-0.1)
    with pytest.raises(ConfigError, match="cannot hover"):
        airframe("x500", mass=2.5)
    base = AIRFRAMES["crazyflie"]
    with pytest.raises(ConfigError, match="tau_m"):
        check(dataclasses.replace(base, tau_m=-0.01))
    with pytest.raises(ConfigError, match="inertia"):
        check(dataclasses.replace(base, inertia=(1e-5, 0.0, 2e-5)))
    with pytest.raises(ConfigError, match="cannot hover"):
        QuadrotorFleet(dataclasses.replace(base, k_eta=1e-9), 2)
    f = QuadrotorFleet(base, 2, inner_hz=10.0)
    with pytest.raises(ConfigError, match="slower than the method's step"):
        f.fly(still(2), still(2), still(2), still(2), still(2), 0.05)
    with pytest.raises(ConfigError, match="dt"):
        f.fly(still(2), still(2), still(2), still(2), still(2), 0.0)
    with pytest.raises(ConfigError, match="gains"):
        QuadrotorFleet(base, 1, gains=Gains(kp_att=-1.0))
    assert str(airframe("crazyflie", mass=0.035).mass) == "0.035"
    heavy = airframe("crazyflie", mass=0.035)
    np.testing.assert_allclose(heavy.inertia[0] / base.inertia[0], 0.035 / 0.030)
    assert default_gains(heavy).kp_att == 310.0
    # substeps: an inner step never longer than 1 / inner_hz
    assert QuadrotorFleet(base, 1).substeps(0.05) == 25 and QuadrotorFleet(base, 1).substeps(0.003) == 2


def test_flipped_vehicles_are_flagged_frozen_and_finite():
    af = airframe("crazyflie")
    f = QuadrotorFleet(af, 3)
    p, v = still(3), still(3)
    f.reset(p, v)
    cmd = np.full((3, 4), af.hover_speed)
    cmd[0] = [af.rotor_speed_max, 0.0, 0.0, af.rotor_speed_max]  # full roll: tumbles
    for _ in range(20):
        p, v = f.fly_rotors(p, v, cmd, 0.05, air=np.array([[0, 0, 0], [0, 0, 0], [1e300, 0, 0]]))
    assert f.flipped.tolist() == [True, False, True]
    assert f.tilt_max_deg[0] > 90 and f.tilt_max_deg[1] < 1e-6
    for arr in (p, v, f.quaternions, f.body_rates, f.rotor_speeds, f.energy_J):
        assert np.isfinite(arr).all()
    # frozen: what is passed in comes back, attitude does not move; the others fly on
    q = f.quaternions
    p2, v2 = f.fly_rotors(p, v, cmd, 0.05)
    assert np.array_equal(p2[[0, 2]], p[[0, 2]]) and np.array_equal(v2[[0, 2]], v[[0, 2]])
    assert np.array_equal(f.quaternions[[0, 2]], q[[0, 2]])
    assert f.flipped.tolist() == [True, False, True]
    f.reset(p2, v2)
    assert not f.flipped.any()


def _steady_acceleration(name: str, drag_ff: bool) -> float:
    """Acceleration [m/s^2] a vehicle holds after 2 s of a 1 m/s^2 reference along x, the reference
    restarting from its state every 0.01 s (as the run's vehicle layer feeds it)."""
    af = airframe(name)
    f = QuadrotorFleet(af, 1, 500.0, dataclasses.replace(default_gains(af), drag_ff=drag_ff))
    p, v = np.zeros((1, 3)), np.zeros((1, 3))
    f.reset(p, v)
    speeds = []
    for _ in range(200):
        p, v = f.fly(p, v, p.copy(), v.copy(), np.array([[1.0, 0.0, 0.0]]), 0.01)
        speeds.append(v[0, 0])
    return (speeds[-1] - speeds[-2]) / 0.01


@pytest.mark.parametrize("name", ["crazyflie", "hummingbird"])
def test_drag_compensation_holds_the_commanded_acceleration(name):
    # without it the drag at ~1.5-2 m/s eats a third or more of the command (RotorPy's SE3Control)
    assert _steady_acceleration(name, False) < 0.7
    # with it the vehicle holds the command but for the lag of its rotors (the last 4 %)
    assert _steady_acceleration(name, True) == pytest.approx(1.0, abs=0.06)


def test_a_falling_vehicle_stops_on_the_floor_and_never_passes_it():
    af = airframe("crazyflie")
    p0, v0 = np.array([[0.0, 0.0, 1.0], [3.0, 0.0, 20.0]]), np.array([[0.5, 0.0, 0.0], [0.0, 0.0, 0.0]])
    floored, free = QuadrotorFleet(af, 2, floor=0.0), QuadrotorFleet(af, 2)
    off = np.zeros((2, 4))  # rotors off: both fall
    out = {}
    for name, f in (("floored", floored), ("free", free)):
        f.reset(p0, v0)
        p, v, zs = p0.copy(), v0.copy(), []
        for _ in range(20):  # 1 s: from 1 m a free fall lands after 0.45 s; from 20 m it is still falling
            p, v = f.fly_rotors(p, v, off, 0.05)
            zs.append(p[:, 2].copy())
        out[name] = (p, v, np.array(zs))
    p, v, zs = out["floored"]
    assert floored.grounded.tolist() == [True, False] and not floored.flipped.any()
    assert zs[:, 0].min() == 0.0 and p[0, 2] == 0.0 and np.array_equal(v[0], [0.0, 0.0, 0.0])  # on it, at rest
    assert np.isfinite(p).all() and p[0, 0] > 0.1  # it landed where its drift took it, not at its start
    # the one still in the air flies as it does without a floor, bit for bit
    assert np.array_equal(p[1], out["free"][0][1]) and np.array_equal(v[1], out["free"][1][1])
    assert out["free"][0][0, 2] < -2.0 and not free.grounded.any()  # without a floor: through z = 0
    floored.reset(p0, v0)
    assert not floored.grounded.any()
    with pytest.raises(ConfigError, match="floor"):
        QuadrotorFleet(af, 1, floor=float("nan"))
