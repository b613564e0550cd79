"""The LSC planner's convex problem: piecewise Bernstein polynomials, their constraint matrices,
the linear safe corridor between two agents, and one OSQP solve per robot per replan.

A robot's plan is ``M`` segments of duration ``h`` [s], each a Bernstein polynomial of degree
``n`` with control points ``c[m, k]`` (k = 0..n) in ``D`` dimensions:

    p(t) = sum_k c[m, k] b_{k,n}((t - m h) / h),  b_{k,n}(s) = C(n, k) s^k (1 - s)^(n - k)

(Park, Kim et al., RA-L 2022, Section III). The decision variable is every control point,
``x[(m (n + 1) + k) D + d]``. Derivatives of a Bernstein polynomial are Bernstein polynomials of
lower degree whose control points are differences of the control points; by the convex-hull
property, a bound on every control point bounds the whole curve. That is what turns the paper's
constraints into linear ones:

- the initial state (position, velocity, acceleration at t = 0) and continuity of the
  derivatives 0..``continuity`` between segments: equalities;
- the robot stops at the end of the horizon (velocity and acceleration zero), which makes the
  previous plan, shifted by one segment, a feasible point of the next problem (the paper's
  feasibility guarantee);
- the safe flight corridor (SFC): segment m's control points inside an obstacle-free box;
- the linear safe corridor (LSC) with agent j, segment m: ``n . c[m, k] <= n . mid[k] - d``;
- velocity and acceleration bounds on the derivative control points.

The cost is the paper's: the squared error of the last control point to the (sub)goal plus a
weight times the integral of the squared ``phi``-th derivative (jerk), both quadratic in ``x``.
"""

from __future__ import annotations

import contextlib
import math
import os
import sys
from dataclasses import dataclass

import numpy as np
import osqp
import scipy.sparse as sp
from scipy.linalg import null_space
from scipy.optimize import nnls


# ------------------------------------------------------------------ Bernstein basis

def bernstein(n: int, s: np.ndarray) -> np.ndarray:
    """Bernstein basis of degree ``n`` at parameters ``s`` in [0, 1]: (len(s), n + 1)."""
    s = np.asarray(s, dtype=float).reshape(-1, 1)
    k = np.arange(n + 1)
    binom = np.array([math.comb(n, i) for i in k], dtype=float)
    return binom * s**k * (1.0 - s) ** (n - k)


def difference(n: int, order: int) -> np.ndarray:
    """(n + 1 - order, n + 1): control points of the ``order``-th derivative of a degree-``n``
    Bernstein polynomial on a unit interval from its control points (repeated forward
    differences times n (n - 1) ... (n - order + 1))."""
    D = np.eye(n + 1)
    for r in range(order):
        deg = n - r
        D = deg * (D[1:] - D[:-1])
    return D


def derivative_basis(n: int, order: int, s: np.ndarray, h: float) -> np.ndarray:
    """(len(s), n + 1): the ``order``-th time derivative [per s^order] of a segment of duration
    ``h`` at parameters ``s``, as weights on its control points."""
    return bernstein(n - order, s) @ difference(n, order) / h**order


def evaluate(ctrl: np.ndarray, h: float, tau: np.ndarray, order: int = 0) -> np.ndarray:
    """The ``order``-th derivative of a piecewise Bernstein plan ``ctrl`` (M, n + 1, D) at times
    ``tau`` [s] from its start: (len(tau), D). Beyond the end it holds its last state (zero
    derivatives), before the start its first."""
    M, n1, D = ctrl.shape
    n = n1 - 1
    tau = np.asarray(tau, dtype=float).reshape(-1)
    T = M * h
    after = tau >= T
    t = np.clip(tau, 0.0, T)
    m = np.minimum((t / h).astype(np.int64), M - 1)
    s = np.clip(t / h - m, 0.0, 1.0)
    W = derivative_basis(n, order, s, h)  # (L, n + 1)
    out = np.einsum("lk,lkd->ld", W, ctrl[m])
    if order > 0:
        out[after] = 0.0
    return out


def jerk_hessian(n: int, h: float, phi: int) -> np.ndarray:
    """(n + 1, n + 1) matrix Q with ``c^T Q c = integral over the segment of |d^phi p / dt^phi|^2``
    per axis (Gauss-Legendre quadrature, exact for this polynomial degree)."""
    xg, wg = np.polynomial.legendre.leggauss(n + 1)
    s = 0.5 * (xg + 1.0)
    W = derivative_basis(n, phi, s, h)
    return h * 0.5 * (W.T * wg) @ W


# ------------------------------------------------------------------ linear safe corridor

def closest_hull_point(points: np.ndarray) -> np.ndarray:
    """The point of the convex hull of ``points`` (K, D) nearest the origin (a least-squares
    problem over the simplex, solved exactly by NNLS with the affine row weighted heavily)."""
    K = points.shape[0]
    scale = max(float(np.abs(points).max()), 1.0)
    w = 1e3 * scale
    A = np.vstack([points.T, w * np.ones((1, K))])
    b = np.concatenate([np.zeros(points.shape[1]), [w]])
    lam, _ = nnls(A, b)
    lam = lam / max(lam.sum(), 1e-300)
    return lam @ points


def lsc_plane(prev_i: np.ndarray, prev_j: np.ndarray, radius: float, fallback: np.ndarray):
    """The linear safe corridor of agent i against agent j over one segment.

    ``prev_i``, ``prev_j``: (n + 1, D) control points of both agents' previous plans over the
    segment. The normal ``nrm`` is the unit vector to the point of the hull of the relative
    control points ``prev_j - prev_i`` nearest the origin (``fallback`` when that point is the
    origin itself). Agent i keeps ``nrm . c[k] <= nrm . (prev_i[k] + prev_j[k]) / 2 - d`` with
    ``d = min(radius, gap / 2)``, ``gap = min_k nrm . (prev_j[k] - prev_i[k])``; agent j keeps the
    mirror image (``-nrm``). Both previous plans satisfy their sides (``d <= gap / 2``), and any
    two plans that do are apart along ``nrm`` by ``2 d`` at every time of the segment (the
    relative Bernstein polynomial lies in the hull of its control points). ``radius`` is
    (r_i + r_j) / 2. Returns (nrm (D,), rhs (n + 1,), gap).
    """
    rel = prev_j - prev_i
    c = closest_hull_point(rel)
    norm = float(np.linalg.norm(c))
    nrm = c / norm if norm > 1e-9 else fallback / max(float(np.linalg.norm(fallback)), 1e-12)
    gap = float(np.min(rel @ nrm))
    d = min(radius, 0.5 * gap)
    rhs = 0.5 * (prev_i + prev_j) @ nrm - d
    return nrm, rhs, gap


# ------------------------------------------------------------------ the QP

def limit_directions(dim: int, kind: str) -> tuple[np.ndarray, float]:
    """Directions ``u`` (K, D) and a factor ``f``: a derivative control point ``w`` is bounded by
    ``u . w <= f * limit`` for every u. ``axis`` (the paper): the coordinate axes, f = 1 (each
    axis within the limit). ``norm`` (ours): a polygon (2-D, 8 sides) or polyhedron (3-D, the
    14 directions of a cube's faces and corners) inscribed in the ball of that radius, so the
    plan keeps within the Euclidean bound the shared dynamics enforce (8 and 14 rows per point
    rather than 16 and 26: the QP's time grows with its rows; the polygon gives up 8 % of the
    speed)."""
    if kind == "axis":
        return np.vstack([np.eye(dim), -np.eye(dim)]), 1.0
    if dim == 2:
        a = 2 * math.pi * np.arange(8) / 8
        return np.stack([np.cos(a), np.sin(a)], axis=1), math.cos(math.pi / 8)
    g = np.array([(i, j, k) for i in (-1, 0, 1) for j in (-1, 0, 1) for k in (-1, 0, 1)
                  if (i, j, k) != (0, 0, 0) and abs(i) + abs(j) + abs(k) != 2], float)
    u = g / np.linalg.norm(g, axis=1, keepdims=True)
    # circumradius of {w: u . w <= 1}: the largest 1 / max_k u_k . w over a dense set of unit w
    m = 20000
    z = 1 - 2 * (np.arange(m) + 0.5) / m
    th = math.pi * (3 - math.sqrt(5)) * np.arange(m)
    w = np.stack([np.sqrt(1 - z * z) * np.cos(th), np.sqrt(1 - z * z) * np.sin(th), z], axis=1)
    R = float(np.max(1.0 / np.max(w @ u.T, axis=1)))
    return u, 0.999 / R


@dataclass(frozen=True, slots=True)
class Problem:
    """One robot's QP. Shapes: ``boxes`` (M, 2, D) SFC per segment; ``lsc_seg`` (P,) segment of
    each LSC plane, ``lsc_n`` (P, D), ``lsc_rhs`` (P, n + 1)."""

    M: int
    n: int
    h: float  # [s] segment duration
    q0: np.ndarray  # (D,) [m] initial position
    v0: np.ndarray  # (D,) [m/s]
    a0: np.ndarray  # (D,) [m/s^2]
    goal: np.ndarray  # (D,) [m] the (sub)goal the last point is drawn to
    boxes: np.ndarray
    lsc_seg: np.ndarray
    lsc_n: np.ndarray
    lsc_rhs: np.ndarray
    v_max: float
    a_max: float
    limits: str = "axis"
    w_goal: float = 1.0
    w_jerk: float = 0.01
    phi: int = 3
    continuity: int = 2

    @property
    def dim(self) -> int:
        return self.q0.shape[0]

    @property
    def nvar(self) -> int:
        return self.M * (self.n + 1) * self.dim


def _var(m, k, d, n1, D):
    return (m * n1 + k) * D + d


def assemble(pb: Problem):
    """The QP ``min 1/2 x^T P x + q^T x  s.t.  l <= A x <= u`` as (P, q, A, l, u, kinds), P and A
    sparse (CSC); ``kinds`` (rows,) names each row's block: 0 initial state, 1 continuity,
    2 terminal rest, 3 SFC, 4 velocity, 5 acceleration, 6 LSC."""
    M, n, h, D = pb.M, pb.n, pb.h, pb.dim
    n1 = n + 1
    N = pb.nvar
    # cost: w_jerk sum_m c_m^T Q c_m (per axis) + w_goal |c[M-1, n] - g|^2
    Q = jerk_hessian(n, h, pb.phi)
    Pd = pb.w_jerk * np.kron(np.eye(M), np.kron(Q, np.eye(D)))
    last = np.array([_var(M - 1, n, d, n1, D) for d in range(D)])
    Pd[last, last] += pb.w_goal
    q = np.zeros(N)
    q[last] = -pb.w_goal * pb.goal
    P = sp.csc_matrix(2.0 * np.triu(Pd))  # OSQP: 1/2 x^T P x, upper triangle
    q = 2.0 * q
    rows, lo, hi, kinds = [], [], [], []

    def add(block: np.ndarray, l, u, kind: int):
        rows.append(block)
        lo.append(np.broadcast_to(l, block.shape[0]).astype(float))
        hi.append(np.broadcast_to(u, block.shape[0]).astype(float))
        kinds.append(np.full(block.shape[0], kind))

    start = [derivative_basis(n, r, np.array([0.0]), h)[0] for r in range(3)]
    end = [derivative_basis(n, r, np.array([1.0]), h)[0] for r in range(max(3, pb.continuity + 1))]
    begin = [derivative_basis(n, r, np.array([0.0]), h)[0] for r in range(max(3, pb.continuity + 1))]
    # initial state
    for r, val in enumerate((pb.q0, pb.v0, pb.a0)):
        blk = np.zeros((D, N))
        for d in range(D):
            blk[d, [_var(0, k, d, n1, D) for k in range(n1)]] = start[r]
        add(blk, val, val, 0)
    # continuity of derivatives 0..continuity between segments
    for m in range(M - 1):
        for r in range(pb.continuity + 1):
            blk = np.zeros((D, N))
            for d in range(D):
                blk[d, [_var(m, k, d, n1, D) for k in range(n1)]] = end[r]
                blk[d, [_var(m + 1, k, d, n1, D) for k in range(n1)]] -= begin[r]
            add(blk, 0.0, 0.0, 1)
    # at rest at the end of the horizon
    for r in (1, 2):
        blk = np.zeros((D, N))
        for d in range(D):
            blk[d, [_var(M - 1, k, d, n1, D) for k in range(n1)]] = end[r]
        add(blk, 0.0, 0.0, 2)
    # SFC: every control point of segment m inside its box
    lo_box = np.repeat(pb.boxes[:, 0, :], n1, axis=0).reshape(-1)
    hi_box = np.repeat(pb.boxes[:, 1, :], n1, axis=0).reshape(-1)
    add(np.eye(N), lo_box, hi_box, 3)
    # velocity and acceleration: derivative control points within the bound
    u, f = limit_directions(D, pb.limits)
    for r, lim, kind in ((1, pb.v_max, 4), (2, pb.a_max, 5)):
        Dr = difference(n, r) / h**r  # (n + 1 - r, n + 1)
        for m in range(M):
            # derivative control point j along direction u: sum_k Dr[j, k] u . c[m, k]
            blk = np.zeros((Dr.shape[0] * u.shape[0], N))
            for j in range(Dr.shape[0]):
                for k in range(n1):
                    for d in range(D):
                        blk[j * u.shape[0]:(j + 1) * u.shape[0], _var(m, k, d, n1, D)] = Dr[j, k] * u[:, d]
            add(blk, -np.inf, f * lim, kind)
    # LSC: n . c[m, k] <= rhs[k]
    if len(pb.lsc_seg):
        P_ = len(pb.lsc_seg)
        blk = np.zeros((P_ * n1, N))
        for p in range(P_):
            m = int(pb.lsc_seg[p])
            for k in range(n1):
                blk[p * n1 + k, [_var(m, k, d, n1, D) for d in range(D)]] = pb.lsc_n[p]
        add(blk, -np.inf, pb.lsc_rhs.reshape(-1), 6)
    A = sp.csc_matrix(np.vstack(rows))
    return P, q, A, np.concatenate(lo), np.concatenate(hi), np.concatenate(kinds)


@dataclass(frozen=True, slots=True)
class Result:
    ctrl: np.ndarray | None  # (M, n + 1, D) control points, None on failure
    status: str
    violation: float  # [m, m/s, ...] largest constraint violation of the returned point
    iterations: int


@dataclass(frozen=True, slots=True)
class _Structure:
    """What a problem's matrices hold that depends only on its structure (M, n, h, D, weights,
    bounds): kept per structure, so a replan assembles only its SFC, LSC and right-hand sides."""

    P: np.ndarray  # (N, N) symmetric cost Hessian (OSQP's 1/2 x^T P x)
    last: np.ndarray  # (D,) variables of the plan's last control point
    Ae_pinv: np.ndarray  # pseudo-inverse of the equality rows
    n_eq: int
    T: np.ndarray  # (N, r) null-space basis of the equalities with T^T P T = I
    A_dyn: np.ndarray  # (R, N) velocity and acceleration rows
    u_dyn: np.ndarray  # (R,) their upper bounds
    A_dyn_T: np.ndarray  # A_dyn @ T


_STRUCTURES: dict[tuple, _Structure] = {}


def structure(pb: Problem) -> _Structure:
    """The cached :class:`_Structure` of ``pb`` (built from :func:`assemble`, the plain reference)."""
    key = (pb.M, pb.n, pb.h, pb.dim, pb.continuity, pb.phi, pb.w_goal, pb.w_jerk, pb.v_max, pb.a_max, pb.limits)
    got = _STRUCTURES.get(key)
    if got is None:
        D = pb.dim
        bare = Problem(pb.M, pb.n, pb.h, np.zeros(D), np.zeros(D), np.zeros(D), np.zeros(D),
                       np.zeros((pb.M, 2, D)), np.zeros(0, np.int64), np.zeros((0, D)), np.zeros((0, pb.n + 1)),
                       pb.v_max, pb.a_max, pb.limits, pb.w_goal, pb.w_jerk, pb.phi, pb.continuity)
        P, _, A, _, u, kinds = assemble(bare)
        P = P.toarray()
        P = P + np.triu(P, 1).T
        A = A.toarray()
        eq = kinds <= 2
        Z = null_space(A[eq])
        lam, V = np.linalg.eigh(Z.T @ P @ Z)
        # w_jerk = 0 leaves directions the cost does not see: they get a unit weight on |w|^2
        # there (a tiny regularisation towards the particular solution) instead of a division by 0
        lam = np.maximum(lam, 1e-9 * max(float(lam.max()), 1e-300))
        T = Z @ V / np.sqrt(lam)
        dyn = (kinds == 4) | (kinds == 5)
        n1 = pb.n + 1
        last = np.array([_var(pb.M - 1, pb.n, d, n1, D) for d in range(D)])
        got = _Structure(P, last, np.linalg.pinv(A[eq]), int(eq.sum()), T, A[dyn], u[dyn], A[dyn] @ T)
        if len(_STRUCTURES) > 16:
            _STRUCTURES.clear()
        _STRUCTURES[key] = got
    return got


@contextlib.contextmanager
def _quiet_stdout():
    """File descriptor 1 to /dev/null: OSQP 1.1's polishing prints "Polishing not needed" from C
    even with verbose=False (its only message then)."""
    try:
        sys.stdout.flush()
        fd = sys.stdout.fileno()
    except (AttributeError, OSError, ValueError):  # no real stdout (captured): nothing to silence
        yield
        return
    saved = os.dup(fd)
    null = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(null, fd)
        yield
    finally:
        os.dup2(saved, fd)
        os.close(saved)
        os.close(null)


def solve(pb: Problem, eps: float = 1e-5, max_iter: int = 4000, tol: float = 2e-3) -> Result:
    """Solve the QP with OSQP; a solution whose constraint violation exceeds ``tol``, or any
    status but solved, is a failure (``ctrl`` None), never an exception or NaN.

    The equalities (initial state, continuity, rest at the end) are eliminated first: ``x = x_p +
    T w`` with ``T`` whitening the cost on their null space, so OSQP sees an identity Hessian
    and only the inequalities. The jerk weight makes the cost's Hessian ill-conditioned
    (condition number ~1e5 on that null space): ADMM on the raw problem needed thousands of
    iterations, whitened it needs tens to hundreds. The rows are those of :func:`assemble`
    (tests/methods/lsc compares them)."""
    st = structure(pb)
    D, n1 = pb.dim, pb.n + 1
    be = np.zeros(st.n_eq)
    be[:3 * D] = np.concatenate([pb.q0, pb.v0, pb.a0])
    xp = st.Ae_pinv @ be
    q = np.zeros(pb.nvar)
    q[st.last] = -2.0 * pb.w_goal * pb.goal
    T = st.T
    # SFC rows are the identity; the LSC rows act on one control point each
    lo_box = np.repeat(pb.boxes[:, 0, :], n1, axis=0).reshape(-1)
    hi_box = np.repeat(pb.boxes[:, 1, :], n1, axis=0).reshape(-1)
    Tm = T.reshape(pb.M, n1, D, -1)
    A_lsc_T = np.einsum("pd,pkdr->pkr", pb.lsc_n, Tm[pb.lsc_seg]).reshape(-1, T.shape[1])
    xp_m = xp.reshape(pb.M, n1, D)
    lsc_xp = np.einsum("pd,pkd->pk", pb.lsc_n, xp_m[pb.lsc_seg]).reshape(-1)
    A_red = np.vstack([T, st.A_dyn_T, A_lsc_T])
    lo = np.concatenate([lo_box - xp, np.full(len(st.u_dyn), -np.inf), np.full(len(lsc_xp), -np.inf)])
    hi = np.concatenate([hi_box - xp, st.u_dyn - st.A_dyn @ xp, pb.lsc_rhs.reshape(-1) - lsc_xp])
    # rows on the control points the initial state fixes (c[0, 0..2]) are constants here: the
    # state decides them, so they are dropped (a previous solution within the solver's tolerance
    # of a bound would otherwise make the next problem infeasible by 1e-9)
    free = np.abs(A_red).max(axis=1) > 1e-9
    A_red, lo, hi = A_red[free], lo[free], hi[free]
    s = osqp.OSQP()
    s.setup(sp.identity(T.shape[1], format="csc"), T.T @ (st.P @ xp + q), sp.csc_matrix(A_red), lo, hi,
            verbose=False, eps_abs=eps, eps_rel=eps, max_iter=max_iter, polishing=True)
    with _quiet_stdout():
        res = s.solve(raise_error=False)
    status = str(res.info.status)
    w = res.x
    iters = int(res.info.iter)
    if w is None or not np.all(np.isfinite(w)):
        return Result(None, status, math.inf, iters)
    Aw = A_red @ w
    viol = float(max(np.max(lo - Aw, initial=0.0), np.max(Aw - hi, initial=0.0)))
    if viol > 0.1 * tol and res.info.status_val == osqp.SolverStatus.OSQP_SOLVED:
        # polishing found no active set: ADMM's answer is eps-accurate only; refine it warm
        s.update_settings(eps_abs=1e-3 * eps, eps_rel=1e-3 * eps)
        with _quiet_stdout():
            res = s.solve(raise_error=False)
        iters += int(res.info.iter)
        if res.x is not None and np.all(np.isfinite(res.x)):
            Aw2 = A_red @ res.x
            viol2 = float(max(np.max(lo - Aw2, initial=0.0), np.max(Aw2 - hi, initial=0.0)))
            if viol2 < viol:
                w, viol, status = res.x, viol2, str(res.info.status)
    ok = res.info.status_val in (osqp.SolverStatus.OSQP_SOLVED, osqp.SolverStatus.OSQP_SOLVED_INACCURATE)
    if not ok or viol > tol:
        return Result(None, status, viol, iters)
    return Result((xp + T @ w).reshape(pb.M, n1, D), status, viol, iters)
