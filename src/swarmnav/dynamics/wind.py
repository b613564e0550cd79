"""Wind: a mean wind plus Dryden turbulence, as the air velocity [m/s] at each vehicle.

Mean wind. ``speed`` [m/s] in the horizontal plane, blowing TOWARD ``direction`` [deg], counted
counter-clockwise from the scene's +x axis (a scene has no north, so the meteorological "from"
bearing would only add a sign flip): mean = speed (cos direction, sin direction, 0).

Turbulence. The Dryden form of MIL-F-8785C's continuous random turbulence at low altitude
(h < 1000 ft), as MIL-HDBK-1797 repeats it: three zero-mean Gaussian gust components in the wind axes (u along the mean wind,
v horizontal and 90 deg counter-clockwise from it, w vertical, +z) with the one-sided spectra in
temporal frequency omega [rad/s], for a vehicle that sees the frozen turbulence field carried past
it at speed V,

    Phi_u(omega) = sigma_u^2 (2 L_u / (pi V)) / (1 + (L_u omega / V)^2)
    Phi_v(omega) = sigma_v^2 (L_v / (pi V)) (1 + 3 (L_v omega / V)^2) / (1 + (L_v omega / V)^2)^2

(Phi_w as Phi_v with L_w, sigma_w), whose autocorrelations are R_u(tau) = sigma_u^2 exp(-tau/T_u)
and R_v(tau) = sigma_v^2 exp(-tau/T_v) (1 - tau / (2 T_v)), T = L / V. Low-altitude scale
lengths and intensity ratios, h the altitude in ft clamped to [10, 1000] ft as the standard's
tables end there:

    L_w = h,   L_u = L_v = h / (0.177 + 0.000823 h)^1.2,   sigma_u / sigma_w = sigma_v / sigma_w
    = 1 / (0.177 + 0.000823 h)^0.4,   and the standard's sigma_w = 0.1 W20 (W20: wind at 20 ft).

``gust`` [m/s] is sigma_u = sigma_v, the standard deviation of each horizontal gust component;
sigma_w follows from the ratio above. :func:`standard_gust` turns the standard's W20 (light,
moderate, severe: 15, 30, 45 kt) into ``gust``. The advection speed is V = max(speed, v_min): a
vehicle that hovers in calm air with turbulence still sees the field move (``v_min``, ours).

Realisation. Each component is the output of its shaping filter (first order for u, second order
(1 + sqrt(3) T s) / (1 + T s)^2 for v and w) driven by white noise, discretised exactly for the
step dt: x_{k+1} = Phi x_k + q_k with Phi = exp(A dt) and q_k ~ N(0, Q_d), Q_d the exact
covariance of the noise integrated over one step (Van Loan's method), and x_0 drawn from the
stationary covariance. The samples are therefore exact samples of the continuous process at t = k
dt: the variance and autocorrelation do not depend on dt and hold from the first step.

One field or one per vehicle. The Dryden correlation of two points r apart is about exp(-r / L);
at the default altitude (10 m) L_u = 67 m and L_w = 10 m, against a swarm spacing of a few metres,
so neighbours feel nearly the same gust and the turbulence moves the swarm together more than it
moves its members apart. ``coherence`` (the fraction c of the gust variance the swarm shares)
makes the choice a parameter: gust_i = sqrt(c) g_shared + sqrt(1 - c) g_i, with g_shared and every
g_i independent Dryden processes of the same spectra, so each vehicle's gust keeps the Dryden
spectrum at any c and two vehicles' gusts have correlation c. The default c = 1 (one field for the
swarm, the frozen-turbulence limit for a swarm small against L_u); c = 0 is the worst case of
independent gusts. The field is uniform over the swarm: positions enter only through their count
and dimension.

Draws come from a stream of their own, ``SeedSequence([seed, TAG])`` (the shared process from one
child, the vehicles' own from another), so a method's draws are unchanged, the same seed gives the
same gusts, and the shared gust does not depend on the coherence or the swarm size.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.linalg import expm, solve_continuous_lyapunov

from swarmnav.params import build, param

#: The stream tag of wind draws ("wnd"): SeedSequence([seed, TAG]).
TAG = 0x776E64
#: [m] one foot: the standard's tables are in feet.
FT = 0.3048
#: [ft] the altitude range of the standard's low-altitude model.
H_MIN_FT, H_MAX_FT = 10.0, 1000.0
#: [m/s] the standard's W20 (wind at 20 ft) of light, moderate and severe turbulence: 15, 30, 45 kt.
W20 = {"light": 15 * 0.514444, "moderate": 30 * 0.514444, "severe": 45 * 0.514444}


@dataclass(frozen=True, slots=True)
class WindParams:
    """The wind of a run (module docstring). Defaults: calm air."""

    speed: float = param(0.0, "m/s", "[0, 30]", "ours",
                         "mean wind speed, horizontal")
    direction: float = param(0.0, "deg", "[-360, 360]", "ours",
                             "direction the mean wind blows toward, counter-clockwise from +x")
    gust: float = param(0.0, "m/s", "[0, 10]", "MIL-F-8785C (Dryden form)",
                        "standard deviation of each horizontal gust component (sigma_u = sigma_v); the "
                        "vertical sigma_w follows from the standard's ratio at the altitude; 0: no turbulence")
    altitude: float = param(10.0, "m", "(0, 304.8]", "MIL-F-8785C (low altitude)",
                            "altitude that sets the Dryden scale lengths and sigma_w / sigma_u; below 3.048 m "
                            "(10 ft) the standard's 10 ft values")
    coherence: float = param(1.0, "", "[0, 1]", "ours",
                             "fraction of the gust variance the swarm shares: 1 one gust for every vehicle, "
                             "0 independent gusts per vehicle")
    v_min: float = param(1.0, "m/s", "(0, 30]", "ours",
                         "least speed at which the turbulence field moves past a vehicle (Taylor's frozen "
                         "field): the advection speed is max(speed, v_min)")

    @property
    def calm(self) -> bool:
        """No wind at all: zero mean and zero turbulence."""
        return self.speed == 0.0 and self.gust == 0.0


def wind_params(**values) -> WindParams:
    """The wind from named values (``speed=6, gust=1.5``; strings as from ``--set`` are coerced).

    Raises:
        ConfigError: an unknown name, a non-finite value or one outside its range (one line).
    """
    return build(WindParams, values, context="wind")


def scale_lengths(altitude: float) -> tuple[float, float, float]:
    """The Dryden low-altitude scale lengths (L_u, L_v, L_w) [m] at ``altitude`` [m] (MIL-F-8785C)."""
    h = _feet(altitude)
    lu = h / (0.177 + 0.000823 * h) ** 1.2
    return lu * FT, lu * FT, h * FT


def intensities(gust: float, altitude: float) -> tuple[float, float, float]:
    """(sigma_u, sigma_v, sigma_w) [m/s] for horizontal gust ``gust`` [m/s] at ``altitude`` [m]."""
    h = _feet(altitude)
    return gust, gust, gust * (0.177 + 0.000823 * h) ** 0.4


def standard_gust(w20: float, altitude: float) -> float:
    """``gust`` [m/s] (sigma_u) of the standard's low-altitude turbulence for wind ``w20`` [m/s] at
    20 ft: sigma_w = 0.1 W20 and sigma_u = sigma_w / (0.177 + 0.000823 h)^0.4 (MIL-F-8785C).
    ``standard_gust(W20["moderate"], 10.0)`` is 2.9 m/s."""
    return 0.1 * w20 / (0.177 + 0.000823 * _feet(altitude)) ** 0.4


def _feet(altitude: float) -> float:
    return min(max(altitude / FT, H_MIN_FT), H_MAX_FT)


def dryden_filters(T: tuple[float, float, float], dt: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The exact discrete shaping filters of the three components with time constants ``T`` [s]
    (u first order, v and w second order) for step ``dt`` [s], as one 5-state block system:
    ``(Phi, L_q, L_0, C)`` with x_{k+1} = Phi x_k + L_q xi_k, x_0 = L_0 xi, y = x C (one unit-variance
    output column per component); xi standard normal."""
    blocks = [_filter(T[0], dt, second=False), _filter(T[1], dt, second=True), _filter(T[2], dt, second=True)]
    Phi, Lq, L0, C = np.zeros((5, 5)), np.zeros((5, 5)), np.zeros((5, 5)), np.zeros((5, 3))
    i = 0
    for k, (phi, lq, l0, c) in enumerate(blocks):
        m = phi.shape[0]
        Phi[i:i + m, i:i + m], Lq[i:i + m, i:i + m], L0[i:i + m, i:i + m] = phi, lq, l0
        C[i:i + m, k] = c
        i += m
    return Phi, Lq, L0, C


def _filter(T: float, dt: float, second: bool):
    """One shaping filter, unit white-noise intensity, output scaled to unit variance."""
    if second:  # (1 + sqrt(3) T s) / (1 + T s)^2, controllable canonical form
        A = np.array([[0.0, 1.0], [-1.0 / T**2, -2.0 / T]])
        B = np.array([[0.0], [1.0]])
        c = np.array([1.0, math.sqrt(3.0) * T])
    else:  # 1 / (1 + T s)
        A = np.array([[-1.0 / T]])
        B = np.array([[1.0]])
        c = np.array([1.0])
    m = A.shape[0]
    P = solve_continuous_lyapunov(A, -B @ B.T)  # stationary covariance: A P + P A' + B B' = 0
    phi = expm(A * dt)
    if dt <= T:  # Van Loan: expm([[-A, BB'], [0, A']] dt) = [[., F12], [0, F22]], Q_d = F22' F12
        M = np.zeros((2 * m, 2 * m))
        M[:m, :m], M[:m, m:], M[m:, m:] = -A, B @ B.T, A.T
        F = expm(M * dt)
        Q = F[m:, m:].T @ F[:m, m:]
    else:  # a step longer than the filter's memory: Q_d = P - Phi P Phi' (no cancellation, exp(-A dt) would overflow)
        Q = P - phi @ P @ phi.T
    Q = 0.5 * (Q + Q.T)
    c = c / math.sqrt(c @ P @ c)
    return phi, _sqrt_psd(Q), _sqrt_psd(P), c


def _sqrt_psd(S: np.ndarray) -> np.ndarray:
    """An L with L L' = S for a symmetric positive semi-definite S: its Cholesky factor, or from its
    eigen-decomposition when rounding leaves S singular."""
    try:
        return np.linalg.cholesky(S)
    except np.linalg.LinAlgError:
        w, V = np.linalg.eigh(S)
        return V * np.sqrt(np.clip(w, 0.0, None))


class Wind:
    """The wind of one run (module docstring): ``air(t, pos)`` once per method step."""

    def __init__(self, params: WindParams, n: int, dt: float, seed: int):
        if not dt > 0:
            raise ValueError(f"dt must be positive, got {dt}")
        self.p = params
        self.n, self.dt = int(n), float(dt)
        th = math.radians(params.direction)
        c, s = math.cos(th), math.sin(th)
        self.mean = np.array([params.speed * c, params.speed * s, 0.0])  # [m/s]
        self.axes = np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])  # rows: e_u, e_v, e_w
        self.k = 0  # the step index of the gust state held
        self.turbulent = params.gust > 0.0
        if not self.turbulent:
            return
        V = max(params.speed, params.v_min)
        L = scale_lengths(params.altitude)
        self.sigma = np.array(intensities(params.gust, params.altitude))  # [m/s]
        self.Phi, self.Lq, L0, C = dryden_filters(tuple(l / V for l in L), self.dt)
        # output in world axes, scaled: gust (rows) = x C diag(sigma) axes
        self.out = C @ (self.sigma[:, None] * self.axes)
        shared, own = np.random.SeedSequence([int(seed), TAG]).spawn(2)
        self.rng_shared = np.random.default_rng(shared)
        self.rng_own = np.random.default_rng(own)
        self.a = math.sqrt(params.coherence)
        self.b = math.sqrt(1.0 - params.coherence)
        self.x_shared = self.rng_shared.standard_normal((1, 5)) @ L0.T
        self.x_own = self.rng_own.standard_normal((self.n, 5)) @ L0.T if self.b > 0 else None

    def gust(self) -> np.ndarray:
        """The gust (N, 3) [m/s] of the state held, world axes (zeros without turbulence)."""
        if not self.turbulent:
            return np.zeros((self.n, 3))
        g = self.a * (self.x_shared @ self.out)
        if self.x_own is not None:
            g = g + self.b * (self.x_own @ self.out)
        return np.broadcast_to(g, (self.n, 3))

    def air(self, t: float, pos: np.ndarray) -> np.ndarray:
        """The air velocity (N, d) [m/s] at each vehicle at time ``t`` [s] = k dt: the mean wind plus
        the gust of step k (the state advances by the steps since the last call; the first state is
        that of t = 0). ``pos`` (N, d), d = 3, or 2 for a planar scene (the horizontal components)."""
        pos = np.asarray(pos)
        if pos.ndim != 2 or pos.shape[0] != self.n or pos.shape[1] not in (2, 3):
            raise ValueError(f"pos must be ({self.n}, 2 or 3), got {pos.shape}")
        d = pos.shape[1]
        if not self.turbulent:
            return np.broadcast_to(self.mean[:d], (self.n, d)).copy()
        k = round(t / self.dt)
        if k < self.k:
            raise ValueError(f"wind time went back: t = {t} s after step {self.k}")
        for _ in range(k - self.k):
            self.x_shared = self.x_shared @ self.Phi.T + self.rng_shared.standard_normal((1, 5)) @ self.Lq.T
            if self.x_own is not None:
                self.x_own = self.x_own @ self.Phi.T + self.rng_own.standard_normal((self.n, 5)) @ self.Lq.T
        self.k = k
        return (self.mean + self.gust())[:, :d]
