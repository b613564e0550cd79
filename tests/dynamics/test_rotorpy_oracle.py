"""RotorPy as the oracle of the quadrotor kernel and its SE(3) controller.

RotorPy (Folk et al. 2023, arXiv 2306.04485; PyPI ``rotorpy`` 3.x, a test dependency only) is
run on the same airframe (our :class:`Airframe` mapped onto its parameter dictionary), the same
initial state and the same commands, and the two trajectories are compared over seconds of flight.

What is on and off in RotorPy: its full aerodynamic model is on (``aero=True``: parasitic drag,
rotor H-force drag with k_d and k_z, translational lift k_h, blade flapping k_flap), as ours
implements all four; ground contact is off (``enable_ground=False``; our vehicles have no
ground) and motor noise is zero (``motor_noise_std = 0``). RotorPy integrates with SciPy's
``solve_ivp``; it is run here with DOP853 at rtol 1e-10 / atol 1e-12, so that its own error is
negligible and the comparison measures ours.

Tolerances. Both sides hold the rotor command over each 2 ms step and solve the same ODE, so
what differs is our integration error: the motor lag is solved exactly, the rigid body by RK4 at
h = 2 ms. RK4's error is largest where the rotor speeds move fast against the step, i.e. for
the Hummingbird's 5 ms motor (h / tau_m = 0.4): its quadrature of the exponential rotor
transient is off by ~(h / tau_m)^4 / 2880 ~ 1e-5 of each change. Measured worst cases over all
cases here: position 3.7e-7 m, velocity 2.7e-6 m/s, quaternion 3.5e-7, body rates 1.8e-5
rad/s, rotor speeds 1.0e-6 w_max (Hummingbird step and figure-eight, where the rotors
saturate); the Crazyflie (tau_m = 72 ms) and the x500 (50 ms) agree within 1e-9 m. The
tolerances, :data:`TOL`, are a factor 3-5 above those worst cases: position 1e-6 m, velocity
1e-5 m/s, quaternion 1e-6, body rates 1e-4 rad/s, rotor speeds 1e-5 w_max. Any wrong sign,
lever arm or coefficient shows by orders of magnitude (the synthetic flapping term changes
the open-loop tilt by 0.8 deg; a 1 % error in k_eta moves a 2 s open-loop flight by ~20 cm).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

rotorpy = pytest.importorskip("rotorpy")
from rotorpy.controllers.quadrotor_control import SE3Control  # noqa: E402
from rotorpy.vehicles.multirotor import Multirotor  # noqa: E402

from swarmnav.dynamics.airframes import AIRFRAMES, ROTOR_DIRECTIONS, Airframe, check  # noqa: E402
from swarmnav.dynamics.quadrotor import Gains, QuadrotorFleet, default_gains  # noqa: E402

H = 0.002  # inner step [s] = 1 / 500 Hz, RotorPy's t_step
# [m], [m/s], quaternion components, [rad/s], rotor speed / w_max; see the module docstring
TOL = {"pos": 1e-6, "vel": 1e-5, "quat": 1e-6, "rates": 1e-4, "rotors": 1e-5}
TIGHT = {"method": "DOP853", "rtol": 1e-10, "atol": 1e-12}


def rotorpy_params(af: Airframe, gains: Gains) -> dict:
    """Our airframe as RotorPy's ``quad_params`` dictionary (keys from rotorpy/vehicles)."""
    r = af.rotor_positions()
    return {
        "mass": af.mass, "Ixx": af.inertia[0], "Iyy": af.inertia[1], "Izz": af.inertia[2],
        "Ixy": 0.0, "Iyz": 0.0, "Ixz": 0.0,
        "num_rotors": 4, "rotor_pos": {f"r{i + 1}": r[i] for i in range(4)},
        "rotor_directions": np.array(ROTOR_DIRECTIONS), "rI": np.zeros(3),
        "c_Dx": af.c_D[0], "c_Dy": af.c_D[1], "c_Dz": af.c_D[2],
        "k_eta": af.k_eta, "k_m": af.k_m, "k_d": af.k_d, "k_z": af.k_z, "k_h": af.k_h, "k_flap": af.k_flap,
        "tau_m": af.tau_m, "rotor_speed_min": af.rotor_speed_min, "rotor_speed_max": af.rotor_speed_max,
        "motor_noise_std": 0.0, "rotor_radius": af.rotor_radius,
        "kp_att": gains.kp_att, "kd_att": gains.kd_att,
    }


def rotorpy_state(p, v, wind, af):
    return {"x": np.array(p, float), "v": np.array(v, float), "q": np.array([0.0, 0.0, 0.0, 1.0]),
            "w": np.zeros(3), "wind": np.array(wind, float), "rotor_speeds": np.full(4, af.hover_speed)}


def assert_same(ours: QuadrotorFleet, p, v, st, where):
    q = ours.quaternions[0]
    err = {
        "pos": np.abs(p[0] - st["x"]).max(),
        "vel": np.abs(v[0] - st["v"]).max(),
        "quat": np.abs(q[[1, 2, 3, 0]] - st["q"]).max(),  # ours (w, x, y, z), RotorPy (x, y, z, w)
        "rates": np.abs(ours.body_rates[0] - st["w"]).max(),
        "rotors": np.abs(ours.rotor_speeds[0] - st["rotor_speeds"]).max() / ours.airframe.rotor_speed_max,
    }
    bad = {k: e for k, e in err.items() if not e <= TOL[k]}
    assert not bad, f"{where}: differences beyond the tolerance: {bad}"
    return err


# relative size of the differential rotor step: a tilt of ~20-30 deg by the end of the flight
STEP = {"crazyflie": 2.5e-4, "hummingbird": 1e-3, "x500": 1e-3, "hummingbird+flap": 1e-3}
# a synthetic flapping coefficient, so the one term no shipped airframe uses is checked too
FLAP = dataclasses.replace(AIRFRAMES["hummingbird"], name="hummingbird+flap", k_flap=2e-7)


@pytest.mark.parametrize("af", [AIRFRAMES["crazyflie"], AIRFRAMES["hummingbird"], AIRFRAMES["x500"], FLAP],
                         ids=lambda a: a.name)
def test_open_loop_rotor_commands_give_rotorpys_trajectory(af):
    """Hover speeds for 0.5 s, then a small differential step (roll, pitch and yaw at once) for
    1.5 s, in a 2 m/s wind from the side and a 0.3 m/s initial climb, so every aero term acts."""
    check(af)
    wind = [1.5, -1.3, 0.2]
    vehicle = Multirotor(rotorpy_params(af, default_gains(af)), control_abstraction="cmd_motor_speeds",
                         aero=True, enable_ground=False, integrator_kwargs=TIGHT)
    st = rotorpy_state([0, 0, 5], [0.2, 0.0, 0.3], wind, af)
    fleet = QuadrotorFleet(af, 1, inner_hz=1 / H)
    p, v = st["x"][None].copy(), st["v"][None].copy()
    fleet.reset(p, v)
    air = np.array([wind])
    worst = {}
    for k in range(1000):  # 2 s
        cmd = np.full(4, af.hover_speed)
        if k >= 250:
            cmd = cmd * (1.0 + STEP[af.name] * np.array([4.0, -2.0, -3.0, 1.0]))
        st = vehicle.step(st, {"cmd_motor_speeds": cmd}, H)
        p, v = fleet.fly_rotors(p, v, cmd[None], H, air=air)
        if k % 50 == 49:
            e = assert_same(fleet, p, v, st, f"t = {(k + 1) * H:.2f} s")
            worst = {key: max(worst.get(key, 0), e[key]) for key in e}
    assert worst["pos"] > 0  # two independent integrations, not the same code twice
    # the step did something: the vehicle has rotated and drifted well beyond the tolerance
    assert fleet.tilt_max_deg[0] > 5 and np.abs(p[0] - [0.4, 0, 5.6]).max() > 0.05


def figure_eight(t):
    """A 2 m x 1 m lemniscate (period 8 s) at 1 m height: position, velocity, acceleration."""
    w = 2 * np.pi / 8.0
    p = np.array([np.sin(w * t), 0.5 * np.sin(2 * w * t), 1.0])
    v = np.array([w * np.cos(w * t), w * np.cos(2 * w * t), 0.0])
    a = np.array([-w * w * np.sin(w * t), -2 * w * w * np.sin(2 * w * t), 0.0])
    return p, v, a


REFERENCES = {
    "hover": lambda t: (np.array([0.0, 0.0, 1.0]), np.zeros(3), np.zeros(3)),
    "step_1m": lambda t: (np.array([1.0, 0.0, 1.0]), np.zeros(3), np.zeros(3)),
    "figure_eight": figure_eight,
}


@pytest.mark.parametrize("name", ["crazyflie", "hummingbird"])
@pytest.mark.parametrize("ref", sorted(REFERENCES))
def test_closed_loop_matches_rotorpys_se3_controller(name, ref):
    """Our fleet flying a 0.05 s method step (25 inner steps of 2 ms) and RotorPy's Multirotor
    under its SE3Control with our gains, stepped at 2 ms, follow the same reference for 3 s:
    the method's reference (p, v, a) sampled every 0.05 s and extrapolated at constant
    acceleration in between, as :meth:`QuadrotorFleet.fly` defines it. A 1 m/s wind blows."""
    af = AIRFRAMES[name]
    gains = default_gains(af)
    params = rotorpy_params(af, gains)
    vehicle = Multirotor(params, control_abstraction="cmd_motor_speeds", aero=True, integrator_kwargs=TIGHT)
    ctrl = SE3Control(params)
    ctrl.kp_pos, ctrl.kd_pos = np.array(gains.kp_pos), np.array(gains.kd_pos)
    wind = [1.0, 0.0, 0.0]
    st = rotorpy_state([0.0, 0.0, 1.0], [0.0, 0.0, 0.0], wind, af)
    fleet = QuadrotorFleet(af, 1, inner_hz=500.0, gains=gains)
    p, v = st["x"][None].copy(), st["v"][None].copy()
    fleet.reset(p, v)
    dt, n_inner = 0.05, 25
    worst = {}
    for j in range(60):  # 3 s
        pr, vr, ar = REFERENCES[ref](j * dt)
        for k in range(n_inner):
            tau = k * H
            flat = {"x": pr + vr * tau + 0.5 * ar * tau * tau, "x_dot": vr + ar * tau, "x_ddot": ar,
                    "x_dddot": np.zeros(3), "x_ddddot": np.zeros(3), "yaw": 0.0, "yaw_dot": 0.0}
            st = vehicle.step(st, ctrl.update(j * dt + tau, st, flat), H)
        p, v = fleet.fly(p, v, pr[None], vr[None], ar[None], dt, air=np.array([wind]))
        e = assert_same(fleet, p, v, st, f"{ref}, t = {(j + 1) * dt:.2f} s")
        worst = {key: max(worst.get(key, 0), e[key]) for key in e}
    assert worst["pos"] > 0
    if ref == "step_1m":  # the comparison covers a real manoeuvre: most of the step is done
        assert p[0, 0] > 0.9 and fleet.tilt_max_deg[0] > 5
