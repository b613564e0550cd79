"""RotorPy's side of the quadrotor oracle (tests/dynamics/test_rotorpy_oracle.py), run in a process
of its own: importing RotorPy loads SciPy's integrators into the process, which changes the
numerical kernels later swarmnav runs of that process use (docs/determinism.md), so the test
process never imports it. ``python -m _helpers.rotorpy_side OUT.npz`` writes every case's states
at its check times; :func:`reference` runs that process and reads them back.

Nothing here imports RotorPy at module level: the shared case definitions (airframes, steps,
references) are read by both sides.
"""

from __future__ import annotations

import dataclasses
import os
import subprocess
import sys
from pathlib import Path

import numpy as np

from swarmnav.dynamics.airframes import AIRFRAMES, ROTOR_DIRECTIONS, Airframe
from swarmnav.dynamics.quadrotor import Gains, default_gains

H = 0.002  # inner step [s] = 1 / 500 Hz, RotorPy's t_step
TIGHT = {"method": "DOP853", "rtol": 1e-10, "atol": 1e-12}
# relative size of the differential rotor step: a tilt of ~20-30 deg by the end of the flight
STEP = {"crazyflie": 2.5e-4, "hummingbird": 1e-3, "x500": 1e-3, "hummingbird+flap": 1e-3}
# a synthetic flapping coefficient, so the one term no shipped airframe uses is checked too
FLAP = dataclasses.replace(AIRFRAMES["hummingbird"], name="hummingbird+flap", k_flap=2e-7)
OPEN_LOOP = [AIRFRAMES["crazyflie"], AIRFRAMES["hummingbird"], AIRFRAMES["x500"], FLAP]
OPEN_WIND = [1.5, -1.3, 0.2]  # [m/s]
CLOSED_WIND = [1.0, 0.0, 0.0]  # [m/s]
CLOSED_AIRFRAMES = ["crazyflie", "hummingbird"]


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
    "figure_eight_yaw": figure_eight,
}
#: [rad/s] the heading ramp psi(t) = rate t of a reference (the others hold yaw 0): 2.4 rad in 3 s
YAW_RATE = {"figure_eight_yaw": 0.8}


def open_loop_command(af: Airframe, k: int) -> np.ndarray:
    """Rotor speeds [rad/s] of inner step k of the open-loop case: hover for 0.5 s, then a small
    differential step (roll, pitch and yaw at once)."""
    cmd = np.full(4, af.hover_speed)
    if k >= 250:
        cmd = cmd * (1.0 + STEP[af.name] * np.array([4.0, -2.0, -3.0, 1.0]))
    return cmd


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


def _record(out: dict, key: str, states: list[dict]) -> None:
    for field in ("x", "v", "q", "w", "rotor_speeds"):
        out[f"{key}/{field}"] = np.array([s[field] for s in states])


def _compute() -> dict[str, np.ndarray]:
    from rotorpy.controllers.quadrotor_control import SE3Control
    from rotorpy.vehicles.multirotor import Multirotor

    out: dict[str, np.ndarray] = {}
    for af in OPEN_LOOP:  # 2 s, checked every 0.1 s
        vehicle = Multirotor(rotorpy_params(af, default_gains(af)), control_abstraction="cmd_motor_speeds",
                             aero=True, enable_ground=False, integrator_kwargs=TIGHT)
        st = rotorpy_state([0, 0, 5], [0.2, 0.0, 0.3], OPEN_WIND, af)
        states = []
        for k in range(1000):
            st = vehicle.step(st, {"cmd_motor_speeds": open_loop_command(af, k)}, H)
            if k % 50 == 49:
                states.append(st)
        _record(out, f"open/{af.name}", states)
    for name in CLOSED_AIRFRAMES:  # 3 s of 0.05 s method steps, checked at every one
        af = AIRFRAMES[name]
        gains = default_gains(af)
        params = rotorpy_params(af, gains)
        for ref in sorted(REFERENCES):
            vehicle = Multirotor(params, control_abstraction="cmd_motor_speeds", aero=True, integrator_kwargs=TIGHT)
            ctrl = SE3Control(params)
            ctrl.kp_pos, ctrl.kd_pos = np.array(gains.kp_pos), np.array(gains.kd_pos)
            st = rotorpy_state([0.0, 0.0, 1.0], [0.0, 0.0, 0.0], CLOSED_WIND, af)
            states = []
            rate = YAW_RATE.get(ref, 0.0)
            for j in range(60):
                pr, vr, ar = REFERENCES[ref](j * 0.05)
                for k in range(25):
                    tau = k * H
                    flat = {"x": pr + vr * tau + 0.5 * ar * tau * tau, "x_dot": vr + ar * tau, "x_ddot": ar,
                            "x_dddot": np.zeros(3), "x_ddddot": np.zeros(3), "yaw": rate * (j * 0.05 + tau),
                            "yaw_dot": rate}
                    st = vehicle.step(st, ctrl.update(j * 0.05 + tau, st, flat), H)
                states.append(st)
            _record(out, f"closed/{name}/{ref}", states)
    return out


def reference(tmp: Path) -> dict[str, np.ndarray]:
    """Every case's RotorPy states, computed in a process of its own (module docstring)."""
    path = tmp / "rotorpy_reference.npz"
    here = Path(__file__).resolve().parents[1]
    src = here.parent / "src"
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(here), str(src), os.environ.get("PYTHONPATH", "")])}
    r = subprocess.run([sys.executable, "-m", "_helpers.rotorpy_side", str(path)], capture_output=True, text=True,
                       env=env)
    if r.returncode != 0:
        raise RuntimeError(f"RotorPy's side failed:\n{r.stderr}")
    with np.load(path) as z:
        return {k: z[k] for k in z.files}


if __name__ == "__main__":
    np.savez(sys.argv[1], **_compute())
