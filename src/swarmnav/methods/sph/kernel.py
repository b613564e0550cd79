"""SPH interaction of the SPH paper (Section III-A): cubic-spline kernel, eq. (4), and the
forces of Algorithm 1. Pure array functions of (N, D) positions; any dimension D.

Two kernel evaluations are offered:

``"paper"`` (default), eq. (4) as printed::

    W(r, h) = c / (pi h^3) * { 1 - 3/2 k^2 + 3/4 k^3   0 <= k <= 1
                             { 1/4 (2 - k)^3           1 <  k <= 2
                             { 0                       otherwise,      k = r / h

    grad_i W(q_ij) = c / (pi h^3) * f'(k) / h * q_ij / r,   q_ij = q_i - q_j.

``1 / (pi h^3)`` is the three-dimensional normalisation of this cubic spline (Monaghan &
Lattanzio 1985): over space the printed kernel integrates to exactly ``c``, so in 3-D eq. (4)
is used as printed. Over the plane it integrates to ``7 c / (10 h)`` (the 2-D normalisation
would be ``10 / (7 pi h^2)``); 2-D flights keep the printed form too. The normalisation is a
constant factor on every W, and with ``rho << rho0`` line 8 reads
``k_den sum grad W / sum W``, in which it cancels: it does not change a flight.

``"released"``: what the authors' C++ (``water_swarm/src/sph_zhang_3d.cpp``,
``SPHSystem::parallelDensityAndPressures``) computes. Its literals are integer divisions, so
``3/2 -> 1``, ``3/4 -> 0``, ``1/4 -> 0``, ``9/4 -> 2`` and ``-3/4 -> 0``; the normalisation is
the 2-D one, ``10 c / (7 pi h^2)``; and the hand-written "gradient" ``-3k + 9/4 k^2`` is
multiplied by ``h`` instead of divided by it::

    W = 10 c / (7 pi h^2) * { 1 - k^2    k <= 1           grad = 10 c / (7 pi h^2) * h * { -3k + 2 k^2   k <= 1
                            { 0          otherwise                                       { 0             otherwise
"""

from __future__ import annotations

import math
from typing import Literal

import numpy as np
from numba import njit

Kernel = Literal["paper", "released"]


def kernel_sigma(c: float, h: float, kind: Kernel = "paper") -> float:
    """Normalisation of the kernel [1/m^3 for "paper"]: ``c / (pi h^3)`` (eq. 4) or the
    released ``10 c / (7 pi h^2)``."""
    if kind == "paper":
        return c / (math.pi * h**3)
    return 10.0 * c / (7.0 * math.pi * h**2)


def kernel_value(r: np.ndarray, h: float, c: float, kind: Kernel = "paper") -> np.ndarray:
    """W(r, h) of eq. (4) (or its released evaluation) for distances ``r`` [m]."""
    k = np.asarray(r, dtype=float) / h
    if kind == "paper":
        f = np.where(k <= 1.0, 1.0 - 1.5 * k**2 + 0.75 * k**3, np.where(k <= 2.0, 0.25 * (2.0 - k) ** 3, 0.0))
    else:
        f = np.where(k <= 1.0, 1.0 - k**2, 0.0)
    return kernel_sigma(c, h, kind) * f


def kernel_slope(r: np.ndarray, h: float, c: float, kind: Kernel = "paper") -> np.ndarray:
    """Radial derivative used for ``grad_i W = slope(r) * q_ij / r``.

    "paper": the exact ``dW/dr = sigma f'(k) / h``. "released": ``sigma * h * (-3k + 2k^2)``
    for ``k <= 1`` and 0 beyond, as the released code evaluates it.
    """
    k = np.asarray(r, dtype=float) / h
    sigma = kernel_sigma(c, h, kind)
    if kind == "paper":
        df = np.where(k <= 1.0, -3.0 * k + 2.25 * k**2, np.where(k <= 2.0, -0.75 * (2.0 - k) ** 2, 0.0))
        return sigma * df / h
    return sigma * h * np.where(k <= 1.0, -3.0 * k + 2.0 * k**2, 0.0)


def sph_forces(
    x: np.ndarray,
    v: np.ndarray,
    i: np.ndarray,
    j: np.ndarray,
    *,
    h: float,
    c: float,
    m: float,
    k_den: float,
    k_rep: float,
    k_vis: float,
    rho0: float,
    gamma: float,
    kind: Kernel = "paper",
    r_floor: float = 0.05,
    rep_cutoff: float = 0.0,
) -> tuple[np.ndarray, np.ndarray, dict[str, np.ndarray]]:
    """Density, pressure/density force, repulsion and viscosity of Algorithm 1 (lines 5-10).

    Args:
        x: (N, D) positions [m]; v: (N, D) velocities [m/s].
        i, j: (P,) unordered interacting pairs (both directions are applied): only the
            visible neighbours within R (Algorithm 2) are passed in.
        r_floor: distances are floored here in the 1/r repulsion [m] (a finite force at
            coincident agents; our choice, never reached in a collision-free run).
        rep_cutoff: 0 (the paper): line 9 sums over every pair passed in. Positive: only pairs
            closer than ``rep_cutoff`` [m] repel, with line 9's unchanged 1/r (a hard cut, as the
            released code's neighbour search cuts every pair term at 2h; ours,
            docs/methods/sph-crowd.md).

    Returns:
        ``(force (N, D), density (N,), parts)``: the sum of the three inter-agent terms
        [m/s^2 per unit mass], the density rho_i (line 5, self term m W(0) included, as in
        standard SPH and the released code), and the terms separately
        (``"density"``, ``"repulsive"``, ``"viscosity"``).

    Line 8: ``F_den_i = -k_den / rho_i [(rho_i/rho0)^gamma - 1] sum_j grad_i W(q_ij)``; with
    W decreasing, ``grad_i W`` points from i towards j, so below the reference density the
    term attracts. Line 9: ``F_rep_i = k_rep sum_j q_ij / |q_ij|^2`` (magnitude 1/r, as the
    released code). Line 10: ``F_vis_i = -k_vis v_i``.
    """
    n = x.shape[0]
    rho = np.full(n, m * float(kernel_value(np.zeros(1), h, c, kind)[0]))
    grad_sum = np.zeros_like(x)
    rep = np.zeros_like(x)
    if len(i):
        d = x[i] - x[j]  # q_ij
        r = np.sqrt(np.einsum("pd,pd->p", d, d))
        w = m * kernel_value(r, h, c, kind)
        rs = np.maximum(r, r_floor)
        unit = d / rs[:, None]
        g = kernel_slope(r, h, c, kind)[:, None] * unit  # grad_i W(q_ij); grad_j W(q_ji) = -g
        f = unit / rs[:, None]  # q_ij / |q_ij|^2
        if rep_cutoff > 0:  # ours: no repulsion from robots beyond the cut-off
            f[r >= rep_cutoff] = 0.0
        _scatter_pairs(i, j, w, g, f, rho, grad_sum, rep)
    pressure = -k_den / rho * ((rho / rho0) ** gamma - 1.0)
    parts = {
        "density": pressure[:, None] * grad_sum,
        "repulsive": k_rep * rep,
        "viscosity": -k_vis * v,
    }
    return parts["density"] + parts["repulsive"] + parts["viscosity"], rho, parts


@njit(cache=True)
def _scatter_pairs(i, j, w, g, f, rho, grad_sum, rep):
    """The pair terms summed per agent, in the order of ``np.add.at`` (pairs in order, first the
    ``i`` ends, then the ``j`` ends: the same sums to the last bit): ``rho[i] += w``,
    ``rho[j] += w``, ``grad_sum[i] += g``, ``grad_sum[j] -= g``, ``rep[i] += f``, ``rep[j] -= f``."""
    P, D = g.shape
    for p in range(P):
        rho[i[p]] += w[p]
    for p in range(P):
        rho[j[p]] += w[p]
    for p in range(P):
        for k in range(D):
            grad_sum[i[p], k] += g[p, k]
    for p in range(P):
        for k in range(D):
            grad_sum[j[p], k] += -g[p, k]
    for p in range(P):
        for k in range(D):
            rep[i[p], k] += f[p, k]
    for p in range(P):
        for k in range(D):
            rep[j[p], k] += -f[p, k]


def environment_force(d: np.ndarray, grad_d: np.ndarray, k_env: float, d_thr: float) -> np.ndarray:
    """Obstacle force from the ESDF, eqs. (5)-(6): ``-k_env grad F`` with
    ``F = (d - d_thr)^2`` for ``d < d_thr`` and 0 beyond.

    Algorithm 1 line 11 prints ``+k_env grad F``; since F grows towards the obstacle, that
    would pull agents into it, so the force is the negative gradient,
    ``2 k_env (d_thr - d) grad d``, pointing away from the obstacle [m/s^2].
    """
    pen = np.where(d < d_thr, d_thr - d, 0.0)
    pen = np.where(np.isfinite(pen), pen, 0.0)
    return (2.0 * k_env * pen)[:, None] * grad_d


def released_environment_force(d: np.ndarray, grad_d: np.ndarray, k_force: float, d_safe: float) -> np.ndarray:
    """Obstacle force of the released code (``bspline_opt_3d.cpp``, ``calcGradForce``):
    ``k_force (d - d_safe)^2`` along the unit ESDF gradient for ``d <= d_safe``, 0 beyond [m/s^2].

    Quadratic where eqs. (5)-(6) are linear: weak at the edge of the band, a stiff wall close to
    the obstacle (with the released k_force = 1000 and d_safe = 0.4 m: 2.5 m/s^2 at 0.05 m inside
    the band, 40 m/s^2 at 0.2 m). ``d`` is the distance the released ESDF measures, i.e. to the
    inflated obstacle (the caller subtracts the inflation).
    """
    pen = np.where(d <= d_safe, d - d_safe, 0.0)
    pen = np.where(np.isfinite(pen), pen, 0.0)
    norm = np.linalg.norm(grad_d, axis=1)
    unit = grad_d / np.maximum(norm, 1e-12)[:, None]
    return (k_force * pen * pen)[:, None] * unit
