"""``vasarhelyi``: the optimised flocking model of Vásárhelyi et al. (Science Robotics 2018).

Every robot sums desired-velocity terms (the paper's Materials and Methods):

    v_d,i = v_flock e_i + sum_j v_ij^rep + sum_j v_ij^frict + sum_s v_is^shill,   |v_d,i| <= v_max

- repulsion: ``p_rep (r0_rep - r_ij) (r_i - r_j) / r_ij`` for ``r_ij < r0_rep``;
- velocity alignment with friction: ``C_frict (v_ij - v_ij^max) (v_j - v_i) / v_ij`` for
  ``v_ij = |v_i - v_j| > v_ij^max = max(v_frict, D(r_ij - r0_frict, a_frict, p_frict))``;
- walls and obstacles through shill agents: at the nearest point of each obstacle edge a
  virtual agent moves away from the obstacle at ``v_shill``; ``(v_is - v_is^max) (v_s - v_i) / v_is``
  for ``v_is = |v_s - v_i| > v_is^max = D(r_is - r0_shill, a_shill, p_shill)``;
- the braking curve: ``D(r, a, p) = 0`` for ``r <= 0``, ``r p`` for ``0 < r p < a / p``,
  ``sqrt(2 a r - a^2 / p^2)`` beyond: the speed from which constant deceleration ``a`` (with a
  linear ``p`` tail) stops in distance ``r``.

Navigation (our reading; the paper's flock has no goal): the self-propulsion ``v_flock e_i`` points
at the scene's goal, ``e_i = g / max(|g|, r_slow)`` with ``g = goal - r_i`` (linear inside
``r_slow`` so the flock stops there). The desired velocity is tracked by ``a = (v_d - v) / tau``
on the SPH Table II vehicle. Shill agents are the local minima of each robot's range ring (APF's
sensing, ``common.RangeSensor``); flock-mates' states are the last 10 Hz broadcast received.

``length_scale`` L and ``time_scale`` T (the default build's only part of ours) map the paper's
outdoor parameter set onto our small scenes by a similarity transform: lengths x L, speeds x L/T,
accelerations x L/T^2, rates x 1/T; ``preset=paper`` has L = T = 1.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from swarmnav.dynamics import SaturatedDoubleIntegrator, clip_norm
from swarmnav.methods.base import Observation
from swarmnav.methods.flocking.common import RangeSensor, StateBoard, pair_differences, velocity_differences
from swarmnav.methods.registry import register
from swarmnav.params import build, param
from swarmnav.world.scenario import Scenario

_V18 = "V18 optimised set, v_flock 4 m/s"


@dataclass(frozen=True, slots=True)
class VasarhelyiParams:
    """The paper's optimised parameter set for v_flock = 4 m/s, and the scale that fits it to
    our scenes (module docstring)."""

    PRESETS: ClassVar[dict[str, dict[str, Any]]] = {
        "swarmnav": {},
        "paper": {"length_scale": 1.0, "time_scale": 1.0, "shill_offset": 0.0},
    }
    DEFAULT_BUILD: ClassVar[str] = "swarmnav"
    PRESET_DOCS: ClassVar[dict[str, str]] = {
        "swarmnav": "the paper's optimised set mapped onto our scenes by a similarity transform (length_scale, "
                    "time_scale: v_flock 4 -> 1 m/s) and obstacle distances from the robot's body (shill_offset)",
        "paper": "the paper's optimised set for v_flock = 4 m/s in SI units, point agents, with the readings its "
                 "silence forces (self-propulsion toward the goal, velocity tracking time tau)",
    }

    dt: float = param(0.02, "s", "[0.0001, 1]", "ours", "control step (50 Hz)")
    v_max: float = param(1.0, "m/s", "(0, inf)", "SPH Table I", "vehicle speed bound; v_d is cut here (the Table II vehicle)")
    a_max: float = param(1.5, "m/s^2", "(0, inf)", "SPH Table I", "vehicle acceleration bound")
    tau: float = param(0.2, "s", "(0, inf)", "ours", "velocity tracking time: a = (v_d - v) / tau")
    v_flock: float = param(4.0, "m/s", "[0, inf)", _V18, "self-propulsion speed v_flock")
    r0_rep: float = param(25.0, "m", "[0, inf)", _V18, "repulsion range r0_rep")
    p_rep: float = param(0.13, "1/s", "[0, inf)", _V18, "repulsion gain p_rep")
    r0_frict: float = param(85.3, "m", "[0, inf)", _V18, "stopping point offset of alignment r0_frict")
    c_frict: float = param(0.05, "", "[0, inf)", _V18, "alignment coefficient C_frict")
    v_frict: float = param(0.63, "m/s", "[0, inf)", _V18, "velocity slack of alignment v_frict")
    p_frict: float = param(3.2, "1/s", "(0, inf)", _V18, "gain of the alignment braking curve p_frict")
    a_frict: float = param(4.16, "m/s^2", "(0, inf)", _V18, "acceleration of the alignment braking curve a_frict")
    r0_shill: float = param(0.3, "m", "[0, inf)", _V18, "stopping point offset of walls r0_shill")
    v_shill: float = param(13.6, "m/s", "[0, inf)", _V18, "speed of the shill agents v_shill")
    p_shill: float = param(3.55, "1/s", "(0, inf)", _V18, "gain of the wall braking curve p_shill")
    a_shill: float = param(3.02, "m/s^2", "(0, inf)", _V18, "acceleration of the wall braking curve a_shill")
    length_scale: float = param(0.07, "", "(0, inf)", "ours: chosen on training forests 1-10",
                                "L: the paper's lengths x L (25 m -> 1.75 m)")
    time_scale: float = param(0.28, "", "(0, inf)", "ours: L / T = 1/4",
                              "T: times x T, so speeds x L/T (4 m/s -> 1 m/s)")
    shill_offset: float = param(0.2, "m", "[0, inf)", "ours",
                               "taken off every obstacle distance: the robot body radius (the paper's agents are points: 0 in paper)")
    r_slow: float = param(2.0, "m", "(0, inf)", "ours", "self-propulsion toward the goal slows linearly inside r_slow")
    broadcast_hz: float = param(10.0, "Hz", "[0.01, 1000]", "ours", "rate of each robot's position+velocity message")
    n_rays: int = param(360, "", "[4, 36000]", "HES Table A1", "rays of the range ring (as APF)")
    n_rays_3d: int = param(2048, "", "[16, 100000]", "ours (as APF)", "rays of the 3-D range sphere")
    lidar_range: float = param(20.0, "m", "(0, inf)", "HES Table A1", "sensor range R_L: shill agents beyond are unseen")


@dataclass(frozen=True, slots=True)
class Scaled:
    """The model's parameters after the similarity transform, in SI units (module docstring)."""

    v_flock: float
    r0_rep: float
    p_rep: float
    r0_frict: float
    c_frict: float
    v_frict: float
    p_frict: float
    a_frict: float
    r0_shill: float
    v_shill: float
    p_shill: float
    a_shill: float

    @staticmethod
    def of(p: VasarhelyiParams) -> Scaled:
        L, T = np.float64(p.length_scale), np.float64(p.time_scale)  # extreme scales: inf, not an exception
        with np.errstate(over="ignore", invalid="ignore", divide="ignore", under="ignore"):
            v, a = L / T, L / (T * T)
            return Scaled(p.v_flock * v, p.r0_rep * L, p.p_rep / T, p.r0_frict * L, p.c_frict, p.v_frict * v,
                          p.p_frict / T, p.a_frict * a, p.r0_shill * L, p.v_shill * v, p.p_shill / T, p.a_shill * a)


def braking(r: np.ndarray, a: float, p: float) -> np.ndarray:
    """The braking curve ``D(r, a, p)`` [m/s]: 0 for r <= 0, ``r p`` while ``r p < a / p``,
    ``sqrt(2 a r - a^2 / p^2)`` beyond (continuous at ``r = a / p^2``, non-decreasing in r)."""
    r = np.asarray(r, dtype=float)
    a, p = np.float64(a), np.float64(p)  # NumPy scalars: an extreme parameter overflows to inf, not OverflowError
    lin = r * p
    root = np.sqrt(np.maximum(2.0 * a * r - (a / p) ** 2, 0.0))
    return np.where(r <= 0, 0.0, np.where(lin < a / p, lin, root))


def shill_reach(s: Scaled, p: VasarhelyiParams) -> float:
    """Distance [m] beyond which a shill agent cannot act: its relative speed is at most
    ``v_shill + v_max``, and the braking curve reaches that at ``r0_shill + D^-1(v_shill + v_max)``
    (plus the body radius taken off). Sensing no farther changes no command and saves most of
    the ray casting (3.8 m instead of 20 m in the default build)."""
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        v = np.float64(s.v_shill) + p.v_max
        knee = np.float64(s.a_shill) / s.p_shill  # D's linear branch ends at this speed
        r = v / s.p_shill if v < knee else (v * v + knee * knee) / (2.0 * s.a_shill)
        return float(s.r0_shill + p.shill_offset + r) * (1.0 + 1e-9) + 1e-9


def repulsion(diff: np.ndarray, s: Scaled) -> np.ndarray:
    """Sum over j of  (N, d) [m/s] from ``diff[i, j] = r_j - r_i`` (N, N, d), diagonal left out."""
    dist = np.sqrt(np.einsum("ijk,ijk->ij", diff, diff))
    np.fill_diagonal(dist, np.inf)
    with np.errstate(invalid="ignore"):  # the diagonal's inf / inf, never selected
        w = np.where(dist < s.r0_rep, s.p_rep * (s.r0_rep - dist) / np.maximum(dist, 1e-12), 0.0)
    return -np.einsum("ij,ijk->ik", w, diff)


def friction(diff: np.ndarray, dv: np.ndarray, s: Scaled) -> np.ndarray:
    """Sum over j of -(5) (N, d) [m/s] from ``diff[i, j] = r_j - r_i`` and ``dv[i, j] = v_j - v_i``."""
    dist = np.sqrt(np.einsum("ijk,ijk->ij", diff, diff))
    speed = np.sqrt(np.einsum("ijk,ijk->ij", dv, dv))
    slack = np.maximum(s.v_frict, braking(dist - s.r0_frict, s.a_frict, s.p_frict))
    w = np.where(speed > slack, s.c_frict * (speed - slack) / np.maximum(speed, 1e-300), 0.0)
    np.fill_diagonal(w, 0.0)
    return np.einsum("ij,ijk->ik", w, dv)


def shill(v: np.ndarray, agent: np.ndarray, dist: np.ndarray, normal: np.ndarray, s: Scaled) -> np.ndarray:
    """Sum over the shill agents of -(7) (N, d) [m/s]: agent ``k`` at ``dist[k]`` [m] from robot
    ``agent[k]`` moves at ``v_shill`` along ``normal[k]`` (unit, from the obstacle to the robot)."""
    out = np.zeros_like(v)
    if len(agent) == 0:
        return out
    rel = s.v_shill * normal - v[agent]  # v_s - v_i
    speed = np.sqrt(np.einsum("kd,kd->k", rel, rel))
    cap = braking(dist - s.r0_shill, s.a_shill, s.p_shill)
    w = np.where(speed > cap, (speed - cap) / np.maximum(speed, 1e-300), 0.0)
    f = w[:, None] * rel
    for c in range(v.shape[1]):
        out[:, c] = np.bincount(agent, f[:, c], minlength=len(v))
    return out


class Vasarhelyi:
    """The optimised flocking model (module docstring)."""

    name = "vasarhelyi"
    dims = (2, 3)
    networked = True  # reads the others only through the network (Observation.known; docs/network.md)
    range_sensor = True  # its range ring (sphere) is read through Observation.scan (docs/sensing.md)

    def __init__(self, **overrides: Any):
        p = build(VasarhelyiParams, overrides, context="vasarhelyi")
        self.params = p
        self.dt = p.dt
        self.scaled = Scaled.of(p)
        self.dynamics = SaturatedDoubleIntegrator(p.v_max, p.a_max)

    def reset(self, scenario: Scenario, positions, velocities, rng) -> None:
        p = self.params
        self.goal = scenario.goal_array
        self._period = (scenario.upper - scenario.lower) if scenario.periodic else None
        self._sensor = RangeSensor(scenario, p.n_rays, p.n_rays_3d, min(p.lidar_range, shill_reach(self.scaled, p)))
        self._board = StateBoard(p.broadcast_hz, p.dt)
        self._steps = 0
        self._shill = 0
        self._cut = 0

    def desired_velocity(self, x: np.ndarray, v: np.ndarray, hx: np.ndarray, hv: np.ndarray,
                         heard: np.ndarray | None = None, obs: Observation | None = None) -> np.ndarray:
        """``v_d`` (N, d) [m/s] before the cut at ``v_max``, from the robots' own states and the held
        broadcasts ``hx``, ``hv`` of the others ((N, d), or (N, N, d) each robot's picture on a
        network, ``heard`` the pairs it has heard); ``obs`` the step's observation, whose
        perception the range sensor reads through (docs/sensing.md)."""
        s, p = self.scaled, self.params
        diff = pair_differences(x, hx, self._period, heard)
        g = self.goal - x
        gn = np.sqrt(np.einsum("ij,ij->i", g, g))
        vd = s.v_flock * g / np.maximum(gn, p.r_slow)[:, None]
        vd += repulsion(diff, s)
        vd += friction(diff, velocity_differences(v, hv), s)
        agent, dist, normal = self._sensor.surface_points(x, np.inf, obs)  # within shill_reach
        vd += shill(v, agent, dist - p.shill_offset, normal, s)
        self._shill += len(agent)
        return vd

    def act(self, obs: Observation, rng: np.random.Generator) -> tuple[np.ndarray, dict]:
        p = self.params
        x, v = obs.positions, obs.velocities
        hx, hv, heard = self._board.update(obs)
        vd = self.desired_velocity(x, v, hx, hv, heard, obs)
        self._cut += int(np.count_nonzero(np.einsum("ij,ij->i", vd, vd) > p.v_max * p.v_max))
        vd = clip_norm(vd, p.v_max)
        self._steps += 1
        return (vd - v) / p.tau, {}

    def summary(self) -> dict[str, float]:
        s = max(self._steps, 1)
        return {"vasarhelyi_shill_agents_mean": self._shill / s,
                "vasarhelyi_speed_cut_fraction": self._cut / (s * self._n()),
                **self._board.summary()}

    def _n(self) -> int:
        return 1 if self._board.x is None else len(self._board.x)


register("vasarhelyi", Vasarhelyi,
         "Vásárhelyi et al. (2018) optimised flocking: repulsion, friction alignment, shill agents, self-propulsion to the goal.",
         params=VasarhelyiParams)
