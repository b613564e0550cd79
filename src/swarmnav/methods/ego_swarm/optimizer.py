"""EGO-Planner's B-spline optimisation with EGO-Swarm's swarm term: cost, rebound, refinement.

The interior control points ``Q_3 .. Q_{K-3}`` of a uniform cubic B-spline (knot span ``dt``)
minimise (EGO-Planner eq. 2, EGO-Swarm eq. 3)

    J = lambda_s J_s + lambda_c J_c + lambda_f J_f + lambda_w J_w   [+ lambda_fit J_fit]

- ``J_s = sum |Q_{i+3} - 3 Q_{i+2} + 3 Q_{i+1} - Q_i|^2``: jerk of the control points (our
  choice; the paper adds the acceleration's);
- ``J_c``: the ESDF-free ``{p, v}`` cost (:mod:`swarmnav.planning.esdf_free`);
- ``J_f = sum_axes max(|V| - v_max, 0)^2 + max(|A| - a_max, 0)^2`` over the control-point
  velocities ``V_i = (Q_{i+1} - Q_i) / dt`` and accelerations ``A_i = (V_{i+1} - V_i) / dt``;
- ``J_w = sum_i sum_k max(C_w - |Q_i - P_k(t_i)|, 0)^3``: EGO-Swarm's reciprocal term against
  the trajectories ``P_k`` the other robots broadcast, read at the control point's time
  ``t_i = t_0 + (i - 1) dt`` (where a cubic B-spline passes near ``Q_i``), ``C_w = 2 swarm_clearance``;
- ``J_fit = sum_j |B(t_j) - B_old(t_j / r)|^2`` at the knots: the refinement's fitness to the
  rebounded curve after the time re-allocation by the ratio ``r`` (EGO-Planner Section V).

The optimiser is L-BFGS (as the authors'), compiled with numba together with this cost and
its analytic gradient (:func:`_lbfgs`); SciPy's L-BFGS-B on the same cost is kept as a switch
(``SOLVER``) and as the oracle of the tests. :func:`rebound_optimize` is EGO-Planner's Algorithm 1: optimise, look
for control-polygon stretches that still cross obstacles, give their points new ``{p, v}`` pairs
from a new guide path, optimise again, a bounded number of times. :func:`reallocate` is the time
re-allocation and refinement.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Callable

import numpy as np
from numba import njit
from scipy.optimize import minimize

from swarmnav.planning.bspline import boundary_points, evaluate
from swarmnav.planning.esdf_free import colliding_runs, find_pairs, occupied, pair_cost, points_occupied, polygon_hits
from swarmnav.planning.lbfgs import direction as lbfgs_direction


#: the solver of :func:`_solve`: "lbfgs" (compiled, default) or "scipy" (L-BFGS-B)
SOLVER = "lbfgs"
#: gradient tolerance of the solver (the released planner's g_epsilon = 0.01 at its scale)
G_TOL = 1e-3


@dataclass(frozen=True, slots=True)
class Weights:
    """Weights and limits of the cost (module docstring)."""

    lam_s: float
    lam_c: float
    lam_f: float
    lam_w: float
    lam_fit: float
    sf: float  # obstacle clearance dist0 [m]
    cw: float  # centre-to-centre swarm clearance [m]
    v_max: float  # [m/s]
    a_max: float  # [m/s^2]
    tol: float  # feasibility tolerance (fraction)
    min_gap: float = 0.5  # [m] restart while a control point passes another robot's plan closer than this


@dataclass(frozen=True, slots=True)
class MapView:
    """One robot's occupancy map as the compiled kernels read it."""

    grid: np.ndarray  # flat uint8 classes
    counts: np.ndarray  # (dim,) cells along x, y[, z]
    origin: np.ndarray  # (dim,) centre of cell 0 [m]
    res: float  # [m]
    blocked: int  # a class >= blocked is occupied


@njit(cache=True)
def cost_grad(ctrl, dt, lam_s, lam_c, lam_f, lam_w, lam_fit, sf, cw, v_max, a_max,
              pair_idx, pair_p, pair_v, others, anchors, lam_t, target, grad):
    """The total cost ``J`` (module docstring) of all control points ``ctrl`` (n, D); its gradient
    with respect to every point is written into ``grad``. ``others``: (n_o, n, D) positions of the
    other robots at the control points' times (NaN: none); ``anchors``: (n - 2, D) knot positions
    of the refinement (an empty array: no fitness term)."""
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
    for i in range(n - 1):
        for d in range(dim):
            vel = (ctrl[i + 1, d] - ctrl[i, d]) * inv
            e = abs(vel) - v_max
            if e > 0.0:
                jf += e * e
                g = 2.0 * lam_f * e * np.sign(vel) * inv
                grad[i + 1, d] += g
                grad[i, d] -= g
    for i in range(n - 2):
        for d in range(dim):
            acc = (ctrl[i + 2, d] - 2.0 * ctrl[i + 1, d] + ctrl[i, d]) * inv * inv
            e = abs(acc) - a_max
            if e > 0.0:
                jf += e * e
                g = 2.0 * lam_f * e * np.sign(acc) * inv * inv
                grad[i + 2, d] += g
                grad[i + 1, d] -= 2.0 * g
                grad[i, d] += g
    total = lam_s * js + lam_f * jf
    total += pair_cost(ctrl, pair_idx, pair_p, pair_v, sf, lam_c, grad)
    jw = 0.0
    if lam_w > 0.0:
        for k in range(others.shape[0]):
            for i in range(3, n):
                if not np.isfinite(others[k, i, 0]):
                    continue
                r2 = 0.0
                for d in range(dim):
                    r2 += (ctrl[i, d] - others[k, i, d]) ** 2
                if r2 >= cw * cw:
                    continue
                r = max(np.sqrt(r2), 1e-9)
                e = cw - r
                jw += e * e * e
                g = -3.0 * lam_w * e * e / r
                for d in range(dim):
                    grad[i, d] += g * (ctrl[i, d] - others[k, i, d])
    total += lam_w * jw
    jfit = 0.0
    if anchors.shape[0] == n - 2 and lam_fit > 0.0:
        for j in range(n - 2):
            for d in range(dim):
                e = (ctrl[j, d] + 4.0 * ctrl[j + 1, d] + ctrl[j + 2, d]) / 6.0 - anchors[j, d]
                jfit += e * e
                g = 2.0 * lam_fit * e / 6.0
                grad[j, d] += g
                grad[j + 1, d] += 4.0 * g
                grad[j + 2, d] += g
    jt = 0.0
    if lam_t > 0.0:
        for d in range(dim):
            e = (ctrl[n - 3, d] + 4.0 * ctrl[n - 2, d] + ctrl[n - 1, d]) / 6.0 - target[d]
            jt += e * e
            g = 2.0 * lam_t * e / 6.0
            grad[n - 3, d] += g
            grad[n - 2, d] += 4.0 * g
            grad[n - 1, d] += g
    return total + lam_fit * jfit + lam_t * jt


@njit(cache=True)
def curve_hits(points, grid, counts, origin, res, blocked):
    """Index of the first occupied point of ``points`` (M, D) after any occupied run they start
    in (a robot inside the inflation band may leave it), or -1 if none."""
    m = points.shape[0]
    k = 0
    while k < m and occupied(grid, counts, origin, res, blocked, points[k]):
        k += 1
    for j in range(k, m):
        if occupied(grid, counts, origin, res, blocked, points[j]):
            return j
    return -1


class Pairs:
    """The ``{p, v}`` pairs of one plan (arrays grown by rebounds)."""

    __slots__ = ("idx", "p", "v")

    def __init__(self, dim: int):
        self.idx = np.zeros(0, dtype=np.int64)
        self.p = np.zeros((0, dim))
        self.v = np.zeros((0, dim))

    def add(self, idx, p, v) -> int:
        """Append the pairs not already held (a point keeps one pair per direction, within ~25 deg);
        returns how many were new."""
        keep = []
        for m in range(len(idx)):
            same = self.idx == idx[m]
            if np.any(same) and np.max(self.v[same] @ v[m]) > 0.9:
                continue
            keep.append(m)
        if keep:
            self.idx = np.concatenate([self.idx, idx[keep]])
            self.p = np.vstack([self.p, p[keep]])
            self.v = np.vstack([self.v, v[keep]])
        return len(keep)


def _segment_hits(ctrl: np.ndarray, dt: float, view: MapView, step: float) -> np.ndarray:
    """Colliding control-polygon segments: those crossing occupied cells, and for every knot
    segment of the curve that does, the middle segment ``Q_{s+1} -> Q_{s+2}`` of its four points."""
    hit = polygon_hits(ctrl, view.grid, view.counts, view.origin, view.res, view.blocked, step)
    n_seg = ctrl.shape[0] - 3
    per = max(8, int(np.ceil(float(np.max(np.linalg.norm(np.diff(ctrl, axis=0), axis=1))) / step)))
    tau = (np.arange(n_seg * per) + 0.5) * (dt / per)
    pts = evaluate(ctrl, dt, tau)[0]
    occ = points_occupied(np.ascontiguousarray(pts), view.grid, view.counts, view.origin, view.res, view.blocked)
    if np.any(occ):
        seg = np.unique(np.minimum((tau[occ] / dt).astype(np.int64), n_seg - 1))
        hit[seg + 1] = True
    return hit


def _assign_pairs(ctrl: np.ndarray, dt: float, pairs: Pairs, view: MapView, search: Callable,
                  step: float) -> tuple[int, int, bool]:
    """Find the stretches of the control polygon or curve that cross obstacles and give their free
    points ``{p, v}`` pairs from an A* guide path; returns (new pairs, failed searches, any hit)."""
    n = ctrl.shape[0]
    hit = _segment_hits(ctrl, dt, view, step)
    new, failed = 0, 0
    for lo, hi in colliding_runs(hit):
        a, b = max(lo + 1, 3), min(hi - 1, n - 2)
        if a > b:  # the stretch lies on the fixed boundary points only
            continue
        path = search(ctrl[lo], ctrl[hi])
        if path is None or len(path) < 2:
            failed += 1
            continue
        idx, p, v = find_pairs(ctrl, a, b, np.ascontiguousarray(path, dtype=float), view.grid, view.counts,
                               view.origin, view.res, view.blocked)
        new += pairs.add(idx, p, v)
    return new, failed, bool(np.any(hit))


@njit(cache=True)
def _lbfgs(ctrl, lo, hi, dt, lam_s, lam_c, lam_f, lam_w, lam_fit, sf, cw, v_max, a_max,
           pair_idx, pair_p, pair_v, others, anchors, lam_t, target, max_iter, g_tol):
    """L-BFGS (Nocedal & Wright Alg. 7.4/7.5; memory 16 as the released planner) on the rows
    ``ctrl[lo:hi]``, in place: two-loop recursion with the ``s'y / y'y`` scaling, backtracking to
    the Armijo condition (c1 = 1e-4), curvature pairs with ``s'y <= 0`` skipped. Stops when the
    largest gradient component is below ``g_tol``, a step moves no point more than 1e-4 m, no
    decrease is found, or after ``max_iter`` iterations. Returns the iteration count."""
    n, dim = ctrl.shape
    nv = (hi - lo) * dim
    mem = 16
    S = np.zeros((mem, nv))
    Y = np.zeros((mem, nv))
    rho = np.zeros(mem)
    alpha = np.zeros(mem)
    G = np.empty((n, dim))
    x = np.empty(nv)
    g = np.empty(nv)
    for k in range(nv):
        x[k] = ctrl[lo + k // dim, k % dim]
    f = cost_grad(ctrl, dt, lam_s, lam_c, lam_f, lam_w, lam_fit, sf, cw, v_max, a_max,
                  pair_idx, pair_p, pair_v, others, anchors, lam_t, target, G)
    for k in range(nv):
        g[k] = G[lo + k // dim, k % dim]
    count = 0
    head = 0
    it = 0
    x_new = np.empty(nv)
    g_new = np.empty(nv)
    while it < max_iter:
        gmax = 0.0
        for k in range(nv):
            gmax = max(gmax, abs(g[k]))
        if gmax <= g_tol:
            break
        it += 1
        q = lbfgs_direction(g, S, Y, rho, alpha, head, count, mem, 0.5)  # first step at most 0.5 m
        slope = -np.dot(g, q)
        if slope >= 0.0:
            count = 0
            q = g.copy()
            slope = -np.dot(g, g)
        step = 1.0
        accepted = False
        f_new = f
        for _ in range(40):
            for k in range(nv):
                x_new[k] = x[k] - step * q[k]
                ctrl[lo + k // dim, k % dim] = x_new[k]
            f_new = cost_grad(ctrl, dt, lam_s, lam_c, lam_f, lam_w, lam_fit, sf, cw, v_max, a_max,
                              pair_idx, pair_p, pair_v, others, anchors, lam_t, target, G)
            if f_new <= f + 1e-4 * step * slope:
                accepted = True
                break
            step *= 0.5
        if not accepted:
            for k in range(nv):
                ctrl[lo + k // dim, k % dim] = x[k]
            break
        move = 0.0
        sy = 0.0
        for k in range(nv):
            g_new[k] = G[lo + k // dim, k % dim]
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


def _solve(ctrl: np.ndarray, dt: float, w: Weights, pairs: Pairs, others: np.ndarray, anchors: np.ndarray,
           lam_fit: float, max_iter: int, target: np.ndarray | None = None) -> tuple[np.ndarray, int, bool]:
    """L-BFGS on ``Q_3 .. Q_{K-3}`` (fixed end) or ``Q_3 .. Q_K`` (free end: ``target`` given,
    pulled there by the terminal term weighted ``lam_c``); returns (points, iterations, finite).
    ``SOLVER = "scipy"`` runs SciPy's L-BFGS-B on the same compiled cost instead (slower: its
    Python call per evaluation costs ~50 us; the tests check both agree)."""
    n, dim = ctrl.shape
    hi = n if target is not None else n - 3
    if hi <= 3:
        return ctrl, 0, True
    work = np.ascontiguousarray(ctrl, dtype=float).copy()
    lam_t = w.lam_c if target is not None else 0.0
    tgt = np.zeros(dim) if target is None else np.asarray(target, dtype=float)
    args = (dt, w.lam_s, w.lam_c, w.lam_f, w.lam_w, lam_fit, w.sf, w.cw, w.v_max, w.a_max,
            pairs.idx, pairs.p, pairs.v, others, anchors, lam_t, tgt)
    if SOLVER == "scipy":
        grad = np.empty_like(work)

        def fun(x):
            work[3:hi] = x.reshape(-1, dim)
            return cost_grad(work, *args, grad), grad[3:hi].ravel().copy()

        res = minimize(fun, work[3:hi].ravel(), jac=True, method="L-BFGS-B",
                       options={"maxiter": int(max_iter), "gtol": G_TOL})
        work[3:hi] = res.x.reshape(-1, dim)
        nit = int(res.nit)
    else:
        nit = int(_lbfgs(work, 3, hi, *args, int(max_iter), G_TOL))
    return work, nit, bool(np.all(np.isfinite(work)))


def sample_curve(ctrl: np.ndarray, dt: float, spacing: float) -> np.ndarray:
    """Points of the spline about ``spacing`` [m] apart (8 per knot span at least)."""
    dur = (ctrl.shape[0] - 3) * dt
    length = float(np.sum(np.linalg.norm(np.diff(ctrl, axis=0), axis=1)))
    m = max(int(np.ceil(length / spacing)), 8 * (ctrl.shape[0] - 3), 2)
    return evaluate(ctrl, dt, np.linspace(0.0, dur, m + 1))[0]


def curve_free(ctrl: np.ndarray, dt: float, view: MapView, part: float = 2.0 / 3.0) -> bool:
    """Whether the first ``part`` of the curve's duration is free on the map (the released planner
    checks the nearest 2/3: the rest is replanned before it is flown)."""
    pts = sample_curve(ctrl, dt, 0.5 * view.res)
    pts = np.ascontiguousarray(pts[: max(int(np.ceil(part * len(pts))), 1)])
    return curve_hits(pts, view.grid, view.counts, view.origin, view.res, view.blocked) < 0


def swarm_gap(ctrl: np.ndarray, others: np.ndarray) -> float:
    """Smallest distance [m] between the free control points and the others' positions at their
    times (inf: no other)."""
    if others.shape[0] == 0 or ctrl.shape[0] <= 3:
        return float("inf")
    gap = np.linalg.norm(others[:, 3:] - ctrl[None, 3:], axis=2)
    gap = gap[np.isfinite(gap)]
    return float(gap.min()) if gap.size else float("inf")


@dataclass(slots=True)
class Outcome:
    ctrl: np.ndarray
    dt: float
    ok: bool  # finite and collision-free on the map
    iterations: int = 0
    rebounds: int = 0
    pairs: int = 0
    failed_searches: int = 0
    refined: bool = False


def rebound_optimize(ctrl: np.ndarray, dt: float, w: Weights, view: MapView, search: Callable,
                     others_at: Callable[[float, int], np.ndarray], max_rebound: int, max_iter: int,
                     target: np.ndarray | None, max_restart: int = 3) -> Outcome:
    """EGO-Planner Algorithm 1 (module docstring) from the initial control points ``ctrl``, with
    the free end of the swarm planner pulled to ``target``: optimise; while the curve crosses
    obstacles on new stretches, add their ``{p, v}`` pairs and optimise again (at most
    ``max_rebound`` times); if it still collides within its first 2/3, or passes another robot's
    broadcast plan closer than ``min_gap`` at a control point, restart with the
    collision and swarm weights doubled (at most ``max_restart`` times)."""
    dim = ctrl.shape[1]
    pairs = Pairs(dim)
    step = 0.5 * view.res
    _, failed, _ = _assign_pairs(ctrl, dt, pairs, view, search, step)
    others = others_at(dt, ctrl.shape[0])
    none = np.zeros((0, dim))
    iters, rebounds, restarts = 0, 0, 0
    wk = w
    while True:
        ctrl, nit, finite = _solve(ctrl, dt, wk, pairs, others, none, 0.0, max_iter, target)
        iters += nit
        if not finite:
            break
        new, f, hit = _assign_pairs(ctrl, dt, pairs, view, search, step)
        failed += f
        if new > 0 and rebounds < max_rebound:
            rebounds += 1
            continue
        if (curve_free(ctrl, dt, view) and swarm_gap(ctrl, others) >= w.min_gap) or restarts >= max_restart:
            break
        restarts += 1
        wk = replace(wk, lam_c=2.0 * wk.lam_c, lam_w=2.0 * wk.lam_w)
    ok = finite and curve_free(ctrl, dt, view)
    return Outcome(ctrl, dt, ok, iters, rebounds, len(pairs.idx), failed)


def reallocate(out: Outcome, start: tuple, w: Weights, view: MapView,
               others_at: Callable[[float, int], np.ndarray], max_iter: int) -> Outcome:
    """Time re-allocation and refinement (EGO-Planner Section V): if a velocity or acceleration
    of the control points exceeds its limit by more than ``tol``, stretch the knot span by
    ``r = max(|V|/v_max, sqrt(|A|/a_max))``, re-impose the start state at the new span (the end
    points stay) and re-optimise smoothness, feasibility and fitness to the stretched curve (and
    the swarm term, at the new times).
    The refined plan is kept only if it is collision-free on the map; else ``out`` is returned."""
    ctrl, dt = out.ctrl, out.dt
    V = np.diff(ctrl, axis=0) / dt
    A = np.diff(V, axis=0) / dt
    ratio = max(float(np.max(np.abs(V))) / w.v_max, float(np.sqrt(np.max(np.abs(A)) / w.a_max)) if len(A) else 0.0)
    if ratio <= 1.0 + w.tol or ctrl.shape[0] <= 6:
        return out
    dt_new = dt * ratio
    anchors = np.ascontiguousarray((ctrl[:-2] + 4.0 * ctrl[1:-1] + ctrl[2:]) / 6.0)
    new = ctrl.copy()
    new[:3] = boundary_points(*start, dt_new)  # the start state at the new span; the end stays
    pairs = Pairs(ctrl.shape[1])
    refined, nit, finite = _solve(new, dt_new, w, pairs, others_at(dt_new, new.shape[0]), anchors, w.lam_fit, max_iter)
    if not finite or not curve_free(refined, dt_new, view):
        return out
    return Outcome(refined, dt_new, True, out.iterations + nit, out.rebounds, out.pairs, out.failed_searches, True)
