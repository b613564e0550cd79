"""Clamped uniform cubic B-splines: the trajectories of MADER (Tordesillas & How, T-RO 2021,
Section IV: "clamped uniform B-splines").

A spline of ``S`` segments of duration ``dt`` has ``S + 3`` control points ``C_0 .. C_{S+2}`` and
the knots ``[0, 0, 0, 0, dt, 2 dt, ..., (S - 1) dt, T, T, T, T]`` with ``T = S dt``. Segment ``s``
(time ``[s dt, (s + 1) dt]``) depends on ``C_s .. C_{s+3}`` and lies in their convex hull, as in
the uniform (unclamped) spline of :mod:`swarmnav.planning.bspline`. Unlike it, the curve starts
*at* ``C_0`` and ends at ``C_{S+2}``, and the start state fixes points that stay close to the
start: ``C_1 = q + v dt / 3`` (the uniform spline's ``C_0 = q - v dt + ...`` lies a whole
``v dt`` behind the robot, which in a forest often puts it inside an obstacle).

The derivative control points (velocity ``V_i``, acceleration ``A_i``, jerk ``J_i``) are linear
in the ``C_i`` (de Boor's derivative formula); :func:`derivative_matrices` gives them for
``dt = 1``, and they scale as ``1 / dt``, ``1 / dt^2``, ``1 / dt^3``. Evaluation is SciPy's
:class:`scipy.interpolate.BSpline`.
"""

from __future__ import annotations

import functools

import numpy as np
from scipy.interpolate import BSpline


def knots(num_seg: int, dt: float) -> np.ndarray:
    """The clamped uniform knot vector (``num_seg + 7`` knots) [s]."""
    inner = dt * np.arange(1, num_seg)
    T = dt * num_seg
    return np.concatenate([np.zeros(4), inner, np.full(4, T)])


@functools.cache
def derivative_matrices(num_seg: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(Mv, Ma, Mj) for ``dt = 1``: ``V = Mv C`` (``S + 2`` rows), ``A = Ma C`` (``S + 1``),
    ``J = Mj C`` (``S``: the jerk of each segment, constant on it). Divide by ``dt``, ``dt^2``,
    ``dt^3`` for another segment duration."""
    t = knots(num_seg, 1.0)
    n = num_seg + 3  # control points
    Mv = np.zeros((n - 1, n))
    for i in range(n - 1):
        w = 3.0 / (t[i + 4] - t[i + 1])
        Mv[i, i], Mv[i, i + 1] = -w, w
    Ma = np.zeros((n - 2, n - 1))
    for i in range(n - 2):
        w = 2.0 / (t[i + 4] - t[i + 2])
        Ma[i, i], Ma[i, i + 1] = -w, w
    Mj = np.zeros((n - 3, n - 2))
    for i in range(n - 3):
        w = 1.0 / (t[i + 4] - t[i + 3])
        Mj[i, i], Mj[i, i + 1] = -w, w
    Ma = Ma @ Mv
    Mj = Mj @ Ma
    for M in (Mv, Ma, Mj):
        M.setflags(write=False)
    return Mv, Ma, Mj


def boundary_points(q: np.ndarray, v: np.ndarray, a: np.ndarray, dt: float, num_seg: int) -> np.ndarray:
    """The first three control points (3, D) that start the spline at position ``q`` [m],
    velocity ``v`` [m/s] and acceleration ``a`` [m/s^2]."""
    t = knots(num_seg, dt)
    c1 = q + v * (t[4] - t[1]) / 3.0
    v1 = v + a * (t[4] - t[2]) / 2.0
    c2 = c1 + v1 * (t[5] - t[2]) / 3.0
    return np.stack([q, c1, c2])


def position(ctrl: np.ndarray, dt: float, tau: np.ndarray) -> np.ndarray:
    """Position (T, D) [m] at times ``tau`` [s] from the start: :func:`evaluate`'s first array, the
    same numbers, without building the two derivative splines (a third of the cost)."""
    num_seg = ctrl.shape[0] - 3
    tc = np.clip(np.asarray(tau, dtype=float), 0.0, dt * num_seg)
    return BSpline(knots(num_seg, dt), ctrl, 3, extrapolate=False)(tc)


def evaluate(ctrl: np.ndarray, dt: float, tau: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Position, velocity and acceleration at times ``tau`` [s] from the start; before the start
    and after the end the spline holds its end points at rest (the ends are at rest when the
    last three control points are equal). Returns three (T, D) arrays [m, m/s, m/s^2]."""
    num_seg = ctrl.shape[0] - 3
    T = dt * num_seg
    tau = np.asarray(tau, dtype=float)
    tc = np.clip(tau, 0.0, T)
    spl = BSpline(knots(num_seg, dt), ctrl, 3, extrapolate=False)
    q = spl(tc)
    v = spl.derivative(1)(tc)
    a = spl.derivative(2)(tc)
    out = (tau < 0.0) | (tau > T)
    if np.any(out):
        v[out] = 0.0
        a[out] = 0.0
    return q, v, a


@functools.cache
def bezier_matrices(num_seg: int) -> np.ndarray:
    """(S, 4, 4): the Bézier control points of segment ``s`` are ``M[s] @ C[s:s+4]``. Their hull
    holds the segment too and is tighter than the hull of ``C[s:s+4]`` (MADER's ``basis: BEZIER``).
    Found exactly: the segment's basis functions at u = 0, 1/3, 2/3, 1, mapped through the inverse
    cubic Bernstein matrix (the matrices do not depend on the span duration)."""
    t = knots(num_seg, 1.0)
    u = np.array([0.0, 1.0, 2.0, 3.0]) / 3.0
    bern = np.stack([(1 - u) ** 3, 3 * u * (1 - u) ** 2, 3 * u**2 * (1 - u), u**3], axis=1)
    out = np.empty((num_seg, 4, 4))
    for s in range(num_seg):
        x = s + u
        x[-1] = min(x[-1], num_seg - 1e-12)  # the right end of the last span, inside the base interval
        vals = BSpline.design_matrix(x, t, 3).toarray()[:, s: s + 4]  # (4 times, 4 control points)
        out[s] = np.linalg.solve(bern, vals)
    out.setflags(write=False)
    return out
