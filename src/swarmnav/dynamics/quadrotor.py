"""A batched rigid-body quadrotor and its geometric SE(3) tracking controller, compiled with Numba.

The model (frames, rotor layout and signs in :mod:`swarmnav.dynamics.airframes`). Per vehicle the
state is position p and velocity v (world), the attitude quaternion q (body to world, stored
scalar first, ``(w, x, y, z)``), the body rates omega and the four rotor speeds w_i. With v_a the
air-relative velocity in the body frame, ``v_a = R^T (v - air)``, and each hub's air-relative
velocity ``v_i = v_a + omega x r_i``:

* rotor i pushes along body z with ``T_i = k_eta w_i^2 + k_h (v_i,x^2 + v_i,y^2)`` (thrust plus
  translational lift) and drags with the H-force ``H_i = -w_i diag(k_d, k_d, k_z) v_i``, both
  applied at its hub r_i; it twists the body about z by ``s_i k_m w_i^2`` (s_i = +1, -1, +1, -1)
  and by the flapping moment ``-k_flap w_i (v_i x e3)``;
* the frame drags with ``D = -|v_a| diag(c_Dx, c_Dy, c_Dz) v_a`` at the centre of mass;
* ``p' = v``, ``m v' = R F_body - m g e3``, ``J omega' = M_body - omega x J omega``,
  ``q' = q (x) (0, omega) / 2`` (renormalised after every inner step);
* each motor follows its command with a first-order lag, ``w_i' = (w_cmd,i - w_i) / tau_m``, the
  command clipped to ``[w_min, w_max]``.

These are the equations of RotorPy's ``Multirotor`` (Folk et al. 2023, arXiv 2306.04485,
Section III), against which ``tests/dynamics/test_rotorpy_oracle.py`` checks this module.

The controller (Lee, Leok, McClamroch 2010, "Geometric tracking control of a quadrotor UAV on
SE(3)", eqs. (11)-(16), in the mass- and inertia-normalised form RotorPy's ``SE3Control`` uses):
``F = m (-k_p e_p - k_v e_v + a_r + g e3)`` with per-axis gains; collective thrust ``u1 = F . R e3``;
desired axes ``b3d = F / |F|``, ``b2d = b3d x c1 / |b3d x c1|`` with ``c1 = (cos psi, sin psi, 0)``
and the heading psi (0, or a ramp ``psi_r(tau) = psi_0 + psi_dot tau`` over the step when
:meth:`QuadrotorFleet.fly` is given one), ``b1d = b2d x b3d``; attitude error
``e_R = vee(Rd^T R - R^T Rd) / 2`` and rate error ``e_w = omega - (0, 0, psi_dot)`` (the desired
body rate, which Lee et al. differentiate from Rd, is taken as the yaw rate alone, as RotorPy's
``SE3Control`` takes it: the references here are piecewise-constant accelerations with zero
jerk); moment ``M = J (-k_R e_R - k_w e_w) + omega x J omega``. The wrench
``(u1, M)`` goes through the inverse of the mixer (the linear map from the four rotor thrusts to
collective thrust and the three moments) to rotor thrusts f_i, then to speeds
``sign(f_i) sqrt(|f_i| / k_eta)``, clipped to ``[w_min, w_max]``. The controller runs once per
inner step and holds its command over it (zero-order hold), like a flight controller's loop.

Integration, at the inner step h = dt / ceil(dt * inner_hz): the motor lag is linear in w with
a command held over the step, so it is solved exactly, ``w(t) = c + (w0 - c) exp(-t / tau_m)``;
that is stable for any tau_m (the Hummingbird's 5 ms is shorter than a 500 Hz step would resolve
with an explicit method's margin) and gives the rotor speeds at the stage times of the classical
fourth-order Runge-Kutta step that integrates the rigid body (p, v, q, omega). RK4 at 2 ms keeps
the rigid body well inside its stability region (the fastest closed-loop attitude pole, with
the Crazyflie's gains s^2 + 57 s + 310, is at 51 rad/s: h |lambda| = 0.1 against RK4's 2.8) and
its error below 4e-7 m against RotorPy over 3 s (tests/dynamics/test_rotorpy_oracle.py). Rotor energy ``k_m sum w_i^3`` is
integrated with Simpson's rule on the exact rotor speeds at those stage times.

A vehicle whose tilt exceeds 90 deg, or whose state stops being finite, is *flipped*: its state
is frozen at its last finite value (the position and velocity passed in are returned
unchanged from then on) and it stays flagged until :meth:`QuadrotorFleet.reset`. A fleet given a
floor (``QuadrotorFleet(..., floor=z0)``) checks it after every inner step: a vehicle whose z has
fallen to ``z0`` or below is put on it (z = z0) at rest and is *grounded*, frozen likewise: it
stops in the inner step in which it reached the floor, never flies through it.

Determinism: compiled without fastmath, the vehicles in a fixed order, one thread; identical
inputs give identical outputs, and a vehicle's result does not depend on the others in the batch.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from swarmnav.dynamics.airframes import GRAVITY, ROTOR_DIRECTIONS, Airframe, check
from swarmnav.errors import ConfigError


@dataclass(frozen=True, slots=True)
class Gains:
    """Gains of the SE(3) controller, normalised by mass (position) and inertia (attitude).

    Defaults: RotorPy's ``SE3Control`` (Folk et al. 2023) position gains, and its attitude
    gains for the Crazyflie (``kp_att = 310``, ``kd_att = 57``); :func:`default_gains` gives
    each airframe the values its RotorPy parameter file carries.
    """

    kp_pos: tuple[float, float, float] = (6.5, 6.5, 15.0)  # k_p per world axis [1/s^2]
    kd_pos: tuple[float, float, float] = (4.0, 4.0, 9.0)  # k_v per world axis [1/s]
    kp_att: float = 310.0  # k_R / J [1/s^2]
    kd_att: float = 57.0  # k_w / J [1/s]
    # compensate the airframe's own aerodynamic force (body and rotor drag, translational lift and
    # flapping, at its current state in still air) in the commanded thrust, as rotor-drag-aware
    # controllers do (Faessler, Franchi & Scaramuzza, RA-L 3(2), 2018); the wind stays unknown to it.
    # False: RotorPy's SE3Control, which has no such term (the oracle tests)
    drag_ff: bool = False


# RotorPy parameter files: crazyflie_params (310, 57), hummingbird_params (544, 46.64); the PX4
# SIH file carries none, so RotorPy's SE3Control falls back to (310, 57).
_ATTITUDE_GAINS = {"crazyflie": (310.0, 57.0), "hummingbird": (544.0, 46.64), "x500": (310.0, 57.0)}


def default_gains(airframe: Airframe) -> Gains:
    """The controller gains for ``airframe`` (RotorPy's, see :class:`Gains`)."""
    kp, kd = _ATTITUDE_GAINS.get(airframe.name, (310.0, 57.0))
    return Gains(kp_att=kp, kd_att=kd)


def _check_gains(g: Gains) -> Gains:
    vals = (*g.kp_pos, *g.kd_pos, g.kp_att, g.kd_att)
    if len(g.kp_pos) != 3 or len(g.kd_pos) != 3 or not all(math.isfinite(v) and v > 0 for v in vals):
        raise ConfigError(f"controller gains must be finite and > 0 (three per position gain), got {g}")
    return g


# Layout of the flat parameter vector the kernels read.
_MASS, _IXX, _IYY, _IZZ, _KETA, _KM, _WMIN, _WMAX, _TAU, _CDX, _CDY, _CDZ, _KD, _KZ, _KH, _KFLAP, _G = range(17)


def _params(af: Airframe) -> np.ndarray:
    return np.array([af.mass, *af.inertia, af.k_eta, af.k_m, af.rotor_speed_min, af.rotor_speed_max,
                     af.tau_m, *af.c_D, af.k_d, af.k_z, af.k_h, af.k_flap, GRAVITY], dtype=np.float64)


def mixer(af: Airframe) -> np.ndarray:
    """The (4, 4) map from rotor thrusts [N] to (collective thrust [N], moments about body x, y, z
    [N m]): rows ``1``, ``y_i``, ``-x_i``, ``s_i k_m / k_eta``."""
    r = af.rotor_positions()
    return np.array([np.ones(4), r[:, 1], -r[:, 0], np.array(ROTOR_DIRECTIONS) * af.k_m / af.k_eta])


@njit(cache=True)
def _rotation(q, R):
    """Rotation matrix (body to world) of the quaternion q = (w, x, y, z), normalised first."""
    n = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    w, x, y, z = q[0] / n, q[1] / n, q[2] / n, q[3] / n
    R[0, 0] = 1.0 - 2.0 * (y * y + z * z)
    R[0, 1] = 2.0 * (x * y - z * w)
    R[0, 2] = 2.0 * (x * z + y * w)
    R[1, 0] = 2.0 * (x * y + z * w)
    R[1, 1] = 1.0 - 2.0 * (x * x + z * z)
    R[1, 2] = 2.0 * (y * z - x * w)
    R[2, 0] = 2.0 * (x * z - y * w)
    R[2, 1] = 2.0 * (y * z + x * w)
    R[2, 2] = 1.0 - 2.0 * (x * x + y * y)


@njit(cache=True)
def _derivative(s, wr, air, P, rpos, rdir, R, out):
    """Time derivative of s = (p, v, q, omega) (13,) with rotor speeds wr (4,) and air velocity
    air (3,) [m/s]; R is scratch (3, 3)."""
    _rotation(s[6:10], R)
    wx, wy, wz = s[10], s[11], s[12]
    ax, ay, az = s[3] - air[0], s[4] - air[1], s[5] - air[2]
    # air-relative velocity in the body frame, R^T (v - air)
    bx = R[0, 0] * ax + R[1, 0] * ay + R[2, 0] * az
    by = R[0, 1] * ax + R[1, 1] * ay + R[2, 1] * az
    bz = R[0, 2] * ax + R[1, 2] * ay + R[2, 2] * az
    k_eta, k_m, k_d, k_z, k_h, k_flap = P[_KETA], P[_KM], P[_KD], P[_KZ], P[_KH], P[_KFLAP]
    fx = fy = fz = 0.0
    mx = my = mz = 0.0
    for j in range(4):
        rx, ry, rz = rpos[j, 0], rpos[j, 1], rpos[j, 2]
        # hub velocity v_a + omega x r
        lx = bx + wy * rz - wz * ry
        ly = by + wz * rx - wx * rz
        lz = bz + wx * ry - wy * rx
        w = wr[j]
        Fx = -w * k_d * lx
        Fy = -w * k_d * ly
        Fz = k_eta * w * w + k_h * (lx * lx + ly * ly) - w * k_z * lz
        fx += Fx
        fy += Fy
        fz += Fz
        mx += ry * Fz - rz * Fy - k_flap * w * ly
        my += rz * Fx - rx * Fz + k_flap * w * lx
        mz += rx * Fy - ry * Fx + rdir[j] * k_m * w * w
    sp = math.sqrt(bx * bx + by * by + bz * bz)
    fx -= sp * P[_CDX] * bx
    fy -= sp * P[_CDY] * by
    fz -= sp * P[_CDZ] * bz
    m = P[_MASS]
    out[0], out[1], out[2] = s[3], s[4], s[5]
    out[3] = (R[0, 0] * fx + R[0, 1] * fy + R[0, 2] * fz) / m
    out[4] = (R[1, 0] * fx + R[1, 1] * fy + R[1, 2] * fz) / m
    out[5] = (R[2, 0] * fx + R[2, 1] * fy + R[2, 2] * fz) / m - P[_G]
    qw, qx, qy, qz = s[6], s[7], s[8], s[9]
    out[6] = -0.5 * (qx * wx + qy * wy + qz * wz)
    out[7] = 0.5 * (qw * wx + qy * wz - qz * wy)
    out[8] = 0.5 * (qw * wy + qz * wx - qx * wz)
    out[9] = 0.5 * (qw * wz + qx * wy - qy * wx)
    Ix, Iy, Iz = P[_IXX], P[_IYY], P[_IZZ]
    out[10] = (mx - (wy * Iz * wz - wz * Iy * wy)) / Ix
    out[11] = (my - (wz * Ix * wx - wx * Iz * wz)) / Iy
    out[12] = (mz - (wx * Iy * wy - wy * Ix * wx)) / Iz


@njit(cache=True)
def _control(s, pr, vr, ar, P, G, A, R, cmd, yaw_on, psi, psi_dot):
    """SE(3) controller: rotor speed commands cmd (4,) [rad/s], unclipped, for the state s; yaw 0,
    or with ``yaw_on`` the heading psi [rad] turning at psi_dot [rad/s]."""
    m, g = P[_MASS], P[_G]
    Fx = m * (-G[0] * (s[0] - pr[0]) - G[3] * (s[3] - vr[0]) + ar[0])
    Fy = m * (-G[1] * (s[1] - pr[1]) - G[4] * (s[4] - vr[1]) + ar[1])
    Fz = m * (-G[2] * (s[2] - pr[2]) - G[5] * (s[5] - vr[2]) + ar[2] + g)
    _rotation(s[6:10], R)
    u1 = Fx * R[0, 2] + Fy * R[1, 2] + Fz * R[2, 2]
    nF = math.sqrt(Fx * Fx + Fy * Fy + Fz * Fz)
    if nF > 1e-12:
        b3x, b3y, b3z = Fx / nF, Fy / nF, Fz / nF
    else:
        b3x, b3y, b3z = 0.0, 0.0, 1.0
    if yaw_on:  # b2d = b3d x c1 with c1 = (cos psi, sin psi, 0)
        c1x, c1y = math.cos(psi), math.sin(psi)
        c2x, c2y, c2z = -b3z * c1y, b3z * c1x, b3x * c1y - b3y * c1x
        n2 = math.sqrt(c2x * c2x + c2y * c2y + c2z * c2z)
        if n2 > 1e-12:
            b2x, b2y, b2z = c2x / n2, c2y / n2, c2z / n2
        else:
            b2x, b2y, b2z = -c1y, c1x, 0.0
    else:  # b2d = b3d x c1 with c1 = (1, 0, 0) (yaw 0)
        c2x, c2y, c2z = 0.0, b3z, -b3y
        n2 = math.sqrt(c2y * c2y + c2z * c2z)
        if n2 > 1e-12:
            b2x, b2y, b2z = c2x, c2y / n2, c2z / n2
        else:
            b2x, b2y, b2z = 0.0, 1.0, 0.0
    b1x = b2y * b3z - b2z * b3y
    b1y = b2z * b3x - b2x * b3z
    b1z = b2x * b3y - b2y * b3x
    # E = Rd^T R: entries needed by vee((E - E^T) / 2)
    # (Rd^T R)[a, b] = d_a . R[:, b] with d_0 = b1d, d_1 = b2d, d_2 = b3d
    e21 = b3x * R[0, 1] + b3y * R[1, 1] + b3z * R[2, 1]
    e12 = b2x * R[0, 2] + b2y * R[1, 2] + b2z * R[2, 2]
    e02 = b1x * R[0, 2] + b1y * R[1, 2] + b1z * R[2, 2]
    e20 = b3x * R[0, 0] + b3y * R[1, 0] + b3z * R[2, 0]
    e10 = b2x * R[0, 0] + b2y * R[1, 0] + b2z * R[2, 0]
    e01 = b1x * R[0, 1] + b1y * R[1, 1] + b1z * R[2, 1]
    erx = 0.5 * (e21 - e12)
    ery = 0.5 * (e02 - e20)
    erz = 0.5 * (e10 - e01)
    wx, wy, wz = s[10], s[11], s[12]
    Ix, Iy, Iz = P[_IXX], P[_IYY], P[_IZZ]
    kR, kW = G[6], G[7]
    Mx = Ix * (-kR * erx - kW * wx) + (wy * Iz * wz - wz * Iy * wy)
    My = Iy * (-kR * ery - kW * wy) + (wz * Ix * wx - wx * Iz * wz)
    # the desired body rate is (0, 0, psi_dot), as RotorPy's SE3Control takes it (zero with yaw held)
    Mz = Iz * (-kR * erz - kW * (wz - psi_dot)) + (wx * Iy * wy - wy * Ix * wx)
    k_eta = P[_KETA]
    for j in range(4):
        f = A[j, 0] * u1 + A[j, 1] * Mx + A[j, 2] * My + A[j, 3] * Mz
        if f >= 0.0:
            cmd[j] = math.sqrt(f / k_eta)
        else:
            cmd[j] = -math.sqrt(-f / k_eta)


@njit(cache=True)
def _advance(pos, vel, quat, omega, rotor, flipped, grounded, floor, cos_tilt_min, sat_steps, energy,
             controlled, p_ref, v_ref, a_ref, rotor_cmd, air, h, n_inner, P, rpos, rdir, G, A,
             pos_out, vel_out, yaw_on, yaw0, yaw_rate):
    """Advance every vehicle by n_inner inner steps of h [s], in place on the fleet state
    (quat, omega, rotor, flipped, grounded, cos_tilt_min, sat_steps, energy); new p, v into
    pos_out, vel_out. A vehicle whose z falls to ``floor`` [m] stops there, at rest, grounded.
    With ``yaw_on`` vehicle i's heading reference is yaw0[i] + yaw_rate[i] tau [rad], else 0."""
    s = np.empty(13)
    s0 = np.empty(13)
    st = np.empty(13)
    k1 = np.empty(13)
    k2 = np.empty(13)
    k3 = np.empty(13)
    k4 = np.empty(13)
    R = np.empty((3, 3))
    cmd = np.empty(4)
    kff = np.empty(13)
    still = np.zeros(3)
    w0 = np.empty(4)
    wh = np.empty(4)
    we = np.empty(4)
    pr = np.empty(3)
    vr = np.empty(3)
    ar = np.empty(3)
    a = np.empty(3)
    wmin, wmax, tau, k_m = P[_WMIN], P[_WMAX], P[_TAU], P[_KM]
    if tau > 0.0:
        e_half = math.exp(-0.5 * h / tau)
        e_full = math.exp(-h / tau)
    else:
        e_half = 0.0
        e_full = 0.0
    for i in range(pos.shape[0]):
        for c in range(3):
            pos_out[i, c] = pos[i, c]
            vel_out[i, c] = vel[i, c]
        if flipped[i] or grounded[i]:
            continue
        for c in range(3):
            s[c] = pos[i, c]
            s[3 + c] = vel[i, c]
            s[10 + c] = omega[i, c]
            a[c] = air[i, c]
        for c in range(4):
            s[6 + c] = quat[i, c]
            w0[c] = rotor[i, c]
        for k in range(n_inner):
            if controlled:
                tk = k * h
                for c in range(3):
                    pr[c] = p_ref[i, c] + v_ref[i, c] * tk + 0.5 * a_ref[i, c] * tk * tk
                    vr[c] = v_ref[i, c] + a_ref[i, c] * tk
                    ar[c] = a_ref[i, c]
                if G[8] > 0.0:  # drag_ff: the vehicle's own aerodynamic force now, in still air, cancelled
                    _derivative(s, w0, still, P, rpos, rdir, R, kff)
                    lift = P[_KETA] * (w0[0] ** 2 + w0[1] ** 2 + w0[2] ** 2 + w0[3] ** 2) / P[_MASS]
                    ar[0] -= kff[3] - R[0, 2] * lift
                    ar[1] -= kff[4] - R[1, 2] * lift
                    ar[2] -= kff[5] + P[_G] - R[2, 2] * lift
                if yaw_on:
                    _control(s, pr, vr, ar, P, G, A, R, cmd, True, yaw0[i] + yaw_rate[i] * tk, yaw_rate[i])
                else:
                    _control(s, pr, vr, ar, P, G, A, R, cmd, False, 0.0, 0.0)
            else:
                for c in range(4):
                    cmd[c] = rotor_cmd[i, c]
            at_bound = False
            for c in range(4):
                if cmd[c] <= wmin:
                    cmd[c] = wmin
                    at_bound = True
                elif cmd[c] >= wmax:
                    cmd[c] = wmax
                    at_bound = True
                if tau <= 0.0:  # no lag: the rotor is at its command from the step's start
                    w0[c] = cmd[c]
                wh[c] = cmd[c] + (w0[c] - cmd[c]) * e_half
                we[c] = cmd[c] + (w0[c] - cmd[c]) * e_full
            if at_bound:
                sat_steps[i] += 1
            for c in range(13):
                s0[c] = s[c]
            _derivative(s, w0, a, P, rpos, rdir, R, k1)
            for c in range(13):
                st[c] = s[c] + 0.5 * h * k1[c]
            _derivative(st, wh, a, P, rpos, rdir, R, k2)
            for c in range(13):
                st[c] = s[c] + 0.5 * h * k2[c]
            _derivative(st, wh, a, P, rpos, rdir, R, k3)
            for c in range(13):
                st[c] = s[c] + h * k3[c]
            _derivative(st, we, a, P, rpos, rdir, R, k4)
            for c in range(13):
                s[c] = s[c] + h / 6.0 * (k1[c] + 2.0 * k2[c] + 2.0 * k3[c] + k4[c])
            nq = math.sqrt(s[6] * s[6] + s[7] * s[7] + s[8] * s[8] + s[9] * s[9])
            for c in range(6, 10):
                s[c] = s[c] / nq
            e = 0.0
            for c in range(4):
                e += w0[c] ** 3 + 4.0 * wh[c] ** 3 + we[c] ** 3
            ok = True
            for c in range(13):
                if not math.isfinite(s[c]):
                    ok = False
            if not ok:
                for c in range(13):
                    s[c] = s0[c]
                flipped[i] = True
                break
            energy[i] += k_m * h / 6.0 * e
            for c in range(4):
                w0[c] = we[c]
            if s[2] <= floor:  # it reached the ground within this inner step: it stops on it
                s[2] = floor
                s[3] = 0.0
                s[4] = 0.0
                s[5] = 0.0
                grounded[i] = True
                break
            ct = 1.0 - 2.0 * (s[7] * s[7] + s[8] * s[8])
            if ct < cos_tilt_min[i]:
                cos_tilt_min[i] = ct
            if ct < 0.0:
                flipped[i] = True
                break
        for c in range(3):
            pos_out[i, c] = s[c]
            vel_out[i, c] = s[3 + c]
            omega[i, c] = s[10 + c]
        for c in range(4):
            quat[i, c] = s[6 + c]
            rotor[i, c] = w0[c]


class QuadrotorFleet:
    """N quadrotors of one airframe, each under its own SE(3) controller.

    The fleet holds what a point mass does not have: attitude, body rates, rotor speeds, and
    the run's vehicle statistics since :meth:`reset`. Position and velocity stay with the caller
    (a periodic world may wrap them), and are passed in and returned by every step.
    """

    def __init__(self, airframe: Airframe, n: int, inner_hz: float = 500.0, gains: Gains | None = None,
                 floor: float = -math.inf):
        self.airframe = check(airframe)
        if math.isnan(floor) or floor == math.inf:
            raise ConfigError(f"the floor must be a height [m] or -inf (none), got {floor!r}")
        self.floor = float(floor)
        if int(n) != n or n < 1:
            raise ConfigError(f"a fleet needs n >= 1 vehicles, got {n!r}")
        if not (math.isfinite(inner_hz) and inner_hz > 0):
            raise ConfigError(f"inner_hz must be a positive rate [Hz], got {inner_hz!r}")
        self.n = int(n)
        self.inner_hz = float(inner_hz)
        self.gains = _check_gains(gains if gains is not None else default_gains(airframe))
        self._P = _params(self.airframe)
        self._rpos = np.ascontiguousarray(self.airframe.rotor_positions())
        self._rdir = np.array(ROTOR_DIRECTIONS, dtype=np.float64)
        self._G = np.array([*self.gains.kp_pos, *self.gains.kd_pos, self.gains.kp_att, self.gains.kd_att,
                            1.0 if self.gains.drag_ff else 0.0], dtype=np.float64)
        self._A = np.ascontiguousarray(np.linalg.inv(mixer(self.airframe)))
        self._quat = np.zeros((self.n, 4))
        self._omega = np.zeros((self.n, 3))
        self._rotor = np.zeros((self.n, 4))
        self._flipped = np.zeros(self.n, dtype=np.bool_)
        self._grounded = np.zeros(self.n, dtype=np.bool_)
        self._cos_tilt_min = np.ones(self.n)
        self._sat = np.zeros(self.n, dtype=np.int64)
        self._steps = 0
        self._energy = np.zeros(self.n)
        self._no_yaw = np.zeros(self.n)
        self.reset(np.zeros((self.n, 3)), np.zeros((self.n, 3)))

    # ------------------------------------------------------------------ state
    def reset(self, pos: np.ndarray, vel: np.ndarray) -> None:
        """Level attitude (yaw 0), zero body rates, rotors at hover speed; statistics cleared.
        ``pos``, ``vel`` (N, 3) are the caller's start state (checked for shape and finiteness)."""
        self._state_arrays(pos, vel)
        self._quat[:] = (1.0, 0.0, 0.0, 0.0)
        self._omega[:] = 0.0
        self._rotor[:] = self.airframe.hover_speed
        self._flipped[:] = False
        self._grounded[:] = False
        self._cos_tilt_min[:] = 1.0
        self._sat[:] = 0
        self._steps = 0
        self._energy[:] = 0.0

    def fly(self, pos, vel, p_ref, v_ref, a_ref, dt, air=None, yaw=None, yaw_rate=None) -> tuple[np.ndarray, np.ndarray]:
        """Advance every vehicle by dt [s] (one method step) at the inner rate, tracking the
        reference p_r(tau) = p_ref + v_ref tau + a_ref tau^2/2, v_r = v_ref + a_ref tau, a_r = a_ref,
        tau in [0, dt], and the heading psi_r(tau) = yaw + yaw_rate tau (yaw, yaw_rate (N,) [rad],
        [rad/s]; None: yaw 0, the controller as RotorPy's with yaw held). pos, vel (N, 3) are the
        translational state the run holds; air (N, 3) [m/s] is the air's velocity at each vehicle
        (wind + downwash), constant over the step; None = still air. Returns new (pos, vel),
        (N, 3) float64."""
        p, v = self._state_arrays(pos, vel)
        refs = [self._array(x, name) for x, name in ((p_ref, "p_ref"), (v_ref, "v_ref"), (a_ref, "a_ref"))]
        if (yaw is None) != (yaw_rate is None):
            raise ValueError("give both yaw and yaw_rate, or neither")
        heading = None if yaw is None else (self._array(yaw, "yaw", None), self._array(yaw_rate, "yaw_rate", None))
        return self._run(p, v, True, *refs, np.zeros((self.n, 4)), air, dt, heading)

    def fly_rotors(self, pos, vel, rotor_cmd, dt, air=None) -> tuple[np.ndarray, np.ndarray]:
        """Like :meth:`fly` with the controller bypassed: rotor_cmd (N, 4) [rad/s] are the
        commanded rotor speeds (clipped to the airframe's range), held over the step."""
        p, v = self._state_arrays(pos, vel)
        cmd = self._array(rotor_cmd, "rotor_cmd", 4)
        z = np.zeros((self.n, 3))
        return self._run(p, v, False, z, z, z, cmd, air, dt)

    def _run(self, p, v, controlled, p_ref, v_ref, a_ref, cmd, air, dt, heading=None):
        n_inner = self.substeps(dt)
        yaw0, yaw_rate = (self._no_yaw, self._no_yaw) if heading is None else heading
        a = np.zeros((self.n, 3)) if air is None else self._array(air, "air")
        p_out, v_out = np.empty((self.n, 3)), np.empty((self.n, 3))
        _advance(p, v, self._quat, self._omega, self._rotor, self._flipped, self._grounded, self.floor,
                 self._cos_tilt_min, self._sat,
                 self._energy, controlled, p_ref, v_ref, a_ref, cmd, a, float(dt) / n_inner, n_inner,
                 self._P, self._rpos, self._rdir, self._G, self._A, p_out, v_out, heading is not None, yaw0, yaw_rate)
        self._steps += n_inner
        return p_out, v_out

    def substeps(self, dt: float) -> int:
        """Inner steps per method step dt [s]: ceil(dt * inner_hz); ConfigError if dt is not a
        positive duration or the inner rate is slower than the method's step."""
        if not (math.isfinite(dt) and dt > 0):
            raise ConfigError(f"the method step dt must be > 0 s, got {dt!r}")
        x = dt * self.inner_hz
        if x < 1.0 - 1e-9:
            raise ConfigError(f"vehicle inner rate {self.inner_hz:g} Hz is slower than the method's step "
                              f"dt = {dt:g} s (need inner_hz >= {1.0 / dt:g} Hz)")
        return max(1, math.ceil(x - 1e-9))

    def _array(self, x, name: str, cols: int | None = 3) -> np.ndarray:
        """``x`` as a contiguous float64 (N, cols) array, or (N,) for cols None; checked finite."""
        a = np.ascontiguousarray(x, dtype=np.float64)
        shape = (self.n,) if cols is None else (self.n, cols)
        if a.shape != shape:
            raise ValueError(f"{name} must have shape {shape}, got {a.shape}")
        if not np.isfinite(a).all():
            raise ValueError(f"{name} must be finite")
        return a

    def _state_arrays(self, pos, vel):
        return self._array(pos, "pos"), self._array(vel, "vel")

    # ------------------------------------------------------------- read-only views
    @property
    def quaternions(self) -> np.ndarray:
        """(N, 4) attitude quaternions, body to world, scalar first (w, x, y, z)."""
        return self._quat.copy()

    @property
    def attitude(self) -> np.ndarray:
        """(N, 3, 3) rotation matrices, body to world (columns: body x, y, z in world axes)."""
        w, x, y, z = self._quat.T
        R = np.empty((self.n, 3, 3))
        R[:, 0, 0] = 1 - 2 * (y * y + z * z)
        R[:, 0, 1] = 2 * (x * y - z * w)
        R[:, 0, 2] = 2 * (x * z + y * w)
        R[:, 1, 0] = 2 * (x * y + z * w)
        R[:, 1, 1] = 1 - 2 * (x * x + z * z)
        R[:, 1, 2] = 2 * (y * z - x * w)
        R[:, 2, 0] = 2 * (x * z - y * w)
        R[:, 2, 1] = 2 * (y * z + x * w)
        R[:, 2, 2] = 1 - 2 * (x * x + y * y)
        return R

    @property
    def yaw(self) -> np.ndarray:
        """(N,) heading [rad] in (-pi, pi]: the angle of the body x axis's horizontal projection
        from world x, atan2(R[1, 0], R[0, 0])."""
        w, x, y, z = self._quat.T
        return np.arctan2(2 * (x * y + z * w), 1 - 2 * (y * y + z * z))

    @property
    def body_rates(self) -> np.ndarray:
        """(N, 3) body rates omega [rad/s], body axes."""
        return self._omega.copy()

    @property
    def rotor_speeds(self) -> np.ndarray:
        """(N, 4) rotor speeds [rad/s], rotors 1..4."""
        return self._rotor.copy()

    @property
    def thrust(self) -> np.ndarray:
        """(N,) collective rotor thrust k_eta sum w_i^2 [N] at the current rotor speeds."""
        return self.airframe.k_eta * np.einsum("ij,ij->i", self._rotor, self._rotor)

    @property
    def tilt_max_deg(self) -> np.ndarray:
        """(N,) largest angle between body z and world z since reset [deg]."""
        return np.degrees(np.arccos(np.clip(self._cos_tilt_min, -1.0, 1.0)))

    @property
    def saturated_fraction(self) -> np.ndarray:
        """(N,) fraction of inner steps since reset with any rotor command at w_min or w_max."""
        return self._sat / max(self._steps, 1)

    @property
    def energy_J(self) -> np.ndarray:
        """(N,) rotor mechanical energy k_m sum w_i^3 integrated since reset [J]."""
        return self._energy.copy()

    @property
    def flipped(self) -> np.ndarray:
        """(N,) bool: tilted past 90 deg or non-finite since reset (state frozen since)."""
        return self._flipped.copy()

    @property
    def grounded(self) -> np.ndarray:
        """(N,) bool: came down to the floor since reset (stopped there, at rest, frozen since)."""
        return self._grounded.copy()
