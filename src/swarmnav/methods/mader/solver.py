"""MADER's optimisation (Tordesillas & How, T-RO 2021, Section V), solved with IPOPT through
CasADi (:func:`solve_ipopt`, the default), or with NLopt as the authors' open path does
(``mader.yaml``: ``solver: LD_MMA``; :func:`solve`, uniform knots only).

Decision variables: the free control points of a uniform cubic B-spline of ``num_pol``
segments, and one plane (n, d) per (segment, obstacle) pair. The first three control points
are fixed by the start state (position, velocity, acceleration); the last three are one free
point ``q_f`` (zero velocity and acceleration at the end). With ``N + 1 = num_pol + 3`` points
the free ones are ``q_3 .. q_{N-3}`` and ``q_f``.

    minimise   int ||jerk||^2 dt + weight ||q_f - G||^2
    subject to n_p . v + d_p >= 1        every vertex v of obstacle p's polyhedron,
               n_p . c + d_p <= -1       every control point c of segment s(p),
               |V_i| <= v_max, |A_i| <= a_max   per axis, on the velocity / acceleration
                                                control points (the B-spline's hull of them).

The jerk of a uniform cubic B-spline is constant on each segment, ``(C_{i+3} - 3 C_{i+2} +
3 C_{i+1} - C_i) / dt^3``, so the integral is :func:`~swarmnav.planning.bspline.smoothness_cost`
over ``dt^5``. Every constraint and its Jacobian are array expressions.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from scipy.optimize import nnls

from swarmnav.planning import clamped
from swarmnav.planning.bspline import smoothness_cost

import casadi as ca

try:  # NLopt is a declared dependency; the import is guarded so a missing wheel fails in reset, not at import
    import nlopt
except ImportError:  # pragma: no cover
    nlopt = None


@dataclass(frozen=True, slots=True)
class Problem:
    """One replan's optimisation problem (see the module docstring)."""

    start: np.ndarray  # (3, D) fixed control points C_0 .. C_2
    goal: np.ndarray  # (D,) local goal G [m]
    dt_knot: float  # [s]
    num_pol: int
    seg: np.ndarray  # (P,) segment of each plane
    verts: np.ndarray  # (P, V, D) obstacle vertices of each plane [m]
    weight: float
    v_max: float  # [m/s] per axis
    a_max: float  # [m/s^2] per axis
    radius: np.ndarray | None = None  # (P,) clearance of each plane's pair [m] (clearance=ball), None: none
    norm_limits: bool = False  # True: |V_i| <= v_max, |A_i| <= a_max in Euclidean norm (limits=norm), else per axis


@dataclass(frozen=True, slots=True)
class Result:
    ctrl: np.ndarray | None  # (N + 1, D), None if no feasible solution
    evaluations: int
    violation: float  # largest constraint value at the returned point (<= tol: feasible)
    status: str


class Mader:
    """The constraint and cost functions of one :class:`Problem`, on the flat variable vector
    ``x = [free points (F, D), n (P, D), d (P,)]``."""

    def __init__(self, pb: Problem):
        self.pb = pb
        D = pb.start.shape[1]
        N = pb.num_pol + 2  # index of the last control point
        F = pb.num_pol - 2  # free points: q_3 .. q_{N-3}, q_f
        P = len(pb.seg)
        V = pb.verts.shape[1] if P else 0
        self.D, self.N, self.F, self.P, self.V = D, N, F, P, V
        cmap = np.full(N + 1, -1)
        cmap[3: N - 2] = np.arange(F - 1)
        cmap[N - 2:] = F - 1
        self.cmap = cmap
        self.off_n = F * D
        self.off_d = F * D + P * D
        self.nvar = self.off_d + P
        # ctrl = B x_free + c_fixed, (N + 1) x F selection
        B = np.zeros((N + 1, F))
        B[cmap >= 0, cmap[cmap >= 0]] = 1.0
        self.B = B
        fixed = np.zeros((N + 1, D))
        fixed[:3] = pb.start
        self.fixed = fixed
        # linear velocity / acceleration rows that depend on a free point
        dt = pb.dt_knot
        Mv = (np.eye(N + 1, k=1) - np.eye(N + 1))[:N] / dt  # V_i = (C_{i+1} - C_i) / dt
        Ma = np.zeros((N - 1, N + 1))
        for i in range(N - 1):
            Ma[i, i], Ma[i, i + 1], Ma[i, i + 2] = 1.0 / dt**2, -2.0 / dt**2, 1.0 / dt**2
        rows, bounds = [], []
        for M, bound in ((Mv, pb.v_max), (Ma, pb.a_max)):
            MB = M @ B
            keep = np.any(np.abs(MB) > 1e-12, axis=1)
            rows.append((M[keep], MB[keep]))
            bounds.append(np.full(int(keep.sum()), bound))
        M = np.vstack([r[0] for r in rows])
        MB = np.vstack([r[1] for r in rows])
        b = np.concatenate(bounds)
        # per axis, both signs: rows (2 L D)
        L = len(b)
        Alin = np.zeros((2 * L * D, self.nvar))
        for k in range(D):
            Alin[k * L:(k + 1) * L, k: F * D: D] = MB
            Alin[(D + k) * L:(D + k + 1) * L, k: F * D: D] = -MB
        self.Alin = Alin
        cst = M @ fixed  # (L, D)
        self.blin = np.concatenate([cst[:, k] - b for k in range(D)] + [-cst[:, k] - b for k in range(D)])
        # plane rows: index arrays of the Jacobian
        self.m_cp = 4 * P
        self.m_v = P * V
        self.m = self.m_cp + self.m_v + len(self.blin)
        p_of = np.repeat(np.arange(P), 4)
        k_of = np.tile(np.arange(4), P)
        self.cp_idx = pb.seg[p_of] + k_of  # control point of each cp row
        f_of = cmap[self.cp_idx]
        self.cp_free_rows = np.nonzero(f_of >= 0)[0]
        self.cp_free_cols = f_of[self.cp_free_rows][:, None] * D + np.arange(D)[None, :]
        self.cp_p = p_of
        self.n_cols = self.off_n + np.arange(P)[:, None] * D + np.arange(D)[None, :]  # (P, D)
        self.evals = 0

    # ------------------------------------------------------------------ pieces

    def unpack(self, x: np.ndarray):
        F, D, P = self.F, self.D, self.P
        free = x[: F * D].reshape(F, D)
        n = x[self.off_n: self.off_d].reshape(P, D)
        d = x[self.off_d:]
        return free, n, d

    def ctrl(self, x: np.ndarray) -> np.ndarray:
        return self.B @ self.unpack(x)[0] + self.fixed

    def pack(self, free: np.ndarray, n: np.ndarray, d: np.ndarray) -> np.ndarray:
        return np.concatenate([free.ravel(), n.ravel(), d.ravel()])

    def cost(self, x: np.ndarray, grad: np.ndarray) -> float:
        self.evals += 1
        pb = self.pb
        C = self.ctrl(x)
        js, gs = smoothness_cost(C)
        s5 = pb.dt_knot ** 5
        e = C[-1] - pb.goal
        f = js / s5 + pb.weight * float(e @ e)
        if grad.size:
            grad[:] = 0.0
            gfree = self.B.T @ (gs / s5)
            gfree[-1] += 2.0 * pb.weight * e
            grad[: self.F * self.D] = gfree.ravel()
        return float(f)

    def constraints(self, result: np.ndarray, x: np.ndarray, grad: np.ndarray) -> None:
        P, V, D = self.P, self.V, self.D
        C = self.ctrl(x)
        _, n, d = self.unpack(x)
        cps = C[self.cp_idx]  # (4P, D)
        c_cp = np.einsum("rd,rd->r", n[self.cp_p], cps) + d[self.cp_p] + 1.0
        c_v = (1.0 - np.einsum("pd,pvd->pv", n, self.pb.verts) - d[:, None]).ravel()
        c_lin = self.Alin @ x + self.blin
        result[:] = np.concatenate([c_cp, c_v, c_lin])
        if grad.size:
            grad[:] = 0.0
            r = np.arange(self.m_cp)
            grad[r[:, None], self.n_cols[self.cp_p]] = cps
            grad[r, self.off_d + self.cp_p] = 1.0
            fr = self.cp_free_rows
            grad[fr[:, None], self.cp_free_cols] = n[self.cp_p[fr]]
            if V:
                rv = self.m_cp + np.arange(P * V)
                pv = np.repeat(np.arange(P), V)
                grad[rv[:, None], self.n_cols[pv]] = -self.pb.verts.reshape(-1, D)
                grad[rv, self.off_d + pv] = -1.0
            grad[self.m_cp + self.m_v:] = self.Alin

    def violation(self, x: np.ndarray) -> float:
        out = np.empty(self.m)
        self.constraints(out, x, np.zeros(0))
        return float(out.max()) if out.size else 0.0


def solve(pb: Problem, free0: np.ndarray, n0: np.ndarray, d0: np.ndarray, max_eval: int, tol: float,
          xtol_rel: float, ftol_rel: float, algorithm: str = "LD_SLSQP", box: float = 12.0,
          plane_bound: float = 100.0) -> Result:
    """Solve ``pb`` from the initial guess with NLopt; the best feasible point seen is kept
    (NLopt may stop on a round-off limit after reaching it)."""
    prob = Mader(pb)
    x0 = prob.pack(free0, n0, d0)
    if not np.all(np.isfinite(x0)):
        return Result(None, 0, float("inf"), "nan-guess")
    best = {"x": None, "f": np.inf}

    def f(x, grad):
        val = prob.cost(x, grad)
        return val

    def g(result, x, grad):
        prob.constraints(result, x, grad)
        if np.all(np.isfinite(result)) and result.max() <= tol:
            val = prob.cost(x, np.zeros(0))
            prob.evals -= 1
            if val < best["f"]:
                best["x"], best["f"] = x.copy(), val
    opt = nlopt.opt(getattr(nlopt, algorithm), prob.nvar)
    opt.set_min_objective(f)
    # bounds: free points within ``box`` [m] of the start, plane normals within +-plane_bound [1/m]
    lo, hi = np.full(prob.nvar, -1e4), np.full(prob.nvar, 1e4)
    F, D = prob.F, prob.D
    lo[: F * D] = np.tile(pb.start[0] - box, F)
    hi[: F * D] = np.tile(pb.start[0] + box, F)
    lo[prob.off_n: prob.off_d], hi[prob.off_n: prob.off_d] = -plane_bound, plane_bound
    opt.set_lower_bounds(lo)
    opt.set_upper_bounds(hi)
    x0 = np.clip(x0, lo, hi)
    if prob.m:
        opt.add_inequality_mconstraint(g, np.full(prob.m, tol * 0.5))
    opt.set_maxeval(int(max_eval))
    opt.set_xtol_rel(xtol_rel)
    opt.set_ftol_rel(ftol_rel)
    status = "ok"
    try:
        x = opt.optimize(x0)
        viol = prob.violation(x)
        if np.all(np.isfinite(x)) and viol <= tol and prob.cost(x, np.zeros(0)) <= best["f"]:
            best["x"] = x
    except Exception as exc:  # noqa: BLE001 - NLopt raises its own classes (roundoff, runtime_error); keep the best seen
        status = type(exc).__name__
    if best["x"] is None:
        return Result(None, prob.evals, float("inf"), status if status != "ok" else "infeasible")
    x = best["x"]
    C = prob.ctrl(x)
    if not np.all(np.isfinite(C)):
        return Result(None, prob.evals, float("inf"), "nan")
    return Result(C, prob.evals, prob.violation(x), status)


# ---------------------------------------------------------------------- IPOPT (CasADi)

#: Bézier control points of one uniform cubic B-spline segment from its four B-spline control
#: points (the Bézier hull is inside the B-spline hull: MADER's ``basis: BEZIER``).
BEZIER = np.array([[1.0, 4.0, 1.0, 0.0], [0.0, 4.0, 2.0, 0.0], [0.0, 2.0, 4.0, 0.0], [0.0, 1.0, 4.0, 1.0]]) / 6.0
_IPOPT_CACHE: dict[tuple, Any] = {}


def hull_matrices(num_pol: int, basis: str, knots: str) -> np.ndarray:
    """(S, 4, 4): the hull points of segment ``s`` are ``M[s] @ C[s:s+4]``: the control points
    themselves (``bspline``) or the segment's Bézier points (``bezier``, for either knot vector)."""
    if basis == "bspline":
        return np.broadcast_to(np.eye(4), (num_pol, 4, 4))
    if knots == "clamped":
        return clamped.bezier_matrices(num_pol)
    return np.broadcast_to(BEZIER, (num_pol, 4, 4))


def _ipopt_solver(D: int, num_pol: int, P: int, V: int, basis: str, max_iter: int, tol: float, knots: str,
                  ball: bool = False, norm_limits: bool = False, options: tuple = ()):
    """The compiled CasADi/IPOPT problem for a shape (cached): variables ``x = [free (F, D),
    n (P, D), d (P,)]``, parameters ``[C_0..C_2, G, dt_knot, v_max, a_max, weight, verts (P, V, D),
    segment (P,)]`` and, with ``ball``, ``radius (P,)``. The segment of each plane is a parameter,
    so one shape serves every assignment of planes to segments.

    ``ball``: each plane also keeps ``|n_p| <= 2 / radius_p`` (a convex bound): with the margins
    +-1 the two sets are then at least ``radius_p`` apart along n, so the Euclidean distance
    between them is at least ``radius_p`` -- a ball of that radius instead of a box."""
    key = (D, num_pol, P, V, basis, max_iter, tol, knots, ball, norm_limits, options)
    hit = _IPOPT_CACHE.get(key)
    if hit is not None:
        return hit
    N, F = num_pol + 2, num_pol - 2
    x = ca.SX.sym("x", F * D + P * D + P)
    par = ca.SX.sym("p", 3 * D + D + 4 + P * V * D + P + (P if ball else 0))
    start = ca.reshape(par[: 3 * D], D, 3).T
    G = par[3 * D: 4 * D].T
    dtk, vmax, amax, weight = par[4 * D], par[4 * D + 1], par[4 * D + 2], par[4 * D + 3]
    o = 4 * D + 4
    verts = ca.reshape(par[o: o + P * V * D], D, P * V).T  # row p V + v
    seg = par[o + P * V * D: o + P * V * D + P]
    free = ca.reshape(x[: F * D], D, F).T
    C = ca.vertcat(start, free[: F - 1, :], free[F - 1, :], free[F - 1, :], free[F - 1, :])  # (N + 1, D)
    if knots == "clamped":  # derivative control points of the clamped spline (planning/clamped.py)
        Mv, Ma, Mj = (ca.DM(m) for m in clamped.derivative_matrices(num_pol))
        jerk, vel, acc = ca.mtimes(Mj, C), ca.mtimes(Mv, C) / dtk, ca.mtimes(Ma, C) / dtk**2
    else:
        jerk = C[3:, :] - 3 * C[2:-1, :] + 3 * C[1:-2, :] - C[:-3, :]
        vel = (C[1:, :] - C[:-1, :]) / dtk
        acc = (C[2:, :] - 2 * C[1:-1, :] + C[:-2, :]) / dtk**2
    f = ca.sumsqr(jerk) / dtk**5 + weight * ca.sumsqr(C[N, :] - G)
    n = ca.reshape(x[F * D: F * D + P * D], D, P).T
    d = x[F * D + P * D:]
    segs = [ca.mtimes(ca.DM(M), C[s: s + 4, :])  # (4, D) hull points of each segment
            for s, M in enumerate(hull_matrices(num_pol, basis, knots))]
    g_cp, g_v = [], []
    for p in range(P):
        pts = sum((ca.if_else(seg[p] == s, 1.0, 0.0) * segs[s] for s in range(num_pol)), ca.SX.zeros(4, D))
        g_cp.append(ca.mtimes(pts, n[p, :].T) + d[p])  # <= -1
        g_v.append(ca.mtimes(verts[p * V:(p + 1) * V, :], n[p, :].T) + d[p])  # >= 1
    if norm_limits:  # the hull of the derivative control points inside a ball: the curve's norm bounded
        lim = ca.vertcat(ca.sum2(vel * vel) / vmax**2, ca.sum2(acc * acc) / amax**2)
        m_l, lim_lo = vel.shape[0] + acc.shape[0], -np.inf
    else:
        lim = ca.vertcat(ca.vec(vel) / vmax, ca.vec(acc) / amax)
        m_l, lim_lo = vel.shape[0] * D + acc.shape[0] * D, -1.0
    g = ca.vertcat(*g_cp, *g_v, lim)
    m_cp, m_v = 4 * P, V * P
    lbg = np.concatenate([np.full(m_cp, -np.inf), np.ones(m_v), np.full(m_l, lim_lo)])
    ubg = np.concatenate([-np.ones(m_cp), np.full(m_v, np.inf), np.ones(m_l)])
    if ball and P:
        rad = par[o + P * V * D + P:]
        g = ca.vertcat(g, ca.sum2(n * n) * (rad * rad) / 4.0)  # |n_p|^2 r_p^2 / 4 <= 1
        lbg, ubg = np.concatenate([lbg, np.full(P, -np.inf)]), np.concatenate([ubg, np.ones(P)])
    opts = {"print_time": False, "ipopt.print_level": 0, "ipopt.sb": "yes", "ipopt.max_iter": int(max_iter),
            "ipopt.tol": float(tol), "ipopt.mu_strategy": "adaptive"}
    opts.update({"ipopt." + k: v for k, v in options})
    solver = ca.nlpsol("mader", "ipopt", {"x": x, "p": par, "f": f, "g": g}, opts)
    _IPOPT_CACHE[key] = (solver, lbg, ubg)
    return _IPOPT_CACHE[key]


def infeasible_start(pb: Problem, tol: float, plane_bound: float) -> bool:
    """True if the fixed control points prove ``pb`` infeasible before any solve (B-spline hulls).

    The first three control points C_0..C_2 are fixed by the start state; segment s <= 2 has
    C_s..C_2 among its hull points. Its plane p needs n.a + d <= -1 at every point a of their hull
    A and n.v + d >= 1 at every point v of the vertices' hull V, so n.(v - a) >= 2: with
    |n| <= n_max the two hulls must be at least 2 / n_max apart. Within the solver's tolerance
    ``tol`` (the margins -1 + tol, 1 - tol and, with a ball clearance, |n| r / 2 <= sqrt(1 + tol)),
    a point q = v - a of the hull of the differences with |q| n_max < 2 (1 - tol) certifies that no
    point is feasible: IPOPT could only fail on it. n_max is plane_bound sqrt(D) (the bounds on
    n), or 2 sqrt(1 + tol) / r_p with a ball. q is found by NNLS, its weights normalised to sum 1,
    so q lies in that hull whatever the NNLS error: the test can only err towards solving."""
    P = len(pb.seg)
    if P == 0:
        return False
    D = pb.start.shape[1]
    n_max = np.full(P, plane_bound * math.sqrt(D))
    if pb.radius is not None:
        n_max = np.minimum(n_max, 2.0 * math.sqrt(1.0 + tol) / np.asarray(pb.radius, float))
    n_max *= 1.0 + 1e-6  # IPOPT relaxes the variable bounds by 1e-8 (bound_relax_factor): stay on the safe side
    reach = 2.0 * (1.0 - tol) / n_max  # (P,) hulls closer than this cannot be separated
    lo, hi = pb.verts.min(axis=1), pb.verts.max(axis=1)  # (P, D)
    for s in range(3):
        planes = np.nonzero(pb.seg == s)[0]
        A = pb.start[s:3]
        a_lo, a_hi = A.min(axis=0), A.max(axis=0)
        box_gap = np.linalg.norm(np.maximum(lo[planes] - a_hi, 0.0) + np.maximum(a_lo - hi[planes], 0.0), axis=1)
        for p in planes[box_gap < reach[planes]]:  # the hulls are at least as far apart as their boxes
            M = (pb.verts[p][None, :, :] - A[:, None, :]).reshape(-1, D)  # differences v - a
            w = 1e3 * (1.0 + float(np.abs(M).max()))  # the weight of sum(lambda) = 1
            lam, _ = nnls(np.vstack([M.T, np.full(len(M), w)]), np.concatenate([np.zeros(D), [w]]))
            if lam.sum() > 0.0 and np.linalg.norm(M.T @ (lam / lam.sum())) < reach[p]:
                return True
    return False


def solve_ipopt(pb: Problem, free0: np.ndarray, n0: np.ndarray, d0: np.ndarray, max_iter: int, tol: float,
                basis: str = "bspline", box: float = 12.0, plane_bound: float = 100.0,
                knots: str = "uniform", options: tuple = (), precheck: bool = False) -> Result:
    """Solve ``pb`` with IPOPT (interior point, exact Hessian, MUMPS) through CasADi. The plane
    normals are bounded by ``plane_bound`` [1/m] (the separation's margin is 2 / |n|, so the
    bound admits gaps down to 2 / (plane_bound sqrt(D)) m): without a bound the barrier pushes the
    planes' scale to infinity. Feasible means every constraint within ``tol``. With ``precheck``
    (B-spline hulls only) a problem :func:`infeasible_start` proves infeasible is not solved
    (status ``infeasible-start``, 0 iterations): the same outcome as IPOPT's, without its cost."""
    if precheck and basis == "bspline" and infeasible_start(pb, tol, plane_bound):
        return Result(None, 0, float("inf"), "infeasible-start")
    D = pb.start.shape[1]
    P = len(pb.seg)
    V = pb.verts.shape[1] if P else 0
    F = pb.num_pol - 2
    ball = pb.radius is not None
    solver, lbg, ubg = _ipopt_solver(D, pb.num_pol, P, V, basis, max_iter, tol, knots, ball, pb.norm_limits, options)
    par = np.concatenate([pb.start.ravel(), pb.goal, [pb.dt_knot, pb.v_max, pb.a_max, pb.weight],
                          pb.verts.reshape(-1), pb.seg.astype(float)] + ([np.asarray(pb.radius, float)] if ball else []))
    x0 = np.concatenate([free0.ravel(), n0.ravel(), d0])
    if not np.all(np.isfinite(x0)) or not np.all(np.isfinite(par)):
        return Result(None, 0, float("inf"), "nan-guess")
    lbx, ubx = np.full(x0.size, -np.inf), np.full(x0.size, np.inf)
    lbx[: F * D], ubx[: F * D] = np.tile(pb.start[0] - box, F), np.tile(pb.start[0] + box, F)
    lbx[F * D: F * D + P * D], ubx[F * D: F * D + P * D] = -plane_bound, plane_bound
    reach = plane_bound * (np.sqrt(D) * (box + np.abs(pb.verts).max() if P else box) + 1.0)
    lbx[F * D + P * D:], ubx[F * D + P * D:] = -reach, reach
    sol = solver(x0=np.clip(x0, lbx, ubx), p=par, lbg=lbg, ubg=ubg, lbx=lbx, ubx=ubx)
    stats = solver.stats()
    x = np.asarray(sol["x"]).ravel()
    g = np.asarray(sol["g"]).ravel()
    viol = float(max(np.max(lbg - g, initial=0.0), np.max(g - ubg, initial=0.0)))
    iters = int(stats.get("iter_count", 0))
    status = str(stats.get("return_status", "unknown"))
    if not np.all(np.isfinite(x)) or viol > tol:
        return Result(None, iters, viol, status)
    free = x[: F * D].reshape(F, D)
    C = np.vstack([pb.start, free[: F - 1], np.repeat(free[F - 1:], 3, axis=0)])
    return Result(C, iters, viol, status)
