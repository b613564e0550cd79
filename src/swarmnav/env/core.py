"""The numerics every environment shares: B copies of one scene stepped as (B, N, d) arrays.

One step of all copies is a handful of array calls: the simulator's dynamics
(:mod:`swarmnav.dynamics`) on the (B N, d) state, one LiDAR call for all B N rings (the sensing
kernels behind :func:`swarmnav.lidar_scan`, on the geometry prepared once), one signed-distance
call for the clearance of all B N agents (the simulator's contact and d_safe checks) and one
compiled k-nearest-neighbour pass. The PettingZoo, Gymnasium and vector environments are thin
wrappers around :class:`SwarmCore` with B = 1 or B copies.

Observation of agent i (float32, in this order):

- ``n_rays`` LiDAR values in [0, 1]: the ring of ``lidar_rays`` rays pooled by the minimum over
  ``lidar_rays / n_rays`` adjacent rays (observed ray j covers the ring's sector
  [2 pi j / n_rays, 2 pi (j + 1) / n_rays) from +x, counter-clockwise), divided by
  ``lidar_range``; 0 when the agent is inside an obstacle. In a 3-D world the ring is
  horizontal, at the agent's altitude;
- its velocity v_i (d) [m/s];
- the goal vector g - p_i (d) [m];
- for its ``k_neighbors`` nearest other agents, nearest first: relative positions p_j - p_i
  (k d) [m], relative velocities v_j - v_i (k d) [m/s], and a mask (k) that is 1 for a real
  neighbour and 0 for a padding slot (fewer than k other agents; its other entries are 0).

Reward of agent i for a step (every weight an option)::

    r_i = w_progress (|g - p_i(k)| - |g - p_i(k + 1)|)        progress to the goal [m]
        + w_goal      [arrived at this step]
        - w_contact dt ([clearance_i < body_radius] + [min_j |p_i - p_j| < 2 body_radius])
        - w_unsafe dt  [clearance_i < d_safe]

The penalties are rates [1/s] times the step dt, so an episode's return does not depend on dt
(the progress term does not either: it sums to the distance gained).

Arrived agents (within ``goal_radius`` of the goal) are terminated and hover where they are
(velocity 0, actions ignored); they stay in the world as obstacles to the others' neighbour
and contact checks, as a parked UAV would. With ``terminate_at_goal=False`` nobody is
terminated: every agent acts until the step limit and is scored at its last state, the
protocol of ``swarmnav run`` (the arrival bonus is paid once, the other terms every step).
Like the simulator, the world does not stop an agent at an obstacle: contacts are counted and
penalised, not resolved.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from swarmnav.dynamics import DampedDoubleIntegrator, SaturatedDoubleIntegrator, clip_norm
from swarmnav.env.options import EnvOptions
from swarmnav.errors import ConfigError
from swarmnav.sensing import PreparedGeometry, ray_table, signed_distance
from swarmnav.world.scenario import Scenario


@njit(cache=True)
def knn_kernel(pos, k, out_idx, out_d2, nearest_d2):
    """The ``k`` nearest other agents of every agent of every copy, by brute force per copy.

    Args:
        pos: (B, N, d) positions [m].
        k: neighbours wanted (``out_idx.shape[2]``).
        out_idx: (B, N, k) int64 <- neighbour indices, nearest first (ties: lower index first);
            -1 in padding slots (fewer than k other agents).
        out_d2: (B, N, k) float64 <- their squared distances [m^2] (inf in padding slots).
        nearest_d2: (B, N) float64 <- squared distance to the nearest other agent (inf: none),
            whatever k is (the contact check needs it also with k = 0).

    O(B N^2 k) without an N x N matrix: an insertion into a sorted k-list per candidate, cheap
    for the swarm sizes of the scenes (N <= a few hundred).
    """
    B, N, d = pos.shape
    for b in range(B):
        for i in range(N):
            for s in range(k):
                out_idx[b, i, s] = -1
                out_d2[b, i, s] = np.inf
            best = np.inf
            for j in range(N):
                if j == i:
                    continue
                r2 = 0.0
                for c in range(d):
                    t = pos[b, j, c] - pos[b, i, c]
                    r2 += t * t
                if r2 < best:
                    best = r2
                if k == 0 or r2 >= out_d2[b, i, k - 1]:
                    continue
                s = k - 1
                while s > 0 and out_d2[b, i, s - 1] > r2:
                    out_d2[b, i, s] = out_d2[b, i, s - 1]
                    out_idx[b, i, s] = out_idx[b, i, s - 1]
                    s -= 1
                out_d2[b, i, s] = r2
                out_idx[b, i, s] = j
            nearest_d2[b, i] = best


@njit(cache=True)
def observe_kernel(ring, pool, inv_range, pos, vel, goal, idx, out):
    """Fill ``out`` (B, N, obs_dim) float32 with the observation of every agent of every copy
    (layout in the module docstring) in one pass.

    Args:
        ring: (B N, R pool) LiDAR ranges [m], agent i of copy b in row b N + i.
        pool: rays pooled (by the minimum) into one observed ray.
        inv_range: 1 / lidar_range [1/m].
        pos, vel: (B, N, d) state [m], [m/s]; goal: (d,) [m].
        idx: (B, N, k) neighbour indices, -1 in padding slots.
    """
    B, N, d = pos.shape
    R = ring.shape[1] // pool
    k = idx.shape[2]
    for b in range(B):
        for i in range(N):
            m = b * N + i
            for j in range(R):
                v = ring[m, j * pool]
                for q in range(1, pool):
                    w = ring[m, j * pool + q]
                    if w < v:
                        v = w
                out[b, i, j] = v * inv_range
            c = R
            for e in range(d):
                out[b, i, c + e] = vel[b, i, e]
                out[b, i, c + d + e] = goal[e] - pos[b, i, e]
            c += 2 * d
            for s in range(k):
                j = idx[b, i, s]
                for e in range(d):
                    if j >= 0:
                        out[b, i, c + s * d + e] = pos[b, j, e] - pos[b, i, e]
                        out[b, i, c + k * d + s * d + e] = vel[b, j, e] - vel[b, i, e]
                    else:
                        out[b, i, c + s * d + e] = 0.0
                        out[b, i, c + k * d + s * d + e] = 0.0
                out[b, i, c + 2 * k * d + s] = 1.0 if j >= 0 else 0.0


@njit(cache=True)
def score_kernel(p0, p1, arrived, hover, clr, near_d2, goal, goal_radius, body_radius, d_safe, w_progress,
                 w_goal, w_contact_dt, w_unsafe_dt, reward, arrived_out, obst, agent, unsafe, dist1):
    """The reward and the simulator's checks of every agent after a step (module docstring):
    (B, N) outputs from the states before (p0) and after (p1) [m], the clearance [m] and the
    squared distance to the nearest other agent [m^2] after the step. ``arrived`` flags the
    agents that had arrived before the step: with ``hover`` they score 0, without it they go on
    scoring (the arrival bonus only once)."""
    B, N, d = p0.shape
    contact2 = (2.0 * body_radius) ** 2
    for b in range(B):
        for i in range(N):
            s0 = 0.0
            s1 = 0.0
            for e in range(d):
                t0 = p0[b, i, e] - goal[e]
                t1 = p1[b, i, e] - goal[e]
                s0 += t0 * t0
                s1 += t1 * t1
            d0 = np.sqrt(s0)
            d1 = np.sqrt(s1)
            now = d1 <= goal_radius
            o = clr[b, i] < body_radius
            a = near_d2[b, i] < contact2
            u = clr[b, i] < d_safe
            dist1[b, i] = d1
            obst[b, i] = o
            agent[b, i] = a
            unsafe[b, i] = u
            arrived_out[b, i] = arrived[b, i] or now
            if arrived[b, i] and hover:
                reward[b, i] = 0.0
            else:
                reward[b, i] = (w_progress * (d0 - d1) + (w_goal if now and not arrived[b, i] else 0.0)
                                - w_contact_dt * ((1.0 if o else 0.0) + (1.0 if a else 0.0))
                                - w_unsafe_dt * (1.0 if u else 0.0))


@njit(cache=True)
def hold_kernel(p0, p1, v1, arrived):
    """Arrived agents hover: their position stays ``p0`` and their velocity is 0 (in place)."""
    B, N, d = p0.shape
    for b in range(B):
        for i in range(N):
            if arrived[b, i]:
                for e in range(d):
                    p1[b, i, e] = p0[b, i, e]
                    v1[b, i, e] = 0.0


@dataclass(frozen=True, slots=True)
class StepOutcome:
    """What one step of B copies produced, (B, N) arrays unless said otherwise."""

    reward: np.ndarray  # float64, 0 for agents that had already arrived
    arrived: np.ndarray  # bool: within goal_radius after the step (arrived now or before)
    clearance: np.ndarray  # float64 signed distance to the nearest obstacle [m] (+inf: none)
    obstacle_contact: np.ndarray  # bool: clearance < body_radius
    agent_contact: np.ndarray  # bool: another agent nearer than 2 body_radius
    unsafe: np.ndarray  # bool: clearance < d_safe
    distance_to_goal: np.ndarray  # float64 [m]


class SwarmCore:
    """Scene, options and the pure step of B copies (the wrappers own the state arrays).

    Args:
        scenario: the scene (a navigation scene: open world, one goal).
        options: checked options.
    """

    def __init__(self, scenario: Scenario, options: EnvOptions):
        if scenario.periodic:
            raise ConfigError(f"env: {scenario.name} is a periodic world without a goal region; "
                              "the environment needs a navigation scene")
        self.scenario = scenario
        self.options = o = options
        self.n = scenario.n
        self.dim = d = scenario.dim
        self.goal = scenario.goal_array
        self.prepared = PreparedGeometry(scenario.geometry)
        cos_t, sin_t = ray_table(o.lidar_rays)
        self._cos, self._sin = np.ascontiguousarray(cos_t), np.ascontiguousarray(sin_t)
        # the 3-D ring: the planar ring's directions, horizontal
        self._dirs3 = np.ascontiguousarray(np.column_stack([cos_t, sin_t, np.zeros(o.lidar_rays)]))
        self._pool = o.lidar_rays // o.n_rays
        if o.dynamics == "damped":
            self._dyn = DampedDoubleIntegrator()
        else:
            self._dyn = SaturatedDoubleIntegrator(np.inf if o.v_max is None else o.v_max, o.a_max)
        k = o.k_neighbors
        self.obs_dim = o.n_rays + 2 * d + k * (2 * d + 1)
        lo = np.full(self.obs_dim, -np.inf, dtype=np.float32)
        hi = np.full(self.obs_dim, np.inf, dtype=np.float32)
        lo[: o.n_rays] = 0.0
        hi[: o.n_rays] = 1.0
        lo[self.obs_dim - k:] = 0.0
        hi[self.obs_dim - k:] = 1.0
        self.obs_low, self.obs_high = lo, hi

    # ------------------------------------------------------------------ episode start
    def spawn(self, rng: np.random.Generator) -> np.ndarray:
        """(N, d) start positions [m], as :func:`swarmnav.run` draws them from the same generator."""
        return self.scenario.spawn_positions(rng)

    # ------------------------------------------------------------------ sensing
    def lidar(self, pos: np.ndarray) -> np.ndarray:
        """(B, N, lidar_rays) ranges [m] of every agent of every copy, one kernel call."""
        B, N, d = pos.shape
        o = self.options
        flat = np.ascontiguousarray(pos.reshape(B * N, d))
        out = np.empty((B * N, o.lidar_rays))
        if d == 2:
            self.prepared.lidar_into(flat, self._cos, self._sin, o.lidar_range, out)
        else:
            self.prepared.range_into(flat, self._dirs3, o.lidar_range, out)
        return out.reshape(B, N, o.lidar_rays)

    def clearance(self, pos: np.ndarray) -> np.ndarray:
        """(B, N) signed distance to the nearest obstacle [m] (+inf without obstacles)."""
        B, N, d = pos.shape
        if self.prepared.is_empty:
            return np.full((B, N), np.inf)
        return signed_distance(self.scenario.geometry, pos.reshape(B * N, d)).reshape(B, N)

    def neighbours(self, pos: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(idx (B, N, k), d2 (B, N, k), nearest_d2 (B, N)): see :func:`knn_kernel`."""
        B, N, _ = pos.shape
        k = self.options.k_neighbors
        idx = np.empty((B, N, k), dtype=np.int64)
        d2 = np.empty((B, N, k))
        near = np.empty((B, N))
        knn_kernel(np.ascontiguousarray(pos), k, idx, d2, near)
        return idx, d2, near

    def observe(self, pos: np.ndarray, vel: np.ndarray, idx: np.ndarray | None = None) -> np.ndarray:
        """(B, N, obs_dim) float32 observations of state (pos, vel), (B, N, d) each."""
        B, N, _ = pos.shape
        if idx is None:
            idx = self.neighbours(pos)[0]
        ring = self.lidar(pos).reshape(B * N, -1)
        out = np.empty((B, N, self.obs_dim), dtype=np.float32)
        observe_kernel(ring, self._pool, 1.0 / self.options.lidar_range, np.ascontiguousarray(pos),
                       np.ascontiguousarray(vel), self.goal, idx, out)
        return out

    # ------------------------------------------------------------------ one step
    def step(self, pos: np.ndarray, vel: np.ndarray, arrived: np.ndarray, action: np.ndarray
             ) -> tuple[np.ndarray, np.ndarray, StepOutcome, np.ndarray]:
        """Advance every copy by dt.

        Args:
            pos, vel: (B, N, d) state [m], [m/s].
            arrived: (B, N) bool, agents that have arrived in the goal region (with
                ``terminate_at_goal`` they hover: unchanged).
            action: (B, N, d) finite normalised accelerations; a row of norm above 1 is scaled
                to norm 1 (the commanded acceleration is ``a_max`` times the row).

        Returns:
            ``(pos, vel, outcome, idx)``: the new state, what the step produced, and the
            neighbour indices of the new state (for the next observation).
        """
        o = self.options
        B, N, d = pos.shape
        a = clip_norm(action.reshape(B * N, d).astype(np.float64, copy=False), 1.0) * o.a_max
        p1, v1 = self._dyn.step(pos.reshape(B * N, d), vel.reshape(B * N, d), a, o.dt)
        p1 = np.ascontiguousarray(p1.reshape(B, N, d))
        v1 = np.ascontiguousarray(v1.reshape(B, N, d))
        if o.terminate_at_goal:
            hold_kernel(pos, p1, v1, arrived)
        clr = self.clearance(p1)
        idx, _, near = self.neighbours(p1)
        out = StepOutcome(np.empty((B, N)), np.empty((B, N), bool), clr, np.empty((B, N), bool),
                          np.empty((B, N), bool), np.empty((B, N), bool), np.empty((B, N)))
        score_kernel(pos, p1, arrived, o.terminate_at_goal, clr, near, self.goal, o.goal_radius, o.body_radius,
                     o.d_safe, o.w_progress, o.w_goal, o.w_contact * o.dt, o.w_unsafe * o.dt, out.reward, out.arrived,
                     out.obstacle_contact, out.agent_contact, out.unsafe, out.distance_to_goal)
        return p1, v1, out, idx
