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

It uses the same damped double integrator and inverse-model input as HES (eq. 5-7), so the
comparison is on equal dynamics. It has the textbook weaknesses of potential fields: local
minima in front of concave or wide obstacles, and oscillation in narrow passages. That is the
point of a baseline: it is honest, not tuned per scene.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from swarmnav.dynamics import DampedDoubleIntegrator, clip_norm
from swarmnav.methods.base import Observation
from swarmnav.methods.registry import register
from swarmnav.params import build
from swarmnav.sensing import lidar_ring, neighbor_pairs
from swarmnav.world.scenario import Scenario


@dataclass(frozen=True, slots=True)
class ApfParams:
    """Gains of the APF baseline. All values are our choice (no paper gives APF gains for
    these scenes). They were set once, as the smallest repulsion, separation and damping of a
    coarse grid that gave zero collisions on the four HES scenes and two random forests at
    seed 1, and are kept fixed for every scene."""

    dt: float = 0.1  # integration step [s], as HES
    n_rays: int = 360  # LiDAR rays, as HES Table A1
    lidar_range: float = 20.0  # R_L [m], as HES Table A1
    k_att: float = 2.0  # goal attraction [m/s^2] (unit-direction pull)
    r_att: float = 5.0  # radius inside which the pull becomes linear [m]
    k_rep: float = 8.0  # obstacle repulsion gain [m^3/s^2 per rad]
    d0: float = 3.0  # obstacle influence distance [m]
    k_sep: float = 3.0  # inter-agent separation gain [m^3/s^2]
    r_sep: float = 2.0  # separation influence radius [m]
    k_damp: float = 1.5  # velocity damping [1/s]
    a_max: float = 2.6  # acceleration saturation [m/s^2], as HES Table A1
    d_floor: float = 0.05  # distances are floored here before 1/d^2 [m] (bounded force)


class Apf:
    name = "apf"

    def __init__(self, **overrides: Any):
        self.params = build(ApfParams, overrides, context="apf")
        self.dt = self.params.dt
        self.dynamics = DampedDoubleIntegrator()
        theta = 2 * np.pi * np.arange(self.params.n_rays) / self.params.n_rays
        self._dirs = np.column_stack([np.cos(theta), np.sin(theta)])  # (R, 2) ray directions

    def reset(self, scenario: Scenario, positions, velocities, rng) -> None:
        self.scenario = scenario
        self.goal = scenario.goal_array

    def act(self, obs: Observation, rng: np.random.Generator) -> tuple[np.ndarray, dict]:
        p = self.params
        x, v = obs.positions, obs.velocities
        to_goal = self.goal - x
        dist = np.sqrt(np.einsum("ij,ij->i", to_goal, to_goal))
        a = p.k_att * to_goal / np.maximum(dist, p.r_att)[:, None]
        geom = self.scenario.geometry
        if not geom.is_empty:
            ring = lidar_ring(geom, x, p.n_rays, p.lidar_range)  # (N, R)
            agent, ray = np.nonzero(ring < p.d0)  # only the few returns inside d0 matter
            if len(agent):
                d = np.maximum(ring[agent, ray], p.d_floor)
                w = (2 * np.pi / p.n_rays) * p.k_rep * (1.0 / d - 1.0 / p.d0) / d**2
                n = len(x)  # push away from each return
                a[:, 0] -= np.bincount(agent, w * self._dirs[ray, 0], minlength=n)
                a[:, 1] -= np.bincount(agent, w * self._dirs[ray, 1], minlength=n)
        a += separation(x, p.k_sep, p.r_sep, p.d_floor)
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
    out = np.zeros_like(x)
    if len(i) == 0:
        return out
    d = np.maximum(np.sqrt(np.einsum("ij,ij->i", diff, diff)), d_floor)
    f = (k * (1.0 / d - 1.0 / r) / d**3)[:, None] * diff
    for c in range(2):
        out[:, c] = np.bincount(i, f[:, c], minlength=n) - np.bincount(j, f[:, c], minlength=n)
    return out


register("apf", Apf, "Artificial potential field baseline: goal attraction, LiDAR repulsion, separation.")
