"""``apf``: the classic artificial potential field baseline (Khatib 1986), on the LiDAR ring.

Each agent sums three forces and a velocity damping term, then saturates:

    a_i = k_att * g(p_g - p_i) + F_rep,i + F_sep,i - k_damp * v_i,   ||a_i|| <= a_max

- goal attraction, conic far from the goal and quadratic inside ``r_att`` so the potential
  is C1: ``g(x) = x / max(||x||, r_att)`` (unit pull far away, linear near the goal);
- obstacle repulsion from the agent's own 360-ray LiDAR ring: every ray closer than ``d0``
  contributes Khatib's gradient ``k_rep (1/d - 1/d0) / d^2`` away from the return, weighted
  by the ray's angular width ``2 pi / n_rays`` (so the force does not depend on the angular
  resolution and integrates the obstacle's visible extent);
- inter-agent separation with the same law against neighbours closer than ``r_sep``.

In a 3-D world the ring becomes a sphere of ``n_rays_3d`` rays in Fibonacci-lattice
directions (near-uniform, deterministic), each weighted by its solid angle ``4 pi / n_rays_3d``
times a constant fixed once so that a flat wall pushes exactly as hard as in the plane (the
normal force of a wall at 1 m is the same for the ring and the sphere; see
:func:`sphere_weight`). Everything else is the same formula on (N, 3) arrays.

It uses the same damped double integrator and inverse-model input as HES (eq. 5-7), so the
comparison is on equal dynamics. It has the textbook weaknesses of potential fields: local
minima in front of concave or wide obstacles, and oscillation in narrow passages. That is the
point of a baseline: it is honest, not tuned per scene.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from typing import Any, ClassVar

import numpy as np

from swarmnav.dynamics import DampedDoubleIntegrator, clip_norm
from swarmnav.methods.base import Observation
from swarmnav.methods.registry import register
from swarmnav.params import build, param
from swarmnav.sensing import PreparedGeometry, fibonacci_sphere, lidar_ring, neighbor_pairs
from swarmnav.world.scenario import Scenario


@dataclass(frozen=True, slots=True)
class ApfParams:
    """Gains of the APF baseline. All values are our choice (no paper gives APF gains for
    these scenes). They were set once, as the smallest repulsion, separation and damping of a
    coarse grid that gave zero collisions on the four HES scenes and two random forests at
    seed 1, and are kept fixed for every scene."""

    #: One build: Khatib's field as docs/methods/apf.md reads it, with the gains below; named ``paper``
    #: so that every method answers ``preset=paper`` (a spec flying the paper builds of several methods).
    PRESETS: ClassVar[dict[str, dict[str, Any]]] = {"paper": {}}
    DEFAULT_BUILD: ClassVar[str] = "paper"
    PRESET_DOCS: ClassVar[dict[str, str]] = {
        "paper": "Khatib's potential field (1986) per agent on its own range sensor, with our gains (no paper "
                 "gives APF gains for these scenes)"}

    dt: float = param(0.1, "s", "[0.0001, 1]", "ours", "integration step, as HES")
    n_rays: int = param(360, "", "[4, 36000]", "HES Table A1", "LiDAR rays")
    lidar_range: float = param(20.0, "m", "(0, inf)", "HES Table A1", "LiDAR range R_L")
    k_att: float = param(2.0, "m/s^2", "[0, inf)", "ours", "goal attraction (unit-direction pull)")
    r_att: float = param(5.0, "m", "(0, inf)", "ours", "radius inside which the pull becomes linear")
    k_rep: float = param(8.0, "m^3/s^2 per rad", "[0, inf)", "ours", "obstacle repulsion gain")
    d0: float = param(3.0, "m", "(0, inf)", "ours", "obstacle influence distance")
    k_sep: float = param(3.0, "m^3/s^2", "[0, inf)", "ours", "inter-agent separation gain")
    r_sep: float = param(2.0, "m", "(0, inf)", "ours", "separation influence radius")
    k_damp: float = param(1.5, "1/s", "[0, inf)", "ours", "velocity damping")
    a_max: float = param(2.6, "m/s^2", "(0, inf)", "HES Table A1", "acceleration saturation")
    d_floor: float = param(0.05, "m", "(0, inf)", "ours", "distances are floored here before 1/d^2 (bounded force)")
    n_rays_3d: int = param(2048, "", "[16, 100000]", "ours",
        "rays of the 3-D range sphere (~4.5 deg apart, 0.24 m at d0 = 3 m)")


class Apf:
    name = "apf"
    dims = (2, 3)  # a range ring in the plane, a range sphere in 3-D
    networked = True  # the separation term reads the others through Observation.known (docs/network.md)
    range_sensor = True  # its LiDAR ring (3-D: range sphere) is read through Observation.scan (docs/sensing.md)

    def __init__(self, **overrides: Any):
        self.params = build(ApfParams, overrides, context="apf")
        self.dt = self.params.dt
        self.dynamics = DampedDoubleIntegrator()
        theta = 2 * np.pi * np.arange(self.params.n_rays) / self.params.n_rays
        self._dirs = np.column_stack([np.cos(theta), np.sin(theta)])  # (R, 2) ray directions
        self._weight = 2 * np.pi / self.params.n_rays  # [rad] per ray

    def reset(self, scenario: Scenario, positions, velocities, rng) -> None:
        self.scenario = scenario
        self.goal = scenario.goal_array
        p = self.params
        if scenario.dim == 3:
            self._dirs = fibonacci_sphere(p.n_rays_3d)
            self._weight = 4 * np.pi / p.n_rays_3d * sphere_weight(p.d0)
            self._prepared = PreparedGeometry(scenario.geometry)  # converted once, not per step
            self._ranges = np.empty((scenario.n, p.n_rays_3d))
        else:
            theta = 2 * np.pi * np.arange(p.n_rays) / p.n_rays
            self._dirs = np.column_stack([np.cos(theta), np.sin(theta)])
            self._weight = 2 * np.pi / p.n_rays

    def act(self, obs: Observation, rng: np.random.Generator) -> tuple[np.ndarray, dict]:
        p = self.params
        x, v = obs.positions, obs.velocities
        to_goal = self.goal - x
        dist = np.sqrt(np.einsum("ij,ij->i", to_goal, to_goal))
        a = p.k_att * to_goal / np.maximum(dist, p.r_att)[:, None]
        geom = self.scenario.geometry
        if not geom.is_empty:
            if x.shape[1] == 2:
                ring = obs.scan(lambda at: lidar_ring(geom, at, p.n_rays, p.lidar_range), x, self._dirs,
                                p.lidar_range)  # (N, R)
            else:
                reach = min(p.lidar_range, p.d0)
                ring = obs.scan(lambda at: self._prepared.range_into(np.ascontiguousarray(at), self._dirs, reach,
                                                                     self._ranges), x, self._dirs, reach)  # (N, R)
            agent, ray = np.nonzero(ring < p.d0)  # only the few returns inside d0 matter
            if len(agent):
                d = np.maximum(ring[agent, ray], p.d_floor)
                w = self._weight * p.k_rep * (1.0 / d - 1.0 / p.d0) / d**2
                n = len(x)  # push away from each return
                for c in range(x.shape[1]):
                    a[:, c] -= np.bincount(agent, w * self._dirs[ray, c], minlength=n)
        if obs.view is None:
            a += separation(x, p.k_sep, p.r_sep, p.d_floor)
        else:  # each robot from its own picture of the others
            kx, _, heard = obs.known()
            a += separation_known(x, kx, heard, p.k_sep, p.r_sep, p.d_floor)
        a -= p.k_damp * v
        return clip_norm(a, p.a_max), {}

    def summary(self) -> dict[str, float]:
        return {}


def separation(x: np.ndarray, k: float, r: float, d_floor: float) -> np.ndarray:
    """Khatib-law inter-agent repulsion, sum over neighbours j with d_ij < r of
    ``k (1/d - 1/r) / d^2 * (x_i - x_j)/d`` [m/s^2]; O(N log N) via neighbour pairs."""
    n = len(x)
    if n <= 64:  # small swarms: all pairs at once is cheaper than building a tree
        i, j = np.triu_indices(n, 1)
        diff = x[i] - x[j]
        d2 = np.einsum("ij,ij->i", diff, diff)
        near = d2 < r * r
        i, j, diff = i[near], j[near], diff[near]
    else:
        i, j = neighbor_pairs(x, r)
        diff = x[i] - x[j]
    return _khatib(n, x.shape[1], i, j, diff, k, r, d_floor)


def _khatib(n: int, dim: int, i: np.ndarray, j: np.ndarray | None, diff: np.ndarray, k: float, r: float,
            d_floor: float) -> np.ndarray:
    """The Khatib push of pairs ``(i, j)`` at offsets ``diff = x_i - x_j``, summed onto robot i and,
    with the opposite sign, onto robot j (``j`` None: onto i only, the directed pairs of a network)."""
    out = np.zeros((n, dim))
    if len(i) == 0:
        return out
    d = np.maximum(np.sqrt(np.einsum("ij,ij->i", diff, diff)), d_floor)
    f = (k * (1.0 / d - 1.0 / r) / d**3)[:, None] * diff
    for c in range(dim):
        out[:, c] = np.bincount(i, f[:, c], minlength=n)
        if j is not None:
            out[:, c] -= np.bincount(j, f[:, c], minlength=n)
    return out


def separation_known(x: np.ndarray, kx: np.ndarray, heard: np.ndarray, k: float, r: float,
                     d_floor: float) -> np.ndarray:
    """:func:`separation` on a network: robot i is pushed by every robot j it has heard, from
    where it believes j is (``kx[i, j]``, (N, N, d)), and j by its own picture of i."""
    n = len(x)
    i, j = np.nonzero(heard & ~np.eye(n, dtype=bool))
    diff = x[i] - kx[i, j]
    d2 = np.einsum("ij,ij->i", diff, diff)
    near = d2 < r * r
    return _khatib(n, x.shape[1], i[near], None, diff[near], k, r, d_floor)


@lru_cache(maxsize=8)
def sphere_weight(d0: float, d: float = 1.0) -> float:
    """Per-steradian weight [rad/sr] that gives a sphere of rays the ring's push on a flat wall.

    A wall at distance ``d`` seen by rays at angle ``t`` from its normal returns ``d / cos t``;
    the normal force of the Khatib law ``g(r) = (1/r - 1/d0) / r^2`` summed over the ring is
    ``F2 = int g(d/cos t) cos t dt`` over ``|t| < acos(d/d0)``, over the sphere
    ``F3 = int g(d/cos t) cos t 2 pi sin t dt``. The weight ``F2 / F3`` (at ``d`` = 1 m, our
    choice) makes APF's obstacle push the same in 3-D as in the plane.
    """
    from scipy.integrate import quad

    if d >= d0:
        d = 0.5 * d0
    tm = np.arccos(d / d0)
    g = lambda t: (np.cos(t) / d - 1.0 / d0) * (np.cos(t) / d) ** 2 * np.cos(t)  # noqa: E731
    f2 = 2.0 * quad(g, 0.0, tm)[0]
    f3 = quad(lambda t: g(t) * 2.0 * np.pi * np.sin(t), 0.0, tm)[0]
    return float(f2 / f3)


register("apf", Apf, "Artificial potential field baseline: goal attraction, LiDAR repulsion, separation.",
         params=ApfParams)
