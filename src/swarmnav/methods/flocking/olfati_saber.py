"""``olfati-saber``: flocking with obstacle avoidance, Algorithm 3 of Olfati-Saber (IEEE TAC 2006).

Every robot is an alpha-agent (a double integrator, ``q' = p``, ``p' = u``); its command is

    u_i = u_i^alpha + u_i^beta + u_i^gamma                                   (Algorithm 3)

- alpha (flock-mates within r):
  ``c1a sum_j phi_alpha(||q_j - q_i||_s) n_ij + c2a sum_j a_ij(q) (p_j - p_i)``;
- beta (obstacles, Section VII): every obstacle surface the robot sees within r' gives one
  beta-agent, the robot's projection onto it, moving with the robot's velocity projected on the
  surface's tangent plane: ``c1b sum_k phi_beta(||qh_k - q_i||_s) nh_k + c2b sum_k b_k (ph_k - p_i)``;
- gamma (navigational feedback): ``-c1g sigma_1(q_i - q_r) - c2g (p_i - p_r)``.

With the sigma-norm ``||z||_s = (sqrt(1 + eps ||z||^2) - 1) / eps``, its gradient
``n_ij = (q_j - q_i) / sqrt(1 + eps ||q_j - q_i||^2)``, the bump ``rho_h``, the
action function ``phi``, ``phi_alpha(z) = rho_h(z / r_a) phi(z - d_a)``,
``phi_beta(z) = rho_h(z / d_b) (sigma_1(z - d_b) - 1)``, ``a_ij = rho_h(||q_j - q_i||_s / r_a)``
 and ``b_k = rho_h(||qh_k - q_i||_s / d_b)``; ``r_a = ||r||_s``, ``d_a = ||d||_s``,
``d_b = ||d'||_s``.

Our readings where the paper is silent (docs/methods/flocking.md): the gamma-agent is static
at the scene's goal (``q_r`` = goal, ``p_r`` = 0); the beta-agents are the local minima of the
robot's own range ring (APF's sensing), each read as a point of a wall (tangent plane), since
a range sensor does not give an obstacle's radius; the flock-mates' states are the last
10 Hz broadcast each robot received; the vehicle is the SPH Table II vehicle.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from swarmnav.dynamics import SaturatedDoubleIntegrator
from swarmnav.errors import ConfigError
from swarmnav.methods.base import Observation
from swarmnav.methods.flocking.common import RangeSensor, StateBoard, pair_differences, velocity_differences
from swarmnav.methods.registry import register
from swarmnav.params import build, param
from swarmnav.world.scenario import Scenario

_OS = "Olfati-Saber 2006"


@dataclass(frozen=True, slots=True)
class OlfatiSaberParams:
    """Parameters of Algorithm 3. The paper's examples are unitless; ``paper`` reads its
    lengths as metres (Section VIII: d = 7, r = 1.2 d, d' = 0.6 d, r' = 1.2 d'); the default
    build ``swarmnav`` keeps every ratio and scales the lattice to the robots' spacing."""

    PRESETS: ClassVar[dict[str, dict[str, Any]]] = {
        "swarmnav": {},
        "paper": {"d": 7.0, "r": 8.4, "d_obs": 4.2, "r_obs": 5.04},
    }
    DEFAULT_BUILD: ClassVar[str] = "swarmnav"
    PRESET_DOCS: ClassVar[dict[str, str]] = {
        "swarmnav": "Algorithm 3 with the paper's ratios r = 1.2 d, d' = 0.6 d, r' = 1.2 d' on a lattice scaled to "
                    "the scenes (d = 1.2 m, chosen on training forests 1-10); nothing else of ours",
        "paper": "Algorithm 3 with the paper's Section VIII lengths read as metres (d = 7 m) and the readings its "
                 "silence forces (static gamma-agent at the goal, beta-agents from the range ring, our gains)",
    }

    dt: float = param(0.02, "s", "[0.0001, 1]", "ours", "control step (the paper is continuous-time; 50 Hz)")
    v_max: float = param(1.0, "m/s", "(0, inf)", "SPH Table I", "vehicle speed bound (the Table II vehicle)")
    a_max: float = param(1.5, "m/s^2", "(0, inf)", "SPH Table I", "vehicle acceleration bound")
    d: float = param(1.2, "m", "(0, inf)", "ours: chosen on training forests 1-10", "desired inter-agent distance d")
    r: float = param(1.44, "m", "(0, inf)", "OS06 Sec. VIII: r = 1.2 d", "interaction range r of alpha-agents")
    d_obs: float = param(0.72, "m", "(0, inf)", "OS06 Sec. VIII: d' = 0.6 d", "desired distance d' to obstacles")
    r_obs: float = param(0.864, "m", "(0, inf)", "OS06 Sec. VIII: r' = 1.2 d'", "range r' within which obstacles act")
    eps: float = param(0.1, "", "(0, inf)", "OS06 Sec. VIII", "sigma-norm parameter epsilon")
    a: float = param(5.0, "", "(0, inf)", "OS06 Sec. VIII", "action function phi: a, 0 < a <= b")
    b: float = param(5.0, "", "(0, inf)", "OS06 Sec. VIII", "action function phi: b")
    h_alpha: float = param(0.2, "", "(0, 1)", "OS06 Sec. VIII", "bump rho_h of phi_alpha and a_ij")
    h_beta: float = param(0.9, "", "(0, 1)", "OS06 Sec. VIII", "bump rho_h of phi_beta and b_ik")
    c1_alpha: float = param(15.0, "1/s^2", "[0, inf)", "ours", "alpha gradient gain c1^alpha")
    c2_alpha: float = param(7.746, "1/s", "[0, inf)", "ours: 2 sqrt(c1)", "alpha velocity-consensus gain c2^alpha")
    c1_beta: float = param(30.0, "m/s^2", "[0, inf)", "ours", "beta (obstacle) gradient gain c1^beta")
    c2_beta: float = param(10.954, "1/s", "[0, inf)", "ours: 2 sqrt(c1)", "beta velocity gain c2^beta")
    c1_gamma: float = param(4.0, "m/s^2", "[0, inf)", "ours", "gamma (goal) gain c1^gamma: pull |u| <= c1^gamma")
    c2_gamma: float = param(4.0, "1/s", "[0, inf)", "ours: 2 sqrt(c1)",
                            "gamma damping c2^gamma (free cruise speed c1/c2 = 1 m/s)")
    broadcast_hz: float = param(10.0, "Hz", "[0.01, 1000]", "ours", "rate of each robot's position+velocity message")
    n_rays: int = param(360, "", "[4, 36000]", "HES Table A1", "rays of the range ring (as APF)")
    n_rays_3d: int = param(2048, "", "[16, 100000]", "ours (as APF)", "rays of the 3-D range sphere")
    lidar_range: float = param(20.0, "m", "(0, inf)", "HES Table A1", "sensor range R_L")


# ------------------------------------------------------------------ the paper's functions


def sigma_norm(z2: np.ndarray, eps: float) -> np.ndarray:
    """The sigma-norm from the squared Euclidean norm ``z2``: ``(sqrt(1 + eps z2) - 1) / eps``."""
    return (np.sqrt(1.0 + eps * z2) - 1.0) / eps


def bump(z: np.ndarray, h: float) -> np.ndarray:
    """The bump function rho_h: 1 on [0, h), ``(1 + cos(pi (z - h) / (1 - h))) / 2`` on [h, 1], 0 beyond (and below 0)."""
    z = np.asarray(z, dtype=float)
    t = np.clip((z - h) / (1.0 - h), 0.0, 1.0)  # 0 below h (value 1), 1 from z = 1 on (value 0 exactly)
    return 0.5 * (1.0 + np.cos(np.pi * t)) * (z >= 0)


def sigma_1(z: np.ndarray) -> np.ndarray:
    """``z / sqrt(1 + z^2)`` (the scalar sigma_1 of the action function)."""
    return z / np.sqrt(1.0 + z * z)


def action(z: np.ndarray, a: float, b: float) -> np.ndarray:
    """The action function ``phi(z) = ((a + b) sigma_1(z + c) + (a - b)) / 2``, ``c = |a - b| / sqrt(4 a b)``."""
    c = abs(a - b) / np.sqrt(4.0 * a * b)
    return 0.5 * ((a + b) * sigma_1(z + c) + (a - b))


def phi_alpha(z: np.ndarray, p: OlfatiSaberParams) -> np.ndarray:
    """The alpha action function ``phi_alpha(z) = rho_h(z / r_a) phi(z - d_a)`` with ``r_a = ||r||_s``, ``d_a = ||d||_s``."""
    r_a, d_a = sigma_norm(p.r * p.r, p.eps), sigma_norm(p.d * p.d, p.eps)
    return bump(z / r_a, p.h_alpha) * action(z - d_a, p.a, p.b)


def phi_beta(z: np.ndarray, p: OlfatiSaberParams) -> np.ndarray:
    """The beta action function ``phi_beta(z) = rho_h(z / d_b) (sigma_1(z - d_b) - 1)`` with ``d_b = ||d'||_s`` (repulsive: <= 0)."""
    d_b = sigma_norm(p.d_obs * p.d_obs, p.eps)
    return bump(z / d_b, p.h_beta) * (sigma_1(z - d_b) - 1.0)


def alpha_term(diff: np.ndarray, dv: np.ndarray, p: OlfatiSaberParams) -> np.ndarray:
    """u^alpha (N, d) [m/s^2] from ``diff[i, j] = q_j - q_i`` and ``dv[i, j] = p_j - p_i`` (N, N, d);
    the diagonal (a robot and itself) is left out."""
    d2 = np.einsum("ijk,ijk->ij", diff, diff)
    z = sigma_norm(d2, p.eps)
    n_ij = diff / np.sqrt(1.0 + p.eps * d2)[:, :, None]
    w = phi_alpha(z, p)
    adj = bump(z / sigma_norm(p.r * p.r, p.eps), p.h_alpha)  # a_ij
    np.fill_diagonal(w, 0.0)
    np.fill_diagonal(adj, 0.0)
    return p.c1_alpha * np.einsum("ij,ijk->ik", w, n_ij) + p.c2_alpha * np.einsum("ij,ijk->ik", adj, dv)


def beta_term(v: np.ndarray, agent: np.ndarray, dist: np.ndarray, normal: np.ndarray,
              p: OlfatiSaberParams) -> np.ndarray:
    """u^beta (N, d) [m/s^2] of the beta-agents ``k``: robot ``agent[k]``'s projection at ``dist[k]``
    [m] along ``-normal[k]`` (unit, from the surface to the robot), moving with the robot's
    velocity less its normal part (a wall's ``P p_i``, Section VII-A)."""
    out = np.zeros_like(v)
    keep = dist < p.r_obs  # N_i^beta
    agent, dist, normal = agent[keep], dist[keep], normal[keep]
    if len(agent) == 0:
        return out
    z = sigma_norm(dist * dist, p.eps)
    n_hat = -(dist / np.sqrt(1.0 + p.eps * dist * dist))[:, None] * normal  # (qh - q_i) / sqrt(1 + eps |.|^2)
    b_k = bump(z / sigma_norm(p.d_obs * p.d_obs, p.eps), p.h_beta)
    vn = np.einsum("kd,kd->k", v[agent], normal)
    dp = -vn[:, None] * normal  # ph_k - p_i = (I - a a^T) p_i - p_i
    f = p.c1_beta * phi_beta(z, p)[:, None] * n_hat + p.c2_beta * b_k[:, None] * dp
    for c in range(v.shape[1]):
        out[:, c] = np.bincount(agent, f[:, c], minlength=len(v))
    return out


def gamma_term(x: np.ndarray, v: np.ndarray, q_r: np.ndarray, p_r: np.ndarray, p: OlfatiSaberParams) -> np.ndarray:
    """The navigational feedback ``-c1g sigma_1(q_i - q_r) - c2g (p_i - p_r)``, vector ``sigma_1(z) = z / sqrt(1 + |z|^2)``."""
    e = x - q_r
    return -p.c1_gamma * e / np.sqrt(1.0 + np.einsum("ij,ij->i", e, e))[:, None] - p.c2_gamma * (v - p_r)


# ------------------------------------------------------------------ the method


class OlfatiSaber:
    """Algorithm 3 (module docstring)."""

    name = "olfati-saber"
    dims = (2, 3)
    networked = True  # reads the others only through the network (Observation.known; docs/network.md)
    range_sensor = True  # its range ring (sphere) is read through Observation.scan (docs/sensing.md)

    def __init__(self, **overrides: Any):
        p = build(OlfatiSaberParams, overrides, context="olfati-saber")
        if p.a > p.b:
            raise ConfigError(f"olfati-saber: a = {p.a:g} > b = {p.b:g};  needs 0 < a <= b")
        self.params = p
        self.dt = p.dt
        self.dynamics = SaturatedDoubleIntegrator(p.v_max, p.a_max)

    def reset(self, scenario: Scenario, positions, velocities, rng) -> None:
        p = self.params
        self.goal = scenario.goal_array
        self._period = (scenario.upper - scenario.lower) if scenario.periodic else None
        self._sensor = RangeSensor(scenario, p.n_rays, p.n_rays_3d, min(p.lidar_range, p.r_obs))
        self._board = StateBoard(p.broadcast_hz, p.dt)
        self._steps = 0
        self._beta = 0
        self._neighbours = 0.0

    def act(self, obs: Observation, rng: np.random.Generator) -> tuple[np.ndarray, dict]:
        p = self.params
        x, v = obs.positions, obs.velocities
        hx, hv, heard = self._board.update(obs)  # what the others last received
        diff = pair_differences(x, hx, self._period, heard)
        u = alpha_term(diff, velocity_differences(v, hv), p)
        agent, dist, normal = self._sensor.surface_points(x, p.r_obs, obs)
        u += beta_term(v, agent, dist, normal, p)
        u += gamma_term(x, v, self.goal, np.zeros_like(self.goal), p)
        self._steps += 1
        self._beta += len(agent)
        near = np.einsum("ijk,ijk->ij", diff, diff) < p.r * p.r
        np.fill_diagonal(near, False)
        self._neighbours += np.count_nonzero(near) / len(x)
        return u, {}

    def summary(self) -> dict[str, float]:
        s = max(self._steps, 1)
        return {"olfati_saber_beta_agents_mean": self._beta / s,
                "olfati_saber_neighbours_mean": self._neighbours / s,
                **self._board.summary()}


register("olfati-saber", OlfatiSaber,
         "Olfati-Saber (2006) Algorithm 3: alpha-lattice flocking, beta-agents on obstacles, gamma-agent at the goal.",
         params=OlfatiSaberParams)
