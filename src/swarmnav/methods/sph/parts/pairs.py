"""The pair guard (ours, not in the paper): no robot's command may drive it into another robot.

Algorithm 1 keeps robots apart only through its 1/r repulsion and the density pressure. In a
crowd of 60-100 robots queueing at the gaps of a forest, the robots behind press the queue
forward (their tracking pulls them on, the density term pushes), and two robots at its head meet
at 0.391-0.399 m, inside the 0.4 m contact distance (docs/methods/sph-crowd.md). A force that
grows as 1/r cannot promise a distance; a constraint on the command can.

The guard is the safety barrier certificate of Wang, Ames and Egerstedt ("Safety barrier
certificates for collisions-free multirobot systems", IEEE T-RO 33(3), 2017) for double
integrators, each robot taking half of every pair's constraint (their distributed form). For a
pair i, j with ``dp = p_i - p_j``, ``dv = v_i - v_j``, distance ``d``, unit ``n = dp / d`` and
separation rate ``s = n . dv``, with both robots able to brake at ``decel``:

    h = sqrt(4 decel (d - d_safe)) + s          (h >= 0: the pair can still stop before d_safe)

and ``dh/dt >= -gamma h`` is linear in the commands:

    -n . (a_i - a_j) <= b = gamma h + 2 decel s / sqrt(4 decel (d - d_safe)) + (|dv|^2 - s^2) / d

Robot i keeps ``-n . a_i <= b / 2`` and robot j ``n . a_j <= b / 2``. Each robot's command is
its nominal command, cut to ``a_max`` as its dynamics will cut it, moved to the nearest point
that meets all its pair constraints: a small quadratic programme in 2 or 3 unknowns, solved
exactly by trying every set of at most D active constraints (the KKT point is unique). Where
rest is safe for every pair (every bound >= 0), the dynamics' cut of the result towards 0 keeps
it safe (the feasible set is convex and holds 0). Pairs whose constraint no command within
``a_max`` can break are left out. A robot whose constraints no command meets (a pair already too
close, pressed from both sides) gets the command that breaks them least, and is counted.

The dynamics cut every command to ``a_max``; a command the guard moved beyond it would be cut
toward 0, which can break a constraint the moved command met. With ``bound`` rows (:func:`bound_rows`:
the box of a per-axis clamp exactly, the disc of a norm clamp as an inscribed polygon / polytope),
a robot whose nearest point lies beyond ``a_max`` is solved again with the bound's rows added, so
its command meets every constraint within what the dynamics will fly, when any command does.
"""

from __future__ import annotations

import functools

import numpy as np
from numba import njit
from scipy.spatial import cKDTree

from swarmnav.sensing import fibonacci_sphere

#: Slack [m/s^2] within which a constraint counts as met (rounding of the KKT solves).
TOL = 1e-9


def pair_constraints(x: np.ndarray, v: np.ndarray, d_safe: float, decel: float, gamma: float,
                     a_max: float, v_max: float, dt: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Pairs ``(i, j)`` (P, 2), their unit ``n`` (P, D) from j to i and bound ``b`` (P,) [m/s^2]
    of ``-n . (a_i - a_j) <= b``, for every pair that a command within ``a_max`` could break.

    The barrier's braking term ``2 decel s / root`` grows without bound as the pair nears
    ``d_safe``; applied over a control step ``dt`` [s] it would overshoot, so ``root`` is floored at
    ``4 decel dt`` there (the term's gain times dt stays at most 1/2)."""
    n_robots, dim = x.shape
    pairs = cKDTree(x).query_pairs(r=pair_reach(d_safe, decel, gamma, a_max, v_max), output_type="ndarray")
    if pairs.shape[0] == 0:
        return np.zeros((0, 2), np.int64), np.zeros((0, dim)), np.zeros(0)
    pairs = pairs[np.lexsort((pairs[:, 1], pairs[:, 0]))]  # the tree's order is not ours
    i, j = pairs[:, 0], pairs[:, 1]
    n, b = _barrier(x[i] - x[j], v[i] - v[j], d_safe, decel, gamma, dt)
    keep = b < 2.0 * a_max  # |n . (a_i - a_j)| <= 2 a_max: these constraints cannot bind
    return pairs[keep], n[keep], b[keep]


def pair_reach(d_safe: float, decel: float, gamma: float, a_max: float, v_max: float) -> float:
    """Distance [m] beyond which no pair's bound can bind: there b >= gamma (root - 2 v_max) -
    2 decel >= 2 a_max for any closing speed up to 2 v_max."""
    root = 2.0 * v_max + (2.0 * a_max + 2.0 * decel) / gamma
    return d_safe + root * root / (4.0 * decel)


def _barrier(dp: np.ndarray, dv: np.ndarray, d_safe: float, decel: float, gamma: float,
             dt: float, turning: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """Unit ``n`` (P, D) along ``dp`` and bound ``b`` (P,) of ``-n . (a_i - a_j) <= b`` for pairs
    at offsets ``dp = p_i - p_j`` [m] moving apart at ``dv = v_i - v_j`` [m/s]. ``turning``: the
    distance's second derivative counts the sideways motion, ``(|dv|^2 - s^2) / |dp|``, exact for
    two points; off for an obstacle, where ``|dp|`` is the clearance, not the radius of the
    surface's curvature (a flat wall has none), and the term would let a robot slide into it."""
    root_floor = 4.0 * decel * dt
    d = np.sqrt(np.einsum("pd,pd->p", dp, dp))
    n = dp / np.maximum(d, 1e-12)[:, None]
    s = np.einsum("pd,pd->p", n, dv)
    gap = d - d_safe
    root = np.sign(gap) * np.sqrt(4.0 * decel * np.abs(gap))  # signed: inside d_safe, h < 0 asks them apart
    h = root + s
    tangential = np.maximum(np.einsum("pd,pd->p", dv, dv) - s * s, 0.0) / np.maximum(d, 1e-12) if turning else 0.0
    b = gamma * h + 2.0 * decel * s / np.maximum(np.abs(root), root_floor) + tangential
    return n, b


def obstacle_constraints(v: np.ndarray, clearance: np.ndarray, away: np.ndarray, d_safe: float, decel: float,
                         gamma: float, a_max: float, dt: float,
                         robots: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Robots ``r`` (Q,), unit ``n`` (Q, D) pointing away from their nearest obstacle and bound
    ``b`` (Q,) [m/s^2] of ``-n . a_r <= b``: the pair barrier against a standing obstacle, whose
    whole bound the robot keeps, for every robot whose bound a command within ``a_max`` could
    break. ``clearance`` (N,) [m] is each robot centre's distance to its nearest obstacle surface,
    ``away`` (N, D) the unit direction away from it (the ESDF's value and gradient), ``d_safe``
    the clearance the robot must stop at (its body radius + a margin). With ``robots`` (Q,) the
    rows are (robot, obstacle) pairs instead, ``clearance`` (Q,) and ``away`` (Q, D) one per row
    (:func:`swarmnav.sensing.geometry.surfaces_within`), so a robot keeps clear of every obstacle
    near it, not only the nearest."""
    near = np.flatnonzero(np.isfinite(clearance) & (clearance > 0.0))
    if near.size == 0:
        return near, np.zeros((0, v.shape[1])), np.zeros(0)
    robot = near if robots is None else robots[near]
    g = away[near]
    g = g / np.maximum(np.linalg.norm(g, axis=1), 1e-12)[:, None]
    n, b = _barrier(g * clearance[near, None], v[robot], d_safe, decel, gamma, dt, turning=False)
    keep = b < a_max  # |n . a_r| <= a_max: these cannot bind
    return robot[keep], n[keep], b[keep]


@functools.lru_cache(maxsize=16)
def bound_rows(dim: int, a_max: float, clip: str = "norm", sides: int = 16) -> tuple[np.ndarray, np.ndarray]:
    """Half-spaces ``g . a <= c`` (normals (K, D), bounds (K,)) whose intersection lies inside
    the dynamics' command bound: for ``clip="axis"`` the box ``|a_k| <= a_max`` exactly; for
    ``"norm"`` in 2-D the regular ``sides``-gon inscribed in the disc of radius ``a_max`` (its
    faces at ``a_max cos(pi / sides)``), in 3-D the polytope of ``4 sides`` Fibonacci-sphere normals
    whose faces stand at ``a_max`` times the cosine of their covering angle (every vertex within
    the ball; the covering angle bounded from 20,000 directions plus the sampling's spacing).
    Cached: the arrays are shared, not to be written."""
    if clip == "axis":
        eye = np.eye(dim)
        return np.vstack([eye, -eye]), np.full(2 * dim, float(a_max))
    if dim == 2:
        t = 2.0 * np.pi * np.arange(sides) / sides
        return np.column_stack([np.cos(t), np.sin(t)]), np.full(sides, a_max * np.cos(np.pi / sides))
    g = fibonacci_sphere(4 * sides)
    probe = fibonacci_sphere(20000)
    cover = np.arccos(np.clip(np.min(np.max(probe @ g.T, axis=1)), -1.0, 1.0))
    spacing = np.sqrt(4.0 * np.pi / 20000)  # [rad] the probes' own spacing, added as a margin
    return g, np.full(len(g), a_max * np.cos(min(cover + spacing, np.pi / 2)))


def pair_guard(a: np.ndarray, x: np.ndarray, v: np.ndarray, d_safe: float, decel: float, gamma: float,
               a_max: float, v_max: float, dt: float,
               obstacles: tuple | None = None,
               bound: tuple[np.ndarray, np.ndarray] | None = None) -> tuple[np.ndarray, int, int]:
    """Commands ``a`` (N, D) [m/s^2] changed as little as possible so that no pair closes faster
    than both robots can brake before ``d_safe`` [m] (module docstring); how many robots'
    commands changed, and for how many no command met every constraint. ``obstacles`` =
    ``(clearance, away, d_safe_obstacle)`` adds a row per robot for its nearest obstacle, and
    ``(clearance, away, d_safe_obstacle, robots)`` a row per (robot, obstacle) pair
    (:func:`obstacle_constraints`), so that no command the guard moves drives a robot into one.
    ``bound``: :func:`bound_rows`, so that a moved command lies within what the dynamics fly."""
    pairs, n, b = pair_constraints(x, v, d_safe, decel, gamma, a_max, v_max, dt)
    # robot i: (-n) . a_i <= b / 2; robot j: n . a_j <= b / 2
    rows, normals, bounds = [pairs[:, 0], pairs[:, 1]], [-n, n], [0.5 * b, 0.5 * b]
    return _solve_rows(a, rows, normals, bounds, v, obstacles, decel, gamma, a_max, dt, bound)


def _solve_rows(a, rows, normals, bounds, v, obstacles, decel, gamma, a_max, dt, bound=None):
    """The guard's QPs over the given rows, plus the obstacle rows when ``obstacles`` is given."""
    if obstacles is not None:
        r, n, b = obstacle_constraints(v, obstacles[0], obstacles[1], obstacles[2], decel, gamma, a_max, dt,
                                       obstacles[3] if len(obstacles) > 3 else None)
        rows, normals, bounds = [*rows, r], [*normals, -n], [*bounds, b]
    rows = np.concatenate(rows)
    if rows.size == 0:
        return a, 0, 0
    normals, bounds = np.concatenate(normals), np.concatenate(bounds)
    order = np.argsort(rows, kind="stable")
    rows, normals, bounds = rows[order], normals[order], bounds[order]
    starts = np.searchsorted(rows, np.arange(a.shape[0] + 1))
    out = np.ascontiguousarray(a, dtype=np.float64).copy()
    if bound is None:
        box_n, box_c = np.zeros((0, a.shape[1])), np.zeros(0)
    else:
        box_n, box_c = np.ascontiguousarray(bound[0], dtype=np.float64), np.ascontiguousarray(bound[1], dtype=np.float64)
    changed, infeasible = _guard(out, normals, bounds, starts, a_max, box_n, box_c)
    return out, changed, infeasible


def pair_guard_known(a: np.ndarray, x: np.ndarray, v: np.ndarray, kx: np.ndarray, kv: np.ndarray,
                     heard: np.ndarray, d_safe: float, decel: float, gamma: float, a_max: float, v_max: float,
                     dt: float, obstacles: tuple | None = None,
                     bound: tuple[np.ndarray, np.ndarray] | None = None) -> tuple[np.ndarray, int, int]:
    """:func:`pair_guard` on a network (docs/network.md): robot i keeps its half of the bound of
    every pair (i, j) it has heard, from its own state and its picture ``kx[i, j]``, ``kv[i, j]``
    of robot j (N, N, D), trusting j to keep the other half. Obstacles are its own sensing, as in
    :func:`pair_guard`."""
    n_robots = x.shape[0]
    reach = pair_reach(d_safe, decel, gamma, a_max, v_max)
    i, j = np.nonzero(heard & ~np.eye(n_robots, dtype=bool))
    dp = x[i] - kx[i, j]
    near = np.einsum("pd,pd->p", dp, dp) < reach * reach
    i, j, dp = i[near], j[near], dp[near]
    n, b = _barrier(dp, v[i] - kv[i, j], d_safe, decel, gamma, dt)
    keep = b < 2.0 * a_max
    return _solve_rows(a, [i[keep]], [-n[keep]], [0.5 * b[keep]], v, obstacles, decel, gamma, a_max, dt, bound)


@njit(cache=True)
def _guard(a, normals, bounds, starts, a_max, box_n, box_c):
    """Each robot's command, cut to ``a_max``, moved in place to the nearest point of its
    half-spaces ``g . a <= c`` (rows ``starts[r]:starts[r + 1]``) when it breaks one; when that
    point breaks one of the bound's rows ``box_n . a <= box_c`` (none: no rows), solved again
    with them added."""
    n_robots, dim = a.shape
    changed = 0
    infeasible = 0
    for r in range(n_robots):
        lo, hi = starts[r], starts[r + 1]
        if hi == lo:
            continue
        p0 = a[r].copy()
        nrm = np.sqrt(np.sum(p0 * p0))
        if nrm > a_max:
            p0 *= a_max / nrm
        if _worst(p0, normals, bounds, lo, hi) <= TOL:
            continue
        changed += 1
        best, ok = _nearest(p0, normals, bounds, lo, hi)
        k = box_n.shape[0]
        if ok and k > 0 and _worst(best, box_n, box_c, 0, k) > TOL:
            m = hi - lo
            both_n = np.empty((m + k, normals.shape[1]))
            both_c = np.empty(m + k)
            both_n[:m] = normals[lo:hi]
            both_c[:m] = bounds[lo:hi]
            both_n[m:] = box_n
            both_c[m:] = box_c
            inner, inside = _nearest(p0, both_n, both_c, 0, m + k)
            if inside:
                best = inner
            else:  # no command within the bound meets every constraint: as without the bound
                ok = False
        if not ok:
            infeasible += 1
        a[r] = best
    return changed, infeasible


@njit(cache=True)
def _worst(p, normals, bounds, lo, hi):
    """Largest violation ``g . p - c`` over rows lo:hi."""
    worst = -np.inf
    for c in range(lo, hi):
        w = -bounds[c]
        for k in range(p.shape[0]):
            w += normals[c, k] * p[k]
        worst = max(worst, w)
    return worst


@njit(cache=True)
def _nearest(p0, normals, bounds, lo, hi):
    """Nearest point to ``p0`` of ``{a : g . a <= c}`` (rows lo:hi), D <= 3: the projection onto
    every set of at most D constraint planes, the first with non-negative multipliers that meets
    every constraint being the unique KKT point. None: the point that breaks them least."""
    dim = p0.shape[0]
    m = hi - lo
    best = p0.copy()
    best_worst = np.inf
    best_dist = np.inf
    idx = np.empty(3, np.int64)
    cand = np.empty(dim)
    for size in range(1, min(dim, m) + 1):
        # every subset of `size` rows, in lexicographic order
        for k in range(size):
            idx[k] = k
        while True:
            ok = _project(p0, normals, bounds, lo, idx, size, cand)
            if ok >= 0:
                w = _worst(cand, normals, bounds, lo, hi)
                if ok == 1 and w <= TOL:
                    return cand.copy(), True
                dist = np.sum((cand - p0) ** 2)
                if w < best_worst - TOL or (w <= best_worst + TOL and dist < best_dist):
                    best_worst, best_dist = w, dist
                    best[:] = cand
            # next subset
            k = size - 1
            while k >= 0 and idx[k] == m - size + k:
                k -= 1
            if k < 0:
                break
            idx[k] += 1
            for q in range(k + 1, size):
                idx[q] = idx[q - 1] + 1
    return best, False


@njit(cache=True)
def _project(p0, normals, bounds, lo, idx, size, out):
    """``out`` = projection of ``p0`` onto the planes ``g . a = c`` of rows lo + idx[:size].
    Returns -1 if they are dependent, 1 if every multiplier is >= 0 (a KKT candidate), else 0."""
    dim = p0.shape[0]
    gram = np.empty((size, size))
    res = np.empty(size)
    for u in range(size):
        cu = lo + idx[u]
        res[u] = -bounds[cu]
        for k in range(dim):
            res[u] += normals[cu, k] * p0[k]
        for w in range(size):
            cw = lo + idx[w]
            s = 0.0
            for k in range(dim):
                s += normals[cu, k] * normals[cw, k]
            gram[u, w] = s
    lam = np.empty(size)
    if not _solve_small(gram, res, size, lam):
        return -1
    kkt = 1
    for u in range(size):
        if lam[u] < 0.0:
            kkt = 0
    for k in range(dim):
        out[k] = p0[k]
        for u in range(size):
            out[k] -= lam[u] * normals[lo + idx[u], k]
    return kkt


@njit(cache=True)
def _solve_small(m, r, size, out):
    """Solve ``m out = r`` for a symmetric 1x1, 2x2 or 3x3 ``m`` by Cramer's rule; False if singular."""
    if size == 1:
        if m[0, 0] < 1e-12:
            return False
        out[0] = r[0] / m[0, 0]
        return True
    if size == 2:
        det = m[0, 0] * m[1, 1] - m[0, 1] * m[1, 0]
        if abs(det) < 1e-12:
            return False
        out[0] = (r[0] * m[1, 1] - m[0, 1] * r[1]) / det
        out[1] = (m[0, 0] * r[1] - r[0] * m[1, 0]) / det
        return True
    det = (m[0, 0] * (m[1, 1] * m[2, 2] - m[1, 2] * m[2, 1]) - m[0, 1] * (m[1, 0] * m[2, 2] - m[1, 2] * m[2, 0])
           + m[0, 2] * (m[1, 0] * m[2, 1] - m[1, 1] * m[2, 0]))
    if abs(det) < 1e-12:
        return False
    for c in range(3):
        t = m.copy()
        for q in range(3):
            t[q, c] = r[q]
        out[c] = (t[0, 0] * (t[1, 1] * t[2, 2] - t[1, 2] * t[2, 1]) - t[0, 1] * (t[1, 0] * t[2, 2] - t[1, 2] * t[2, 0])
                  + t[0, 2] * (t[1, 0] * t[2, 1] - t[1, 1] * t[2, 0])) / det
    return True
