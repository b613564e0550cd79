"""Uniform cubic B-splines, and the ESDF-based spline optimisation of the SPH paper (Section III-B),
eqs. (7)-(12).

A trajectory is ``K + 1`` control points ``C_0 .. C_K`` (rows of a (K + 1, D) array) with knot
span ``dt_knot`` [s] (``beta = 1 / dt_knot`` in eq. 12). The first and last three control points
are fixed by the boundary states (eq. 12); the interior ones ``C_3 .. C_{K-3}`` are optimised
with L-BFGS (compiled) on ``lambda_s J_s + lambda_c J_c + lambda_f J_f`` (eq. 8), every term with its
analytic gradient. Everything works in any dimension D; the compiled cost reads a 2-D ESDF
(bilinear) or a 3-D one (trilinear), chosen by the dimension of the field's value array.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np
from numba import njit

from swarmnav.planning.lbfgs import direction as lbfgs_direction

from swarmnav.sensing.esdf import Esdf, esdf3d_query_kernel, esdf_query_kernel

#: Uniform cubic B-spline basis: position on segment s at local u in [0, 1) is
#: ``[1, u, u^2, u^3] @ M @ C[s:s + 4]``.
BASIS = np.array([[1.0, 4.0, 1.0, 0.0], [-3.0, 0.0, 3.0, 0.0], [3.0, -6.0, 3.0, 0.0], [-1.0, 3.0, -3.0, 1.0]]) / 6.0

#: ESDF lookup: (M, D) points -> (distance (M,), gradient (M, D)).
DistanceField = Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]


@dataclass(frozen=True, slots=True)
class SplineCosts:
    """Weights and limits of eq. (8)-(11)."""

    lambda_s: float  # smoothness weight, Table I
    lambda_c: float  # collision weight, Table I
    lambda_f: float  # feasibility weight, Table I
    d_thr: float  # ESDF safety threshold [m], Table I
    v_max: float  # [m/s]
    a_max: float  # [m/s^2]


def boundary_points(q: np.ndarray, v: np.ndarray, a: np.ndarray, dt_knot: float) -> np.ndarray:
    """The three control points that give position, velocity and acceleration ``q, v, a``
    at a spline end: the inverse of eq. (12),

        C_0 = q + a dt^2 / 3 - v dt,   C_1 = q - a dt^2 / 6,   C_2 = q + a dt^2 / 3 + v dt.

    Returns (3, D), in the order ``C_0, C_1, C_2`` (resp. ``C_{K-2}, C_{K-1}, C_K``).
    """
    t2 = dt_knot * dt_knot
    return np.stack([q + a * t2 / 3.0 - v * dt_knot, q - a * t2 / 6.0, q + a * t2 / 3.0 + v * dt_knot])


def boundary_matrix(dt_knot: float) -> np.ndarray:
    """The matrix of eq. (12) with ``beta = 1 / dt_knot``: maps ``[C_0; C_1; C_2]`` to ``[q; v; a]``."""
    b = 1.0 / dt_knot
    return np.array([[1 / 6, 2 / 3, 1 / 6], [-b / 2, 0.0, b / 2], [b * b, -2 * b * b, b * b]])


def evaluate(ctrl: np.ndarray, dt_knot: float, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Position, velocity and acceleration of the spline at times ``t`` [s] from its start.

    Times past the end hold the end position with zero velocity and acceleration (the end
    state the spline was built to reach); negative times clamp to 0.

    Returns three (T, D) arrays [m, m/s, m/s^2].
    """
    n_seg = ctrl.shape[0] - 3
    t = np.asarray(t, dtype=float)
    s_f = np.clip(t / dt_knot, 0.0, n_seg)
    seg = np.minimum(np.floor(s_f).astype(int), n_seg - 1)
    u = s_f - seg
    U = np.stack([np.ones_like(u), u, u * u, u * u * u], axis=1)  # (T, 4)
    dU = np.stack([np.zeros_like(u), np.ones_like(u), 2 * u, 3 * u * u], axis=1) / dt_knot
    ddU = np.stack([np.zeros_like(u), np.zeros_like(u), 2 * np.ones_like(u), 6 * u], axis=1) / dt_knot**2
    win = ctrl[seg[:, None] + np.arange(4)[None, :]]  # (T, 4, D)
    mc = np.einsum("kl,tld->tkd", BASIS, win)  # (T, 4, D) polynomial coefficients
    q = np.einsum("tk,tkd->td", U, mc)
    v = np.einsum("tk,tkd->td", dU, mc)
    a = np.einsum("tk,tkd->td", ddU, mc)
    past = t > n_seg * dt_knot
    if np.any(past):
        v[past] = 0.0
        a[past] = 0.0
    return q, v, a


def smoothness_cost(ctrl: np.ndarray) -> tuple[float, np.ndarray]:
    """Eq. (9): ``J_s = sum_i |C_{i+3} - 3 C_{i+2} + 3 C_{i+1} - C_i|^2`` and its gradient."""
    j3 = ctrl[3:] - 3.0 * ctrl[2:-1] + 3.0 * ctrl[1:-2] - ctrl[:-3]
    g = np.zeros_like(ctrl)
    t = 2.0 * j3
    g[:-3] -= t
    g[1:-2] += 3.0 * t
    g[2:-1] -= 3.0 * t
    g[3:] += t
    return float(np.sum(j3 * j3)), g


def collision_cost(points: np.ndarray, field: DistanceField, d_thr: float) -> tuple[float, np.ndarray]:
    """Eq. (10): ``J_c = sum_i F(C_i, d_thr)`` with ``F = (d - d_thr)^2`` below the threshold
    (eq. 5), and its gradient ``2 (d - d_thr) grad d`` (eq. 6), for the given control points."""
    d, gd = field(points)
    e = np.where(d < d_thr, d - d_thr, 0.0)
    e = np.where(np.isfinite(e), e, 0.0)
    return float(np.sum(e * e)), (2.0 * e)[:, None] * gd


def feasibility_cost(ctrl: np.ndarray, dt_knot: float, v_max: float, a_max: float) -> tuple[float, np.ndarray]:
    """Eq. (11): per axis j, ``G(V_ij^2 - v_max^2) + G(A_ij^2 - a_max^2)`` with
    ``G(x) = max(x, 0)^2``, ``V_i = (C_{i+1} - C_i) / dt``, ``A_i = (V_{i+1} - V_i) / dt``."""
    V = np.diff(ctrl, axis=0) / dt_knot
    A = np.diff(V, axis=0) / dt_knot
    xv = np.maximum(V * V - v_max * v_max, 0.0)
    xa = np.maximum(A * A - a_max * a_max, 0.0)
    gV = 4.0 * xv * V  # d G / d V
    gA = 4.0 * xa * A
    g = np.zeros_like(ctrl)
    # A_i = (C_{i+2} - 2 C_{i+1} + C_i) / dt^2, V_i = (C_{i+1} - C_i) / dt
    g[1:] += gV / dt_knot
    g[:-1] -= gV / dt_knot
    t2 = dt_knot * dt_knot
    g[2:] += gA / t2
    g[1:-1] -= 2.0 * gA / t2
    g[:-2] += gA / t2
    return float(np.sum(xv * xv) + np.sum(xa * xa)), g


def total_cost(ctrl: np.ndarray, dt_knot: float, field: DistanceField, w: SplineCosts) -> tuple[float, np.ndarray]:
    """Eq. (8) on all control points; the collision term covers ``C_3 .. C_{K-3}`` (eq. 10,
    ``i = p .. K - p``). Returns the cost and its gradient with respect to every point."""
    js, gs = smoothness_cost(ctrl)
    jf, gf = feasibility_cost(ctrl, dt_knot, w.v_max, w.a_max)
    g = w.lambda_s * gs + w.lambda_f * gf
    cost = w.lambda_s * js + w.lambda_f * jf
    if ctrl.shape[0] > 6:
        jc, gc = collision_cost(ctrl[3:-3], field, w.d_thr)
        cost += w.lambda_c * jc
        g[3:-3] += w.lambda_c * gc
    return cost, g


@dataclass(frozen=True, slots=True)
class SplinePlan:
    """An optimised trajectory: control points, knot span, optimiser iterations."""

    ctrl: np.ndarray  # (K + 1, D) [m]
    dt_knot: float  # [s]
    iterations: int

    @property
    def duration(self) -> float:
        return (self.ctrl.shape[0] - 3) * self.dt_knot

    def sample(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Position, velocity and acceleration at times ``t`` [s] from the start (:func:`evaluate`)."""
        return evaluate(self.ctrl, self.dt_knot, t)


def optimize(
    start: tuple[np.ndarray, np.ndarray, np.ndarray],
    end: tuple[np.ndarray, np.ndarray, np.ndarray],
    guide: np.ndarray,
    dt_knot: float,
    esdf: Esdf,
    w: SplineCosts,
    max_iter: int = 200,
) -> SplinePlan:
    """Optimise the interior control points of a D-dimensional spline (D = 2 or 3, the ESDF's)
    between two boundary states.

    Args:
        start, end: ``(q, v, a)`` boundary states (eq. 12).
        guide: (M, D) initial interior control points ``C_3 .. C_{K-3}`` (the grid-search
            path resampled at the control-point spacing); M may be 0.
        dt_knot: knot span [s].
        esdf: the distance field of eq. (10).
        max_iter: L-BFGS iteration cap.

    The cost of eq. (8) and its gradient are the numpy functions above, compiled together
    with the L-BFGS loop (:func:`_lbfgs_spline`) so one plan costs well under a millisecond.
    """
    head = boundary_points(*start, dt_knot)
    tail = boundary_points(*end, dt_knot)
    guide = np.asarray(guide, dtype=float).reshape(-1, head.shape[1])
    ctrl = np.ascontiguousarray(np.vstack([head, guide, tail]))
    if len(guide) == 0:
        return SplinePlan(ctrl, dt_knot, 0)
    nit = _lbfgs_spline(ctrl, dt_knot, w.lambda_s, w.lambda_c, w.lambda_f, w.d_thr, w.v_max, w.a_max,
                        np.ascontiguousarray(esdf.values), np.asarray(esdf.origin, dtype=np.float64),
                        float(esdf.resolution), int(max_iter))
    return SplinePlan(ctrl, dt_knot, int(nit))


@njit(cache=True)
def _cost_grad(ctrl, dt, lam_s, lam_c, lam_f, d_thr, v_max, a_max, values, origin, res, pts, dist, dgrad, grad):
    """Eq. (8) = lambda_s (9) + lambda_c (10) + lambda_f (11) and its gradient (into ``grad``),
    the loop form of :func:`total_cost`; ``values`` is a (ny, nx) or (nz, ny, nx) ESDF whose node
    0 sits at ``origin``."""
    n, dim = ctrl.shape
    grad[:, :] = 0.0
    js = 0.0
    for i in range(n - 3):
        for d in range(dim):
            j3 = ctrl[i + 3, d] - 3.0 * ctrl[i + 2, d] + 3.0 * ctrl[i + 1, d] - ctrl[i, d]
            js += j3 * j3
            t = 2.0 * lam_s * j3
            grad[i, d] -= t
            grad[i + 1, d] += 3.0 * t
            grad[i + 2, d] -= 3.0 * t
            grad[i + 3, d] += t
    jf = 0.0
    inv = 1.0 / dt
    inv2 = inv * inv
    for i in range(n - 1):
        for d in range(dim):
            v = (ctrl[i + 1, d] - ctrl[i, d]) * inv
            x = v * v - v_max * v_max
            if x > 0.0:
                jf += x * x
                gv = 4.0 * lam_f * x * v * inv
                grad[i + 1, d] += gv
                grad[i, d] -= gv
    for i in range(n - 2):
        for d in range(dim):
            a = (ctrl[i + 2, d] - 2.0 * ctrl[i + 1, d] + ctrl[i, d]) * inv2
            x = a * a - a_max * a_max
            if x > 0.0:
                jf += x * x
                ga = 4.0 * lam_f * x * a * inv2
                grad[i + 2, d] += ga
                grad[i + 1, d] -= 2.0 * ga
                grad[i, d] += ga
    jc = 0.0
    m = n - 6
    if m > 0:
        for k in range(m):
            for d in range(dim):
                pts[k, d] = ctrl[k + 3, d]
        if values.ndim == 2:  # resolved at compile time: one specialisation per dimension
            esdf_query_kernel(values, origin[0], origin[1], res, pts, dist, dgrad)
        else:
            esdf3d_query_kernel(values, origin[0], origin[1], origin[2], res, pts, dist, dgrad)
        for k in range(m):
            e = dist[k] - d_thr
            if e < 0.0 and math.isfinite(e):
                jc += e * e
                for d in range(dim):
                    grad[k + 3, d] += 2.0 * lam_c * e * dgrad[k, d]
    return lam_s * js + lam_c * jc + lam_f * jf


@njit(cache=True, nogil=True)  # releases the GIL: robots' plans may be optimised in parallel threads
def _lbfgs_spline(ctrl, dt, lam_s, lam_c, lam_f, d_thr, v_max, a_max, values, origin, res, max_iter):
    """L-BFGS (Nocedal & Wright, Alg. 7.4/7.5) on the interior rows ``ctrl[3:-3]``, in place.

    Two-loop recursion over the last 10 curvature pairs with the ``s'y / y'y`` initial
    scaling, backtracking line search to the Armijo condition (c1 = 1e-4), pairs with
    ``s'y <= 0`` skipped. Stops when no control point moves more than 1e-4 m in an iteration
    (the released planner's nlopt ``xtol_rel = 1e-5`` at ~10 m coordinates), the gradient
    vanishes, or after ``max_iter`` iterations. Returns the iteration count.

    Unbounded: the released code's +-10 m box around the initial guess never binds for
    trajectories that stay within a few metres of their grid-search path.
    """
    n, dim = ctrl.shape
    m = n - 6
    nv = m * dim
    mem = 10
    S = np.zeros((mem, nv))
    Y = np.zeros((mem, nv))
    rho = np.zeros(mem)
    alpha = np.zeros(mem)
    pts = np.empty((m, dim))
    dist = np.empty(m)
    dgrad = np.empty((m, dim))
    G = np.empty((n, dim))
    x = np.empty(nv)
    for k in range(nv):
        x[k] = ctrl[3 + k // dim, k % dim]
    f = _cost_grad(ctrl, dt, lam_s, lam_c, lam_f, d_thr, v_max, a_max, values, origin, res, pts, dist, dgrad, G)
    g = np.empty(nv)
    for k in range(nv):
        g[k] = G[3 + k // dim, k % dim]
    count = 0
    head = 0
    it = 0
    x_new = np.empty(nv)
    g_new = np.empty(nv)
    while it < max_iter:
        gmax = 0.0
        for k in range(nv):
            gmax = max(gmax, abs(g[k]))
        if gmax <= 1e-9:
            break
        it += 1
        q = lbfgs_direction(g, S, Y, rho, alpha, head, count, mem, 1.0)  # first step at most 1.0 m
        slope = -np.dot(g, q)
        if slope >= 0.0:  # not a descent direction: restart from steepest descent
            count = 0
            q = g.copy()
            slope = -np.dot(g, g)
        step = 1.0
        accepted = False
        f_new = f
        for _ in range(40):
            for k in range(nv):
                x_new[k] = x[k] - step * q[k]
                ctrl[3 + k // dim, k % dim] = x_new[k]
            f_new = _cost_grad(ctrl, dt, lam_s, lam_c, lam_f, d_thr, v_max, a_max, values, origin, res,
                               pts, dist, dgrad, G)
            if f_new <= f + 1e-4 * step * slope:
                accepted = True
                break
            step *= 0.5
        if not accepted:  # no decrease along the direction: converged to rounding
            for k in range(nv):
                ctrl[3 + k // dim, k % dim] = x[k]
            break
        move = 0.0
        sy = 0.0
        for k in range(nv):
            g_new[k] = G[3 + k // dim, k % dim]
            move = max(move, abs(x_new[k] - x[k]))
            sy += (x_new[k] - x[k]) * (g_new[k] - g[k])
        if sy > 1e-12:
            for k in range(nv):
                S[head, k] = x_new[k] - x[k]
                Y[head, k] = g_new[k] - g[k]
            rho[head] = 1.0 / sy
            head = (head + 1) % mem
            count = min(count + 1, mem)
        x[:] = x_new
        g[:] = g_new
        f = f_new
        if move < 1e-4:
            break
    return it
