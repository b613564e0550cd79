"""``steer``: a small swarm navigation method written as a swarmnav plugin (docs/plugins.md).

Each agent adds three accelerations and flies swarmnav's saturated double integrator:

    a_i = k_goal * (p_goal - p_i) / max(|p_goal - p_i|, 1)       pull toward the goal
        - k_obs * mean over the rays closer than d_obs of (1 - r / d_obs) * (ray direction)
        + k_sep * sum over neighbours closer than d_sep of (1 - d / d_sep) * (p_i - p_j) / d
        - k_damp * v_i

The obstacles come from each agent's own range sensor (``obs.scan``: noise, dropouts and field of
view apply when a run asks for them), the neighbours from what each agent received over the run's
network (``obs.known()``: late or lost under ``net.*``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from swarmnav.dynamics import SaturatedDoubleIntegrator, clip_norm
from swarmnav.params import build, param
from swarmnav.sensing import fibonacci_sphere, range_scan, ray_table


@dataclass(frozen=True, slots=True)
class SteerParams:
    """The gains of ``steer``: our choice, one set for every scene."""

    dt: float = param(0.1, "s", "(0, 1]", "ours", "control step")
    v_max: float = param(1.0, "m/s", "(0, inf)", "ours", "speed limit of the vehicle")
    a_max: float = param(1.5, "m/s^2", "(0, inf)", "ours", "acceleration limit of the vehicle")
    k_goal: float = param(1.0, "m/s^2", "[0, inf)", "ours", "pull toward the goal")
    k_obs: float = param(4.0, "m/s^2", "[0, inf)", "ours", "push away from each close range return")
    d_obs: float = param(2.5, "m", "(0, inf)", "ours", "returns closer than this push")
    k_sep: float = param(3.0, "m/s^2", "[0, inf)", "ours", "push away from each close neighbour")
    d_sep: float = param(1.5, "m", "(0, inf)", "ours", "neighbours closer than this push")
    k_damp: float = param(1.0, "1/s", "[0, inf)", "ours", "velocity damping")
    n_rays: int = param(72, "", "[4, 3600]", "ours", "range-sensor rays")
    sensor_range: float = param(5.0, "m", "(0, inf)", "ours", "range-sensor reach")


class Steer:
    """Goal pull, range-sensor push and neighbour spacing (a swarmnav plugin)."""

    Params = SteerParams  # the parameter record: `swarmnav methods steer` lists it
    name = "steer"
    dims = (2, 3)  # flies 2-D and 3-D scenes: every array is (N, d)
    networked = True  # reads the others only through obs.known()
    range_sensor = True  # reads its obstacles only through obs.scan()

    def __init__(self, **overrides):
        self.params = p = build(SteerParams, overrides, context="steer")  # unknown or out of range: one line
        self.dt = p.dt
        self.dynamics = SaturatedDoubleIntegrator(p.v_max, p.a_max)

    def reset(self, scenario, positions, velocities, rng) -> None:
        p = self.params
        self.goal = np.asarray(scenario.goal_array, dtype=float) if scenario.has_goal else positions.mean(axis=0)
        self.geom = scenario.geometry
        if positions.shape[1] == 2:  # a ring of rays in the plane
            self.rays = np.column_stack(ray_table(p.n_rays))
        else:  # rays spread evenly over the sphere (a Fibonacci lattice)
            self.rays = fibonacci_sphere(p.n_rays)

    def _cast(self, origins):
        """The exact sensor: range [m] along every ray from every origin (the run adds its imperfections)."""
        return range_scan(self.geom, origins, self.rays, self.params.sensor_range)

    def act(self, obs, rng):
        p = self.params
        x, v = obs.positions, obs.velocities
        n = len(x)
        to_goal = self.goal - x
        a = p.k_goal * to_goal / np.maximum(np.linalg.norm(to_goal, axis=1), 1.0)[:, None]
        # obstacles: every return closer than d_obs pushes the agent back along its ray
        r = obs.scan(self._cast, x, self.rays, p.sensor_range)  # (N, rays) [m]
        w = np.clip(1.0 - r / p.d_obs, 0.0, None)
        a -= p.k_obs * (w @ self.rays) / np.maximum(w.astype(bool).sum(axis=1), 1)[:, None]
        # neighbours: as each agent last heard them
        kx, _, heard = obs.known()  # (N, N, d) positions, (N, N) heard
        off = x[:, None, :] - kx
        dist = np.linalg.norm(off, axis=2)
        close = heard & (dist < p.d_sep) & ~np.eye(n, dtype=bool)
        w = np.where(close, (1.0 - dist / p.d_sep) / np.maximum(dist, 1e-9), 0.0)
        a += p.k_sep * np.einsum("ij,ijk->ik", w, off)
        a -= p.k_damp * v
        return clip_norm(a, p.a_max), {}

    def summary(self) -> dict[str, float]:
        return {}
