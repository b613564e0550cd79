"""RotorPy as the oracle of the quadrotor kernel and its SE(3) controller.

RotorPy (Folk et al. 2023, arXiv 2306.04485; PyPI ``rotorpy`` 3.x, a test dependency only) is
run on the same airframe (our :class:`Airframe` mapped onto its parameter dictionary), the same
initial state and the same commands, and the two trajectories are compared over seconds of flight.

What is on and off in RotorPy: its full aerodynamic model is on (``aero=True``: parasitic drag,
rotor H-force drag with k_d and k_z, translational lift k_h, blade flapping k_flap), as ours
implements all four; ground contact is off (``enable_ground=False``; these fleets are given no
floor) and motor noise is zero (``motor_noise_std = 0``). RotorPy integrates with SciPy's
``solve_ivp``; it is run here with DOP853 at rtol 1e-10 / atol 1e-12, so that its own error is
negligible and the comparison measures ours. RotorPy runs in a process of its own
(``_helpers/rotorpy_side.py``): importing it would change the numerical kernels of the swarmnav
runs of later tests in this process.

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

import importlib.util

import numpy as np
import pytest

from _helpers.rotorpy_side import (CLOSED_AIRFRAMES, CLOSED_WIND, H, OPEN_LOOP, OPEN_WIND, REFERENCES, YAW_RATE,
                                   open_loop_command, reference)
from swarmnav.dynamics.airframes import AIRFRAMES, check
from swarmnav.dynamics.quadrotor import QuadrotorFleet, default_gains

if importlib.util.find_spec("rotorpy") is None:
    pytest.skip("RotorPy is not installed (the test extra: pip install -e '.[test]')", allow_module_level=True)

# [m], [m/s], quaternion components, [rad/s], rotor speed / w_max; see the module docstring
TOL = {"pos": 1e-6, "vel": 1e-5, "quat": 1e-6, "rates": 1e-4, "rotors": 1e-5}


@pytest.fixture(scope="module")
def rotorpy(tmp_path_factory) -> dict[str, np.ndarray]:
    """RotorPy's states of every case, at the check times (one process for all of them)."""
    return reference(tmp_path_factory.mktemp("rotorpy"))


def assert_same(ours: QuadrotorFleet, p, v, theirs: dict, key: str, i: int, where: str) -> dict:
    q = ours.quaternions[0]
    err = {
        "pos": np.abs(p[0] - theirs[f"{key}/x"][i]).max(),
        "vel": np.abs(v[0] - theirs[f"{key}/v"][i]).max(),
        "quat": np.abs(q[[1, 2, 3, 0]] - theirs[f"{key}/q"][i]).max(),  # ours (w, x, y, z), RotorPy (x, y, z, w)
        "rates": np.abs(ours.body_rates[0] - theirs[f"{key}/w"][i]).max(),
        "rotors": np.abs(ours.rotor_speeds[0] - theirs[f"{key}/rotor_speeds"][i]).max() / ours.airframe.rotor_speed_max,
    }
    bad = {k: e for k, e in err.items() if not e <= TOL[k]}
    assert not bad, f"{where}: differences beyond the tolerance: {bad}"
    return err


@pytest.mark.parametrize("af", OPEN_LOOP, ids=lambda a: a.name)
def test_open_loop_rotor_commands_give_rotorpys_trajectory(af, rotorpy):
    """Hover speeds for 0.5 s, then a small differential step (roll, pitch and yaw at once) for
    1.5 s, in a 2 m/s wind from the side and a 0.3 m/s initial climb, so every aero term acts."""
    check(af)
    fleet = QuadrotorFleet(af, 1, inner_hz=1 / H)
    p, v = np.array([[0.0, 0.0, 5.0]]), np.array([[0.2, 0.0, 0.3]])
    fleet.reset(p, v)
    air = np.array([OPEN_WIND])
    worst = {}
    for k in range(1000):  # 2 s
        p, v = fleet.fly_rotors(p, v, open_loop_command(af, k)[None], H, air=air)
        if k % 50 == 49:
            e = assert_same(fleet, p, v, rotorpy, f"open/{af.name}", k // 50, f"t = {(k + 1) * H:.2f} s")
            worst = {key: max(worst.get(key, 0), e[key]) for key in e}
    assert worst["pos"] > 0  # two independent integrations, not the same code twice
    # the step did something: the vehicle has rotated and drifted well beyond the tolerance
    assert fleet.tilt_max_deg[0] > 5 and np.abs(p[0] - [0.4, 0, 5.6]).max() > 0.05


@pytest.mark.parametrize("name", CLOSED_AIRFRAMES)
@pytest.mark.parametrize("ref", sorted(REFERENCES))
def test_closed_loop_matches_rotorpys_se3_controller(name, ref, rotorpy):
    """Our fleet flying a 0.05 s method step (25 inner steps of 2 ms) and RotorPy's Multirotor
    under its SE3Control with our gains, stepped at 2 ms, follow the same reference for 3 s:
    the method's reference (p, v, a) sampled every 0.05 s and extrapolated at constant
    acceleration in between, as :meth:`QuadrotorFleet.fly` defines it; with a yaw ramp, the
    heading reference ramps the same way on both sides. A 1 m/s wind blows."""
    af = AIRFRAMES[name]
    fleet = QuadrotorFleet(af, 1, inner_hz=500.0, gains=default_gains(af))
    p, v = np.array([[0.0, 0.0, 1.0]]), np.zeros((1, 3))
    fleet.reset(p, v)
    dt = 0.05
    worst = {}
    rate = YAW_RATE.get(ref)
    for j in range(60):  # 3 s
        pr, vr, ar = REFERENCES[ref](j * dt)
        heading = {} if rate is None else {"yaw": np.array([rate * j * dt]), "yaw_rate": np.array([rate])}
        p, v = fleet.fly(p, v, pr[None], vr[None], ar[None], dt, air=np.array([CLOSED_WIND]), **heading)
        e = assert_same(fleet, p, v, rotorpy, f"closed/{name}/{ref}", j, f"{ref}, t = {(j + 1) * dt:.2f} s")
        worst = {key: max(worst.get(key, 0), e[key]) for key in e}
    assert worst["pos"] > 0
    if ref == "step_1m":  # the comparison covers a real manoeuvre: most of the step is done
        assert p[0, 0] > 0.9 and fleet.tilt_max_deg[0] > 5
    if rate is not None:  # the heading turned with its ramp (2.4 rad at 3 s), not held at 0
        assert abs(fleet.yaw[0] - rate * 3.0) < 0.05
