"""Simulated seconds per CPU second of 100 quadrotors under the SE(3) controller, ours against RotorPy.

Pinned to one core. The work: N vehicles (default 100 Crazyflies), each tracking its own
figure-eight (2 m x 1 m, 8 s period, phases spread over the fleet) given as a method's reference
every 0.05 s (position, velocity, acceleration); the controller and the rigid body run at a
500 Hz inner rate for 10 s of flight, in a 2 m/s wind.

"Ours" is :class:`swarmnav.dynamics.quadrotor.QuadrotorFleet` (one compiled call per method
step for the whole fleet), timed after a first call has compiled it. "RotorPy" is the same work
in RotorPy 3 (PyPI ``rotorpy``): its ``SE3Control.update`` and ``Multirotor.step`` every 2 ms per
vehicle, with the library's default integrator (SciPy ``solve_ivp`` RK45 at its default
tolerances) and its aerodynamic model on. RotorPy's batched simulator (``BatchedMultirotor``,
``BatchedSE3Control``) needs PyTorch; when PyTorch is not installed the benchmark times the
non-batched classes on ``--rotorpy-n`` vehicles for ``--rotorpy-t`` seconds and scales the CPU
time linearly to N vehicles and the full flight (each vehicle is an independent Python loop, so
the cost is linear in both), and says so in its output.

    PYTHONPATH=src python benchmarks/bench_quadrotor.py
    PYTHONPATH=src python benchmarks/bench_quadrotor.py --n 1000 --airframe x500
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

from swarmnav.dynamics.airframes import ROTOR_DIRECTIONS, airframe
from swarmnav.dynamics.quadrotor import QuadrotorFleet, default_gains

DT, INNER_HZ, WIND = 0.05, 500.0, (2.0, 0.0, 0.0)


def references(t: float, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Figure-eights, one per vehicle, 3 m apart, phase-shifted: (N, 3) p, v, a at time t."""
    w = 2 * np.pi / 8.0
    ph = np.linspace(0.0, 2 * np.pi, n, endpoint=False)
    s1, c1, s2, c2 = np.sin(w * t + ph), np.cos(w * t + ph), np.sin(2 * (w * t + ph)), np.cos(2 * (w * t + ph))
    off = np.column_stack([3.0 * (np.arange(n) % 10), 3.0 * (np.arange(n) // 10), np.ones(n)])
    p = off + np.column_stack([s1, 0.5 * s2, np.zeros(n)])
    v = np.column_stack([w * c1, w * c2, np.zeros(n)])
    a = np.column_stack([-w * w * s1, -2 * w * w * s2, np.zeros(n)])
    return p, v, a


def ours(af, n: int, t_final: float) -> tuple[float, float, QuadrotorFleet]:
    fleet = QuadrotorFleet(af, n, inner_hz=INNER_HZ)
    p, v, _ = references(0.0, n)
    v = v.copy()
    air = np.tile(WIND, (n, 1))
    fleet.reset(p, v)
    fleet.fly(p, v, *references(0.0, n), DT, air=air)  # compile (or load the cache)
    fleet.reset(p, v)
    steps = round(t_final / DT)
    refs = [references(j * DT, n) for j in range(steps)]
    c0, w0 = time.process_time(), time.perf_counter()
    for j in range(steps):
        p, v = fleet.fly(p, v, *refs[j], DT, air=air)
    cpu, wall = time.process_time() - c0, time.perf_counter() - w0
    err = np.linalg.norm(p - references(steps * DT, n)[0], axis=1)
    print(f"  tracking error at the end: median {np.median(err):.3f} m, max {err.max():.3f} m; "
          f"tilt max {fleet.tilt_max_deg.max():.1f} deg; flipped {int(fleet.flipped.sum())}")
    return cpu, wall, fleet


def rotorpy_nonbatched(af, n: int, t_final: float) -> float:
    """CPU seconds of RotorPy's Multirotor + SE3Control flying n vehicles for t_final seconds."""
    from rotorpy.controllers.quadrotor_control import SE3Control
    from rotorpy.vehicles.multirotor import Multirotor

    g = default_gains(af)
    r = af.rotor_positions()
    params = {
        "mass": af.mass, "Ixx": af.inertia[0], "Iyy": af.inertia[1], "Izz": af.inertia[2],
        "Ixy": 0.0, "Iyz": 0.0, "Ixz": 0.0, "num_rotors": 4,
        "rotor_pos": {f"r{i + 1}": r[i] for i in range(4)}, "rotor_directions": np.array(ROTOR_DIRECTIONS),
        "rI": np.zeros(3), "c_Dx": af.c_D[0], "c_Dy": af.c_D[1], "c_Dz": af.c_D[2],
        "k_eta": af.k_eta, "k_m": af.k_m, "k_d": af.k_d, "k_z": af.k_z, "k_h": af.k_h, "k_flap": af.k_flap,
        "tau_m": af.tau_m, "rotor_speed_min": af.rotor_speed_min, "rotor_speed_max": af.rotor_speed_max,
        "motor_noise_std": 0.0, "kp_att": g.kp_att, "kd_att": g.kd_att,
    }
    h, n_inner = 1.0 / INNER_HZ, round(DT * INNER_HZ)
    p0, v0, _ = references(0.0, n)
    vehicles = [Multirotor(params, control_abstraction="cmd_motor_speeds", aero=True) for _ in range(n)]
    ctrls = [SE3Control(params) for _ in range(n)]
    states = [{"x": p0[i].copy(), "v": v0[i].copy(), "q": np.array([0.0, 0.0, 0.0, 1.0]), "w": np.zeros(3),
               "wind": np.array(WIND), "rotor_speeds": np.full(4, af.hover_speed)} for i in range(n)]
    c0 = time.process_time()
    for j in range(round(t_final / DT)):
        pr, vr, ar = references(j * DT, n)
        for i in range(n):
            for k in range(n_inner):
                tau = k * h
                flat = {"x": pr[i] + vr[i] * tau + 0.5 * ar[i] * tau * tau, "x_dot": vr[i] + ar[i] * tau,
                        "x_ddot": ar[i], "x_dddot": np.zeros(3), "x_ddddot": np.zeros(3), "yaw": 0.0, "yaw_dot": 0.0}
                states[i] = vehicles[i].step(states[i], ctrls[i].update(j * DT + tau, states[i], flat), h)
    return time.process_time() - c0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=100, help="vehicles")
    ap.add_argument("--t", type=float, default=10.0, help="simulated flight [s]")
    ap.add_argument("--airframe", default="crazyflie")
    ap.add_argument("--rotorpy-n", type=int, default=2, help="vehicles RotorPy flies (non-batched)")
    ap.add_argument("--rotorpy-t", type=float, default=1.0, help="seconds RotorPy flies (non-batched)")
    ap.add_argument("--cpu", type=int, default=None, help="core to pin to (default: the lowest allowed)")
    args = ap.parse_args()
    cpu_id = args.cpu if args.cpu is not None else min(os.sched_getaffinity(0))
    os.sched_setaffinity(0, {cpu_id})
    af = airframe(args.airframe)
    print(f"{args.n} x {af.name}, SE(3) controller + rigid body at {INNER_HZ:g} Hz, method step {DT} s, "
          f"{args.t:g} s of flight, core {cpu_id}")
    print("ours (QuadrotorFleet, Numba):")
    cpu, wall, _ = ours(af, args.n, args.t)
    rt_ours = args.t / cpu
    print(f"  {cpu:.3f} CPU s ({wall:.3f} s wall): {rt_ours:.1f} simulated s per CPU s "
          f"({rt_ours * args.n:.0f} vehicle-seconds per CPU s)")
    try:
        import rotorpy  # noqa: F401
    except ImportError:
        print("RotorPy: not installed (pip install 'rotorpy>=3,<4'); no comparison")
        return
    try:
        import torch  # noqa: F401
        batched = True
    except ImportError:
        batched = False
    if batched:
        print("RotorPy: PyTorch is installed, but this benchmark times the non-batched classes "
              "(the batched simulator is not wired here)")
    else:
        print("RotorPy: BatchedMultirotor needs PyTorch, which is not installed: timing the non-batched "
              f"Multirotor + SE3Control on {args.rotorpy_n} vehicles x {args.rotorpy_t:g} s, scaled linearly")
    c = rotorpy_nonbatched(af, args.rotorpy_n, args.rotorpy_t)
    scaled = c * (args.n / args.rotorpy_n) * (args.t / args.rotorpy_t)
    rt_rp = args.t / scaled
    print(f"  {c:.3f} CPU s measured -> {scaled:.1f} CPU s for {args.n} vehicles x {args.t:g} s: "
          f"{rt_rp:.4f} simulated s per CPU s")
    print(f"ratio ours / RotorPy: {rt_ours / rt_rp:.0f}x")


if __name__ == "__main__":
    main()
