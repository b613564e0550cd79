"""Rotor downwash: the air velocity [m/s] each vehicle sits in from the wakes of the vehicles above it.

Each vehicle's rotors act as one equivalent actuator disc of area A = n_rotors pi r^2 (radius
R = sqrt(n_rotors) r) and thrust T, its wake a vertical round jet below it. Far below, a round
jet depends only on its momentum flux (the thrust), so the one disc is exact there; within a few
rotor radii, where the rotors' wakes are still apart, it is an approximation. The model joins two
classical results, both in closed form:

Near wake: momentum theory for the hovering disc (Leishman, Principles of Helicopter
Aerodynamics, 2nd ed., 2006, Sec. 2.3): induced velocity v_h = sqrt(T / (2 rho A)) at the disc,
2 v_h in the fully contracted wake of area A / 2. Between the two, the on-axis velocity of the
uniformly loaded disc's semi-infinite vortex cylinder (Branlard and Gaunaa, "Cylindrical vortex
wake model: right cylinder", Wind Energy 18, 2015, eq. for the axis):

    U_near(z) = v_h (1 + z / sqrt(z^2 + R^2)),   z [m] the depth below the disc.

Far wake: a self-similar turbulent round jet issuing from the contracted wake (diameter
D_j = sqrt(2) R, velocity 2 v_h), whose centreline velocity falls as 1 / z (Pope, Turbulent
Flows, 2000, Sec. 5.1, Table 5.1: U_c = 2 v_h B D_j / z, B = 5.8 from Hussein, Capp and George,
J. Fluid Mech. 258, 1994). The centreline velocity is the smaller of the two,

    U_c(z) = min(U_near(z), 2 sqrt(2) B v_h R / z),

the near wake ruling to z = 8.2 R and the jet below. Across the wake the profile is Gaussian,
u(z, r) = U_c exp(-ln 2 r^2 / r_half^2), r [m] the horizontal distance from the source's axis,
with the half-width r_half that carries the wake's momentum flux rho A v_h U_near(z) (which grows
to the thrust T as the wake contracts):

    r_half^2 = 2 ln 2 R^2 v_h U_near / U_c^2.

At the disc r_half = 1.18 R; in the far wake r_half = 0.102 z, the spreading rate Pope's Table 5.1
gives for round jets (0.094 to 0.102): the momentum balance reproduces the measured spreading.

Carried wake (ours, optional). The air leaving a disc keeps the horizontal velocity of the air
around it, so in a cross-wind, or behind a moving source, the wake lies where the air has carried
it: the air released at depth z left the disc tau(z) = integral of dz / U_c earlier, and the
wake's axis at depth z is displaced by w_h tau(z), w_h the horizontal air velocity relative to the
source (wind minus the source's velocity). In closed form, tau = (R / v_h) G(z / R) with
G(x) = x + x^3 / 3 - ((x^2 + 1)^(3/2) - 1) / 3 in the near wake and G growing by
(x^2 - x*^2) / (4 sqrt(2) B) beyond its end x* = 8.2. This is the skewed wake of a rotor in
edgewise flow (Leishman Sec. 2.14) drawn with the hover wake's strength: the drop of the induced
velocity in edgewise flow (Glauert) is not modelled, so a strong cross-wind's wake is placed
right but overstated.

Validity: a hovering source. The wake's axis is vertical (or carried as above): a tilted source
is not modelled, nor the entrainment's radial inflow or the turbulence of the wake; wakes of
several sources are summed (an upper bound: jets do not superpose linearly). The jet law holds
in still, quiet air; ambient turbulence mixes a real wake out sooner, and ``cutoff`` ends each
wake at a stated depth. A vehicle level with or above a source feels nothing of it (the inflow
above a disc is neglected).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from swarmnav.params import build, param


@dataclass(frozen=True, slots=True)
class DownwashParams:
    """The downwash model's constants (module docstring)."""

    rho: float = param(1.225, "kg/m^3", "(0, 2]", "ISA sea level",
                       "air density")
    decay: float = param(5.8, "", "[1, 20]", "Pope 2000 Table 5.1 (Hussein et al. 1994)",
                         "velocity-decay constant B of the round turbulent jet: U_c = 2 v_h B D_j / z")
    cutoff: float = param(10.0, "m", "(0, 1000]", "ours",
                          "depth below a vehicle beyond which its wake is ignored")


def downwash_params(**values) -> DownwashParams:
    """The downwash constants from named values (unknown or out of range: one-line ConfigError)."""
    return build(DownwashParams, values, context="downwash")


def induced_velocity(thrust, rotor_radius: float, n_rotors: int = 4, rho: float = 1.225):
    """Momentum-theory induced velocity at the disc in hover, v_h = sqrt(T / (2 rho A)) [m/s],
    A = n_rotors pi r^2 [m^2], for thrust ``thrust`` [N] (negative counts as 0)."""
    area = n_rotors * math.pi * rotor_radius**2
    return np.sqrt(np.maximum(thrust, 0.0) / (2.0 * rho * area))


def descent_time(depth, v_h, rotor_radius: float, n_rotors: int = 4, decay: float = 5.8):
    """tau(z) [s]: how long ago the air now at ``depth`` z [m] below a disc of induced velocity
    ``v_h`` [m/s] left it, the integral of dz / U_c (module docstring); inf where v_h = 0."""
    R = math.sqrt(n_rotors) * rotor_radius
    with np.errstate(divide="ignore"):
        return R / np.asarray(v_h, dtype=np.float64) * _descent(np.asarray(depth, dtype=np.float64) / R, decay)


def _descent(x: np.ndarray, decay: float) -> np.ndarray:
    """G(x) = tau v_h / R at depth x = z / R (module docstring)."""
    xs = _near_end(decay)
    g_near = lambda y: y + y**3 / 3.0 - ((y * y + 1.0) ** 1.5 - 1.0) / 3.0  # noqa: E731
    xn = np.minimum(x, xs)
    return g_near(xn) + (np.maximum(x, xs) ** 2 - xs * xs) / (4.0 * math.sqrt(2.0) * decay)


@functools.cache
def _near_end(decay: float) -> float:
    """x* where the near wake meets the jet: 1 + x / sqrt(x^2 + 1) = 2 sqrt(2) B / x (bisection;
    the left side rises and the right falls, so the root is unique)."""
    k = 2.0 * math.sqrt(2.0) * decay
    lo, hi = 1e-9, k
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if 1.0 + mid / math.sqrt(mid * mid + 1.0) < k / mid:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


def downwash_air(pos: np.ndarray, thrust: np.ndarray, rotor_radius: float, n_rotors: int = 4,
                 params: DownwashParams = DownwashParams(), *, carry: np.ndarray | None = None) -> np.ndarray:
    """The air velocity (N, d) [m/s] at each vehicle from the wakes of every vehicle above it.

    Args:
        pos: (N, 3) positions [m], z up; (N, 2) for a planar scene, where no vehicle is below another
            (zeros).
        thrust: (N,) each vehicle's collective thrust now [N].
        rotor_radius: the radius of one rotor [m]; the vehicle's rotors are one disc of area
            n_rotors pi r^2.
        n_rotors: rotors per vehicle.
        params: the model's constants.
        carry: (N, 3) or (3,) air velocity relative to each source [m/s] (the air at it minus its
            velocity) whose horizontal part carries its wake (module docstring); None: vertical wakes.

    Returns:
        (N, d): downward (-z) air velocity, the sum of the sources' wakes u(z, r) (module docstring);
        a vehicle does not wash itself, and one level with or above a source, or more than
        ``params.cutoff`` below it, gets nothing from it. A compiled loop over all N^2 pairs.
    """
    pos = np.asarray(pos, dtype=np.float64)
    n, d = pos.shape
    out = np.zeros((n, d))
    if d < 3 or n < 2:
        return out
    v_h = induced_velocity(np.asarray(thrust, dtype=np.float64), rotor_radius, n_rotors, params.rho)  # (N,)
    v_h = np.ascontiguousarray(np.broadcast_to(v_h, (n,)))
    w = np.zeros((n, 3)) if carry is None else np.ascontiguousarray(
        np.broadcast_to(np.asarray(carry, dtype=np.float64), (n, 3)))
    _wash(np.ascontiguousarray(pos), v_h, w, carry is not None, math.sqrt(n_rotors) * rotor_radius,
          float(params.decay), float(params.cutoff), _near_end(float(params.decay)), out[:, 2])
    return out


@njit(cache=True)
def _wash(pos, v_h, w, carried, R, decay, cutoff, xs, out_z):
    """:func:`downwash_air`'s sum over pairs into ``out_z`` (N,): target i, source j above it."""
    n = pos.shape[0]
    k = 2.0 * math.sqrt(2.0) * decay
    for i in range(n):
        acc = 0.0
        for j in range(n):
            dz = pos[j, 2] - pos[i, 2]
            if v_h[j] <= 0.0 or dz <= 0.0 or dz > cutoff:
                continue
            x = dz / R
            near = 1.0 + x / math.sqrt(x * x + 1.0)
            f = min(near, k / x)
            dx = pos[i, 0] - pos[j, 0]
            dy = pos[i, 1] - pos[j, 1]
            if carried:  # the wake's axis at this depth, carried by the air since it left the disc
                xn = min(x, xs)
                xf = max(x, xs)
                q = xn * xn + 1.0
                tau = R / v_h[j] * (xn + xn * xn * xn / 3.0 - (q * math.sqrt(q) - 1.0) / 3.0
                                    + (xf * xf - xs * xs) / (2.0 * k))
                dx -= w[j, 0] * tau
                dy -= w[j, 1] * tau
            rr = (dx * dx + dy * dy) / (R * R)
            # u = U_c exp(-ln2 r^2 / r_half^2), r_half^2 = 2 ln2 R^2 v_h U_near / U_c^2: v_h cancels
            acc += v_h[j] * f * math.exp(-0.5 * rr * f * f / near)
        out_z[i] = -acc
