"""One robot's nonlinear MPC problem (Soria, Schiano & Floreano, Nat. Mach. Intell. 2021), built
once per shape with CasADi and solved with IPOPT; and the same cost and constraints in plain
NumPy (:func:`reference`), the oracle the tests hold the compiled problem to.

The robot is the point-mass double integrator of the paper's predictive model, discretised
exactly with a zero-order hold on the acceleration over the control step ``h``:

    p_{k+1} = p_k + h v_k + h^2 / 2 u_k,   v_{k+1} = v_k + h u_k,   k = 0 .. H-1.

The decision variables are the H accelerations ``u_0 .. u_{H-1}`` (single shooting: positions and
velocities are linear in them). The cost is the mean over the predicted states k = 1..H of

    w_sep J_sep + w_coh J_coh + w_dir J_dir + w_nav J_nav + w_u |u_{k-1}|^2

with, for the neighbours j in the cost (weights c_j summing to 1) and e_j = |p_k - q_jk|^2 - d_ref^2,
J_sep = sum_j c_j min(e_j, 0)^2 (too close), J_coh = sum_j c_j max(e_j, 0)^2 (too far): with
w_sep = w_coh the paper's single separation term sum_j c_j e_j^2; J_dir = (1 - (v.u_ref)^2 /
(|v|^2 + eps))^2 (migration direction; ``signed``: (1 - v.u_ref / sqrt(|v|^2 + eps))^2, which
tells forward from backward), J_nav = (|v|^2 - v_ref^2)^2 (migration speed).

Constraints at every predicted step: |u|^2 <= a_max^2, |v_k|^2 <= v_max^2, |p_k - q_jk|^2 >=
rho_j^2 for the neighbours in the constraints (rho_j = 0: none), and per obstacle slot
``alpha (|s o (p_k - c)|^2 - rho^2) + (1 - alpha) (n.(p_k - c) - rho) >= 0``: alpha = 1 a disc,
cylinder or ball of radius rho around c (s masks the axes it spans), alpha = 0 the half-space
beyond the tangent plane at the obstacle's nearest point c with normal n, rho away from it.
An empty slot is alpha = 0, n = 0, rho = -1 (always met). After the H step blocks, K rows of the
reach guard (ours, method.py): |p_1 - c_j|^2 >= rho_j^2 at the first predicted step only.

IPOPT is warm-started from the previous plan shifted by one step and, with ``Options.warm_dual``,
from its multipliers shifted the same way (:func:`shift_duals`).
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

_CACHE: dict[tuple, tuple] = {}
#: statuses IPOPT reports for a usable point
OK_STATUS = ("Solve_Succeeded", "Solved_To_Acceptable_Level")


@dataclass(frozen=True, slots=True)
class Weights:
    """Cost weights and references (see the module docstring)."""

    w_sep: float
    w_coh: float
    w_dir: float
    w_nav: float
    w_u: float
    d_ref: float  # [m]
    eps_v: float  # [m^2/s^2] regularises J_dir at rest
    signed: bool = False  # J_dir = (1 - v.u / sqrt(|v|^2 + eps))^2 instead of the squared cosine


@dataclass(frozen=True, slots=True)
class Problem:
    """One robot's problem at one control step: its state, its references, what it avoids.

    Shapes: H steps, K neighbour slots, M obstacle slots, D dimensions."""

    p0: np.ndarray  # (D,) [m]
    v0: np.ndarray  # (D,) [m/s]
    h: float  # control step [s]
    v_max: float  # [m/s]
    a_max: float  # [m/s^2]
    u_ref: np.ndarray  # (D,) unit migration direction
    v_ref: float  # [m/s] migration speed
    q: np.ndarray  # (K, H, D) neighbours' predicted positions at steps 1..H [m]
    c_cost: np.ndarray  # (K,) weight of each neighbour in J_sep, J_coh (sum 1, or all 0)
    rho_col: np.ndarray  # (K,) least distance to each neighbour [m] (0: not constrained)
    obs_c: np.ndarray  # (M, D) centre / tangent point [m]
    obs_s: np.ndarray  # (M, D) axis mask of a disc / ball (1 or 0)
    obs_n: np.ndarray  # (M, D) unit normal of a half-space
    obs_rho: np.ndarray  # (M,) radius / offset [m]
    obs_alpha: np.ndarray  # (M,) 1: disc, 0: half-space
    #: the one-step reach guard (ours, method.py): |p_1 - reach_c_j| >= reach_rho_j at the first
    #: predicted step only (reach_rho_j = 0: not constrained)
    reach_c: np.ndarray | None = None  # (K, D) [m]
    reach_rho: np.ndarray | None = None  # (K,) [m]

    def reach(self) -> tuple[np.ndarray, np.ndarray]:
        """(reach_c, reach_rho), zeros (never binding) when not given."""
        K, _, D = self.q.shape
        c = np.zeros((K, D)) if self.reach_c is None else np.asarray(self.reach_c, float)
        r = np.zeros(K) if self.reach_rho is None else np.asarray(self.reach_rho, float)
        return c, r


def shape(pb: Problem) -> tuple[int, int, int, int]:
    """(H, K, M, D) of a problem."""
    K, H, D = pb.q.shape
    return H, K, pb.obs_c.shape[0], D


def rollout(p0, v0, U, h):
    """Positions and velocities (H, D) at steps 1..H of the double integrator under ``U`` (H, D);
    works on NumPy arrays and on CasADi matrices."""
    H = U.shape[0]
    ps, vs = [], []
    p, v = p0, v0
    for k in range(H):
        p = p + h * v + 0.5 * h * h * U[k, :]
        v = v + h * U[k, :]
        ps.append(p)
        vs.append(v)
    return ps, vs


def _pack(pb: Problem, w: Weights) -> np.ndarray:
    return np.concatenate([pb.p0, pb.v0, [pb.h, pb.v_max, pb.a_max, pb.v_ref], pb.u_ref,
                           [w.w_sep, w.w_coh, w.w_dir, w.w_nav, w.w_u, w.d_ref, w.eps_v, float(w.signed)],
                           pb.q.ravel(), pb.c_cost, pb.rho_col, pb.obs_c.ravel(), pb.obs_s.ravel(),
                           pb.obs_n.ravel(), pb.obs_rho, pb.obs_alpha, pb.reach()[0].ravel(), pb.reach()[1]]
                          ).astype(float)


@dataclass(frozen=True, slots=True)
class Options:
    """IPOPT settings of a solve (see docs/methods/nmpc.md, *Solver*)."""

    max_iter: int = 50
    tol: float = 1e-6
    hessian: str = "exact"  # or "limited-memory" (L-BFGS)
    warm_dual: bool = False  # warm start the multipliers too (IPOPT warm_start_init_point)
    acceptable_iter: int = 15  # IPOPT stops at a point acceptable (tol x 100) this many iterations in a row
    mu_init: float = 0.1  # IPOPT's initial barrier parameter (its default 0.1)


def _build(H: int, K: int, M: int, D: int, max_iter: int | Options, tol: float = 1e-6):
    """The compiled problem of a shape (cached): variables ``U`` (H D), parameters :func:`_pack`."""
    opt = max_iter if isinstance(max_iter, Options) else Options(int(max_iter), float(tol))
    key = (H, K, M, D, opt)
    hit = _CACHE.get(key)
    if hit is not None:
        return hit
    x = ca.SX.sym("x", 3 * H * D)  # [U (H, D), P (H, D), V (H, D)]: multiple shooting
    npar = 2 * D + 4 + D + 8 + K * H * D + 2 * K + 3 * M * D + 2 * M + K * D + K
    par = ca.SX.sym("p", npar)
    o = 0

    def take(n):
        nonlocal o
        out = par[o: o + n]
        o += n
        return out

    p0, v0 = take(D).T, take(D).T
    h, vmax, amax, vref = (take(1) for _ in range(4))
    uref = take(D).T
    w_sep, w_coh, w_dir, w_nav, w_u, d_ref, eps_v, signed = (take(1) for _ in range(8))
    q = take(K * H * D)
    c_cost, rho_col = take(K), take(K)
    oc, os_, on = (ca.reshape(take(M * D), D, M).T for _ in range(3))
    orho, oalpha = take(M), take(M)
    rc, rrho = ca.reshape(take(K * D), D, K).T, take(K)
    assert o == npar
    U = ca.reshape(x[: H * D], D, H).T
    P = ca.reshape(x[H * D: 2 * H * D], D, H).T
    V = ca.reshape(x[2 * H * D:], D, H).T
    f = 0
    g, lbg, ubg = [], [], []
    for k in range(H):
        p, v, u = P[k, :], V[k, :], U[k, :]
        pp, vp = (p0, v0) if k == 0 else (P[k - 1, :], V[k - 1, :])
        g += [(p - pp - h * vp - 0.5 * h * h * u).T, (v - vp - h * u).T]  # the dynamics
        lbg += [0.0] * (2 * D)
        ubg += [0.0] * (2 * D)
        js = jc = 0
        for j in range(K):
            qj = q[(j * H + k) * D: (j * H + k + 1) * D].T
            dd = ca.sumsqr(p - qj)
            e = dd - d_ref**2
            js += c_cost[j] * ca.fmin(e, 0) ** 2
            jc += c_cost[j] * ca.fmax(e, 0) ** 2
            g.append(dd - rho_col[j] ** 2)
        vv = ca.sumsqr(v)
        jd = (1 - signed) * (1 - ca.dot(v, uref) ** 2 / (vv + eps_v)) ** 2 \
            + signed * (1 - ca.dot(v, uref) / ca.sqrt(vv + eps_v)) ** 2
        jn = (vv - vref**2) ** 2
        f += w_sep * js + w_coh * jc + w_dir * jd + w_nav * jn + w_u * ca.sumsqr(u)
        for m in range(M):
            r = p - oc[m, :]
            g.append(oalpha[m] * (ca.sumsqr(os_[m, :] * r) - orho[m] ** 2)
                     + (1 - oalpha[m]) * (ca.dot(on[m, :], r) - orho[m]))
        g += [vv - vmax**2, ca.sumsqr(u) - amax**2]
        lbg += [0.0] * (K + M) + [-np.inf, -np.inf]
        ubg += [np.inf] * (K + M) + [0.0, 0.0]
    for j in range(K):  # the reach guard, after every step's block (the dual shift keeps them in place)
        g.append(ca.sumsqr(P[0, :] - rc[j, :]) - rrho[j] ** 2)
    lbg += [0.0] * K
    ubg += [np.inf] * K
    f = f / H
    opts = {"print_time": False, "ipopt.print_level": 0, "ipopt.sb": "yes", "ipopt.max_iter": int(opt.max_iter),
            "ipopt.tol": float(opt.tol), "ipopt.acceptable_tol": float(opt.tol) * 100, "ipopt.mu_strategy": "adaptive",
            "ipopt.acceptable_iter": int(opt.acceptable_iter), "ipopt.hessian_approximation": opt.hessian,
            "ipopt.mu_init": float(opt.mu_init)}
    if opt.warm_dual:
        opts.update({"ipopt.warm_start_init_point": "yes", "ipopt.warm_start_bound_push": 1e-6,
                     "ipopt.warm_start_bound_frac": 1e-6, "ipopt.warm_start_slack_bound_push": 1e-6,
                     "ipopt.warm_start_slack_bound_frac": 1e-6, "ipopt.warm_start_mult_bound_push": 1e-6})
    solver = ca.nlpsol("nmpc", "ipopt", {"x": x, "p": par, "f": f, "g": ca.vertcat(*g)}, opts)
    _CACHE[key] = (solver, np.array(lbg), np.array(ubg))
    return _CACHE[key]


@dataclass(frozen=True, slots=True)
class Result:
    U: np.ndarray | None  # (H, D) accelerations [m/s^2], None when the solve failed
    positions: np.ndarray | None  # (H, D) predicted positions at steps 1..H [m]
    cost: float
    violation: float  # largest constraint violation at the returned point
    iterations: int
    status: str
    lam_x: np.ndarray | None = None  # multipliers of the variable bounds and constraints at the point,
    lam_g: np.ndarray | None = None  # for a warm start of the next solve (:func:`shift_duals`)


def shift_duals(res: Result | None, H: int, K: int, D: int) -> tuple[np.ndarray, np.ndarray] | None:
    """The multipliers of ``res`` one control step on (each step's block moves one step earlier, the
    last repeated; the K reach-guard rows stay), the dual half of the shifted warm start; None when
    there are none."""
    if res is None or res.lam_x is None or res.lam_g is None:
        return None
    lx = res.lam_x.reshape(3, H, D)
    lx = np.concatenate([lx[:, 1:], lx[:, -1:]], axis=1).ravel()
    nb = len(res.lam_g) - K
    lg = res.lam_g[:nb].reshape(H, -1)
    lg = np.concatenate([np.concatenate([lg[1:], lg[-1:]], axis=0).ravel(), res.lam_g[nb:]])
    return lx, lg


def solve(pb: Problem, w: Weights, U0: np.ndarray, max_iter: int = 50, tol: float = 1e-6,
          feas_tol: float = 1e-4, options: Options | None = None,
          duals: tuple[np.ndarray, np.ndarray] | None = None) -> Result:
    """Solve ``pb`` with IPOPT from the guess ``U0`` (H, D) (warm start; ``duals``: the multipliers'
    guess, used when ``options.warm_dual``). ``options`` overrides ``max_iter`` and ``tol``. A point
    is returned only if IPOPT reports success and every constraint holds within ``feas_tol``."""
    H, K, M, D = shape(pb)
    opt = options if options is not None else Options(int(max_iter), float(tol))
    solver, lbg, ubg = _build(H, K, M, D, opt)
    par = _pack(pb, w)
    x0 = _shoot(pb, U0)
    if not (np.all(np.isfinite(par)) and np.all(np.isfinite(x0))):
        return Result(None, None, np.inf, np.inf, 0, "non-finite input")
    args = {"x0": x0, "p": par, "lbg": lbg, "ubg": ubg}
    if opt.warm_dual and duals is not None and len(duals[1]) == len(lbg):
        args["lam_x0"], args["lam_g0"] = duals
    sol = solver(**args)
    st = solver.stats()
    status = str(st.get("return_status", "unknown"))
    iters = int(st.get("iter_count", 0))
    x = np.asarray(sol["x"]).ravel()
    gv = np.asarray(sol["g"]).ravel()
    viol = float(max(np.max(lbg - gv, initial=0.0), np.max(gv - ubg, initial=0.0)))
    cost = float(sol["f"])
    if status not in OK_STATUS or not np.all(np.isfinite(x)) or not np.isfinite(cost) or viol > feas_tol:
        return Result(None, None, cost, viol, iters, status)
    U = x[: H * D].reshape(H, D)
    return Result(U, x[H * D: 2 * H * D].reshape(H, D), cost, viol, iters, status,
                  np.asarray(sol["lam_x"]).ravel(), np.asarray(sol["lam_g"]).ravel())


def _shoot(pb: Problem, U) -> np.ndarray:
    """The variable vector of controls ``U`` (H, D): U, then the states they give."""
    U = np.asarray(U, dtype=float).reshape(-1, pb.p0.shape[0])
    ps, vs = rollout(np.asarray(pb.p0, float), np.asarray(pb.v0, float), U, pb.h)
    return np.concatenate([U.ravel(), np.ravel(ps), np.ravel(vs)])


def reference(pb: Problem, w: Weights, U: np.ndarray) -> tuple[float, np.ndarray]:
    """Cost and constraint values of ``U`` (H, D), written plainly (loops over steps, neighbours
    and obstacles): the oracle of the compiled problem. Constraints are returned as margins,
    ``>= 0`` when met, in the compiled problem's order."""
    H, K, M, D = shape(pb)
    U = np.asarray(U, dtype=float).reshape(H, D)
    ps, vs = rollout(np.asarray(pb.p0, float), np.asarray(pb.v0, float), U, pb.h)
    f = 0.0
    g = []
    for k in range(H):
        p, v, u = ps[k], vs[k], U[k]
        js = jc = 0.0
        for j in range(K):
            dd = float(np.sum((p - pb.q[j, k]) ** 2))
            e = dd - w.d_ref**2
            if e < 0:
                js += pb.c_cost[j] * e * e
            else:
                jc += pb.c_cost[j] * e * e
            g.append(dd - pb.rho_col[j] ** 2)
        vv = float(v @ v)
        if w.signed:
            jd = (1.0 - float(v @ pb.u_ref) / np.sqrt(vv + w.eps_v)) ** 2
        else:
            jd = (1.0 - float(v @ pb.u_ref) ** 2 / (vv + w.eps_v)) ** 2
        jn = (vv - pb.v_ref**2) ** 2
        f += w.w_sep * js + w.w_coh * jc + w.w_dir * jd + w.w_nav * jn + w.w_u * float(u @ u)
        for m in range(M):
            r = p - pb.obs_c[m]
            if pb.obs_alpha[m] == 1.0:
                g.append(float(np.sum((pb.obs_s[m] * r) ** 2)) - pb.obs_rho[m] ** 2)
            else:
                g.append(float(pb.obs_n[m] @ r) - pb.obs_rho[m])
        g += [pb.v_max**2 - vv, pb.a_max**2 - float(u @ u)]
    rc, rr = pb.reach()
    for j in range(K):
        g.append(float(np.sum((ps[0] - rc[j]) ** 2)) - rr[j] ** 2)
    return f / H, np.array(g)


def evaluate(pb: Problem, w: Weights, U: np.ndarray) -> tuple[float, np.ndarray]:
    """Cost and constraint margins (as :func:`reference`) of ``U`` by the compiled problem."""
    H, K, M, D = shape(pb)
    solver, lbg, ubg = _build(H, K, M, D, 50, 1e-6)
    fg = _fg(H, K, M, D)
    f, g = fg(_shoot(pb, U), _pack(pb, w))
    g = np.asarray(g).ravel()
    dyn = np.zeros(len(g), dtype=bool)  # the dynamics rows (met by construction) are dropped
    # (the K reach-guard rows after the H step blocks are kept)
    for k in range(H):
        dyn[k * (2 * D + K + M + 2): k * (2 * D + K + M + 2) + 2 * D] = True
    g, lbg, ubg = g[~dyn], lbg[~dyn], ubg[~dyn]
    # margins: >= 0 when met (lower-bounded rows g, upper-bounded rows -g)
    return float(f), np.where(np.isfinite(lbg), g - np.where(np.isfinite(lbg), lbg, 0.0), ubg - g)


_FG: dict[tuple, ca.Function] = {}


def _fg(H, K, M, D) -> ca.Function:
    key = (H, K, M, D)
    if key not in _FG:
        solver = _build(H, K, M, D, 50, 1e-6)[0]
        x, p = ca.MX.sym("x", 3 * H * D), ca.MX.sym("p", solver.size_in("p")[0])
        # the solver's own f and g (its oracle), evaluated outside the optimisation
        nf, ng = solver.get_function("nlp_f"), solver.get_function("nlp_g")
        _FG[key] = ca.Function("fg", [x, p], [nf(x=x, p=p)["f"], ng(x=x, p=p)["g"]])
    return _FG[key]
