"""``ego-swarm``: EGO-Swarm (Zhou, Wang, Gao et al., ICRA 2021) on EGO-Planner (RA-L 2020).

Each robot flies its own B-spline, replanned by a small state machine (EGO-Swarm Section IV,
the released FSM), and follows it with a PD tracking law:

1. every ``check_period`` each robot adds to its occupancy map the obstacles within its sensing
   range, and replans when (a) its plan crosses a newly seen obstacle, (b) a newer plan another
   robot broadcast passes closer than ``swarm_check_clearance`` within ``swarm_check_horizon``,
   (c) it has flown ``replan_period`` on one plan (not within ``no_replan_dist`` of its goal),
   (d) it reached the end of a plan short of its goal, or (e) its last replan failed;
2. a replan: local goal on the global path (the line from its spawn to its goal) at
   ``planning_horizon`` [m]; initial path = the rest of the current plan, then straight to the
   local goal (a straight line the first time); control points ``ctrl_spacing`` apart; rebound
   optimisation with the ESDF-free ``{p, v}`` cost, smoothness, feasibility and the swarm term
   against the broadcast plans (optimizer.py); time re-allocation and refinement;
3. a plan collision-free on the robot's map is committed and broadcast
   (:class:`~swarmnav.planning.messages.TrajectoryBoard`, counted in ``comm_mbps``); a failed one
   keeps the current plan, or brakes if that collides within ``emergency_time``; both are
   counted in ``ego_fallbacks``;
4. every step: ``a = k_p (q* - q) + k_v (v* - v) + a*`` (:func:`~swarmnav.planning.tracker.track`).

Robots replan one after another in index order within a step, each seeing the plans published
before it (the paper's asynchronous broadcast at zero latency). Every array is (N, d), d from the
scene: 2-D and 3-D alike.

On a network (docs/network.md) each committed plan travels as an immutable
:class:`~swarmnav.planning.messages.Broadcast` (``info["publish"]["trajectory"]``) and every robot
checks (1b, the brake's swarm check) and optimises (2) against the newest plan it received of each
other robot, read at the true present time: a late plan is still a plan in absolute time (the
paper's broadcast carries its start time on a clock the robots share). A robot never heard from is
not there. A plan published in a step reaches the others from the next step on.
"""

from __future__ import annotations

import math
import time
from typing import Any

import numpy as np

from swarmnav.dynamics import SaturatedDoubleIntegrator
from swarmnav.methods.base import Observation, check_map_bytes, format_extent
from swarmnav.methods.ego_swarm.optimizer import MapView, Weights, curve_hits, reallocate, rebound_optimize
from swarmnav.methods.ego_swarm.params import EgoSwarmParams
from swarmnav.params import build
from swarmnav.planning.bspline import SplinePlan, boundary_points
from swarmnav.planning.esdf_free import occupied
from swarmnav.planning.goals import goal_slots
from swarmnav.planning.maps import OccupancyMaps, bytes_per_cell, grid_cells, resample
from swarmnav.planning.messages import CommLog, TrajectoryBoard, sample_broadcasts
from swarmnav.planning.plan_log import PlanLog, sample_rows
from swarmnav.planning.scanned import scanner
from swarmnav.planning.tracker import track
from swarmnav.world.scenario import Scenario
from swarmnav.planning.schedule import plan_time_summary


class BrakePlan:
    """Stop along the current velocity at ``a_max`` and hold (the emergency stop)."""

    __slots__ = ("q", "v", "a_max", "duration")

    def __init__(self, q: np.ndarray, v: np.ndarray, a_max: float):
        self.q, self.v, self.a_max = q.copy(), v.copy(), a_max
        self.duration = float(np.linalg.norm(v)) / a_max

    def sample(self, tau: np.ndarray):
        tau = np.clip(np.asarray(tau, dtype=float), 0.0, self.duration)[:, None]
        speed = float(np.linalg.norm(self.v))
        if speed < 1e-9:
            z = np.zeros((tau.shape[0], self.q.shape[0]))
            return self.q + z, z, z.copy()
        dec = -self.a_max * self.v / speed
        moving = (tau < self.duration).astype(float)
        return self.q + self.v * tau + 0.5 * dec * tau * tau, self.v + dec * tau, dec * moving


class EgoSwarm:
    """The EGO-Swarm method (see module docstring)."""

    name = "ego-swarm"
    dims = (2, 3)
    networked = True  # reads the others' plans only through what it received (module docstring)
    periodic = False  # its plans cross the world's edge, where a periodic box wraps: the rollout refuses one
    map_sensor = True  # can build its maps from its own scans (sense.map = scans; docs/sensing.md)

    def __init__(self, **overrides: Any):
        p = build(EgoSwarmParams, overrides, context="ego-swarm")
        self.params = p
        self.dt = p.dt
        self.dynamics = SaturatedDoubleIntegrator(p.v_max, p.a_max)
        self._w = Weights(p.lambda_smooth, p.lambda_collision, p.lambda_feasibility, p.lambda_swarm,
                          p.lambda_fitness, p.dist0, 2.0 * p.swarm_clearance, p.v_max, p.a_max,
                          p.feasibility_tolerance, p.swarm_min_gap)
        self._dt_knot = p.ctrl_spacing / p.v_max

    # ------------------------------------------------------------------ contract

    def reset(self, scenario: Scenario, positions: np.ndarray, velocities: np.ndarray,
              rng: np.random.Generator) -> None:
        p = self.params
        n, dim = np.asarray(positions).shape
        need = grid_cells(scenario.bounds, p.grid_resolution) * bytes_per_cell(dim, n, False, False)
        check_map_bytes("ego-swarm", f"a {format_extent(scenario.lower, scenario.upper)} world at "
                        f"{p.grid_resolution:g} m resolution", need, p.max_map_bytes, "max_map_bytes",
                        "use a coarser grid_resolution or a smaller world")
        self._map_need = need
        self.maps = OccupancyMaps(scenario.solid_obstacles, scenario.bounds, n, p.grid_resolution, p.inflation,
                                  p.sensing_range)
        self._counts = np.array(self.maps.shape[::-1], dtype=np.int64)
        x = np.asarray(positions, dtype=float)
        self.goals = goal_slots(scenario.goal_array, x, p.goal_disc)
        self._home = x.copy()  # start of each robot's global path (the line to its goal)
        self._log = CommLog()
        self.board = TrajectoryBoard(n, self._log)
        self._dim = dim
        self._plans: list = [None] * n
        self._t0 = np.zeros(n)  # [s] start of each robot's plan
        self._k0 = np.zeros(n, dtype=np.int64)  # its start step
        self._len = np.ones(n, dtype=np.int64)  # its samples at the control rate
        self._final = np.zeros(n, dtype=bool)  # the plan ends at the robot's goal
        self._braking = np.zeros(n, dtype=bool)
        self._retry = np.zeros(n, dtype=bool)
        self._last = np.full(n, -10**9, dtype=np.int64)  # step of the last replan
        cap = 64
        self._Q = np.repeat(x[:, None, :], cap, axis=1)
        self._V = np.zeros((n, cap, dim))
        self._A = np.zeros((n, cap, dim))
        self._check_every = max(1, int(round(p.check_period / p.dt)))
        self._min_gap = max(1, int(round(4 * p.check_period / p.dt)))  # steps between two triggered replans
        self._stats = dict(plans=0, fallbacks=0, brakes=0, rebounds=0, refined=0, iterations=0, pairs=0,
                           failed_searches=0, astar_seeds=0, trig_obstacle=0, trig_swarm=0, trig_period=0, trig_end=0)
        self._plan_ms: list[float] = []
        self._steps = 0
        self._log_plans = PlanLog(dim)
        self._geom = scenario.geometry
        self._scanner = None  # maps from scans (sense.map = scans): made at the first step
        self._fresh = np.zeros(n, dtype=bool)  # robots whose scanned map gained cells since the last check

    def act(self, obs: Observation, rng: np.random.Generator) -> tuple[np.ndarray, dict]:
        p = self.params
        x, v = obs.positions, obs.velocities
        k = obs.step
        n = x.shape[0]
        heard = self._heard(obs)
        if self._steps == 0 and obs.sensing is not None:
            self._scanner = scanner(obs, self._geom, self.maps, p.sensing_range, p.dt, budget=(
                "ego-swarm", self._map_need, p.max_map_bytes, "max_map_bytes"))
        if self._scanner is not None:  # each robot's map from its own scans
            self._fresh |= self._scanner.sweep(obs, x)
        if self._steps == 0:
            for r in range(n):
                self.maps.observe(r, x[r])
            for r in range(n):
                self._replan(r, k, obs.time, x[r], v[r], first=True, heard=heard)
        elif k % self._check_every == 0:
            trig = self._triggers(k, obs.time, x, heard)
            for r in np.flatnonzero(trig):
                self._replan(int(r), k, obs.time, x[r], v[r], heard=heard)
        self._steps += 1
        q_ref, v_ref, a_ref = self._reference(k)
        command = track(x, v, q_ref, v_ref, a_ref, p.k_p, p.k_v)
        # the plans as they stand after this step's commits: what every robot sends from now on
        return command, {"publish": {"trajectory": tuple(self.board.records)}}

    def summary(self) -> dict[str, float]:
        s = self._stats
        plans = max(s["plans"], 1)
        return {
            "ego_plans": float(s["plans"]),
            "ego_fallbacks": float(s["fallbacks"]),
            "ego_brakes": float(s["brakes"]),
            "ego_rebounds_mean": s["rebounds"] / plans,
            "ego_refined": float(s["refined"]),
            "ego_opt_iterations_mean": s["iterations"] / plans,
            "ego_pairs_mean": s["pairs"] / plans,
            "ego_failed_searches": float(s["failed_searches"]),
            "ego_astar_seeds": float(s["astar_seeds"]),
            "ego_replans_obstacle": float(s["trig_obstacle"]),
            "ego_replans_swarm": float(s["trig_swarm"]),
            "ego_replans_period": float(s["trig_period"]),
            "ego_replans_end": float(s["trig_end"]),
            **self._log.summary(self._steps * self.params.dt),
            **(self._scanner.summary() if self._scanner is not None else {}),
        }

    def timings(self) -> dict[str, float]:
        """Planning time per robot per replan [ms], wall clock (not a metric)."""
        return plan_time_summary(self._plan_ms)

    def plans(self) -> dict[str, np.ndarray]:
        """Every committed plan (splines and emergency stops), sampled every 0.1 s
        (:class:`~swarmnav.planning.plan_log.PlanLog`; docs/methods/contract.md)."""
        return self._log_plans.arrays()

    # ------------------------------------------------------------------ the state machine

    def _index(self, k: int | np.ndarray) -> np.ndarray:
        return np.clip(np.asarray(k) - self._k0, 0, self._len - 1)

    def _reference(self, k: int):
        r = np.arange(len(self._k0))
        i = self._index(k)
        return self._Q[r, i], self._V[r, i], self._A[r, i]

    def _view(self, r: int) -> MapView:
        return MapView(self.maps.grids[r].reshape(-1), self._counts, self.maps.origin, self.maps.resolution, 1)

    @staticmethod
    def _heard(obs: Observation) -> np.ndarray | None:
        """(N, N) object array: row r the newest plan robot r received of every other (None: none;
        its own entry None, a robot reads its own plan itself); None under the ideal network."""
        if obs.view is None:
            return None
        n = obs.positions.shape[0]
        got = obs.received("trajectory")
        heard = np.full((n, n), None, dtype=object) if got is None else got.copy()
        np.fill_diagonal(heard, None)
        return heard

    def _samples(self, b, js: np.ndarray) -> np.ndarray:
        """A received plan's positions at steps ``js`` (its reference at the control rate, as its
        robot flies it; clamped to the plan: before it its first point, after it its last)."""
        k0, q = b.data
        return q[np.clip(js - k0, 0, len(q) - 1)]

    def _gaps(self, r: int, js: np.ndarray, heard_r: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Least distance [m] over steps ``js`` between robot ``r``'s plan and each plan it
        received (inf: none), and the start [s] of each (NaN: none)."""
        n = len(heard_r)
        gap, start = np.full(n, np.inf), np.full(n, np.nan)
        mine = self._Q[r, np.clip(js - self._k0[r], 0, self._len[r] - 1)]
        for j, b in enumerate(heard_r):
            if b is not None:
                gap[j] = np.linalg.norm(self._samples(b, js) - mine, axis=1).min()
                start[j] = b.start
        return gap, start

    def _triggers(self, k: int, t: float, x: np.ndarray, heard: np.ndarray | None = None) -> np.ndarray:
        """Which robots replan at step ``k`` (module docstring, 1); ``heard``: each robot's
        received plans (:meth:`_heard`), None under the ideal network."""
        p = self.params
        n = x.shape[0]
        trig = np.zeros(n, dtype=bool)
        # (a) newly seen obstacles on the rest of the plan
        m = self.maps
        if m.scanned:  # maps from scans: a robot whose map gained cells checks the rest of its plan
            for r in np.flatnonzero(self._fresh):
                if self._collides(int(r), k) >= 0:
                    trig[r] = True
                    self._stats["trig_obstacle"] += 1
            self._fresh[:] = False
        elif len(m.footprints):
            d = np.maximum(np.maximum(m.bbox_lo[None] - x[:, None], x[:, None] - m.bbox_hi[None]), 0.0)
            near = np.einsum("nod,nod->no", d, d) <= p.sensing_range ** 2
            fresh = np.flatnonzero(np.any(near & ~m.known, axis=1))
            for r in fresh:
                m.observe(int(r), x[r])
                if self._collides(int(r), k) >= 0:
                    trig[r] = True
                    self._stats["trig_obstacle"] += 1
        # (b) a newer broadcast plan passes too close
        step = max(1, int(round(0.2 / p.dt)))
        js = k + step * np.arange(int(p.swarm_check_horizon / (step * p.dt)) + 1)
        if heard is None:
            idx = np.clip(js[None, :] - self._k0[:, None], 0, (self._len - 1)[:, None])  # (N, J)
            P = self._Q[np.arange(n)[:, None], idx]  # (N, J, D)
            gap = np.linalg.norm(P[:, None] - P[None, :], axis=3).min(axis=2)  # (N, N)
            newer = self._t0[None, :] > self._t0[:, None]
        else:  # each robot against the plans it received; a plan many hold is sampled once
            rows, cols, which, plans, seen = [], [], [], [], {}
            for r in range(n):
                for j, b in enumerate(heard[r]):
                    if b is not None:
                        rows.append(r)
                        cols.append(j)
                        which.append(seen.setdefault(id(b), len(plans)))
                        if which[-1] == len(plans):
                            plans.append(b)
            gap, newer = np.full((n, n), np.inf), np.zeros((n, n), dtype=bool)
            if plans:
                idx = np.clip(js[None, :] - self._k0[:, None], 0, (self._len - 1)[:, None])
                mine = self._Q[np.arange(n)[:, None], idx]  # (N, J, D)
                theirs = np.stack([self._samples(b, js) for b in plans])  # (U, J, D)
                rows, cols, which = np.array(rows), np.array(cols), np.array(which)
                gap[rows, cols] = np.linalg.norm(theirs[which] - mine[rows], axis=2).min(axis=1)
                newer[rows, cols] = np.array([b.start for b in plans])[which] > self._t0[rows]
        conflict = np.any((gap < p.swarm_check_clearance) & newer, axis=1) & ~trig
        conflict &= k - self._last >= self._min_gap
        trig |= conflict
        self._stats["trig_swarm"] += int(conflict.sum())
        # (c) replan period, (d) end of a plan short of the goal, (e) a failed replan
        far = np.linalg.norm(x - self.goals, axis=1) > p.no_replan_dist
        period = (t - self._t0 >= p.replan_period) & far & ~trig
        end = (k - self._k0 >= self._len - 1) & ~self._final & ~trig & ~period
        retry = self._retry & (k - self._last >= self._min_gap) & ~trig & ~period & ~end
        self._stats["trig_period"] += int(period.sum())
        self._stats["trig_end"] += int(end.sum())
        return trig | period | end | retry

    def _collides(self, r: int, k: int, horizon: float | None = None) -> int:
        """Step offset (from ``k``) of the first sample of robot ``r``'s plan inside an occupied
        cell of its map (-1: none), looking ``horizon`` [s] ahead (None: to the plan's end)."""
        i0 = int(self._index(k)[r])
        i1 = int(self._len[r]) if horizon is None else min(int(self._len[r]), i0 + int(horizon / self.dt) + 1)
        stride = max(1, int(round(0.5 * self.maps.resolution / (self.params.v_max * self.dt))))
        pts = np.ascontiguousarray(self._Q[r, i0:i1:stride])
        view = self._view(r)
        hit = curve_hits(pts, view.grid, view.counts, view.origin, view.res, view.blocked)
        return -1 if hit < 0 else hit * stride

    def _swarm_conflict(self, r: int, k: int, horizon: float, heard_r: np.ndarray | None = None) -> int:
        """0 if robot ``r``'s plan passes a newer plan of another robot (``heard_r``: the plans it
        received; None: the ideal network's) closer than ``swarm_clearance`` within ``horizon``
        [s], else -1."""
        n = len(self._k0)
        js = k + np.arange(0, int(horizon / self.dt) + 1, max(1, int(round(0.1 / self.dt))))
        if heard_r is not None:
            gap, start = self._gaps(r, js, heard_r)
            with np.errstate(invalid="ignore"):
                close = (gap < self.params.swarm_clearance) & (start > self._t0[r])
            return 0 if np.any(close) else -1
        idx = np.clip(js[None, :] - self._k0[:, None], 0, (self._len - 1)[:, None])
        P = self._Q[np.arange(n)[:, None], idx]  # (N, J, D)
        gap = np.linalg.norm(P - P[r][None], axis=2).min(axis=1)
        close = (gap < self.params.swarm_clearance) & (self._t0 > self._t0[r])
        close[r] = False
        return 0 if np.any(close) else -1

    def _local_goal(self, r: int, q: np.ndarray) -> tuple[np.ndarray, bool]:
        """The point of the global path ``home -> goal`` at ``planning_horizon`` from ``q`` (the
        goal itself within reach), moved towards ``q`` out of occupied cells of the map."""
        p = self.params
        g, s = self.goals[r], self._home[r]
        if np.linalg.norm(g - q) <= p.planning_horizon:
            lg, final = g.copy(), True
        else:
            u = g - s
            L2 = float(u @ u)
            # largest lambda in [0, 1] with |s + lambda u - q| = horizon
            b = float(u @ (s - q))
            c = float((s - q) @ (s - q)) - p.planning_horizon ** 2
            disc = b * b - L2 * c
            lam = (-b + math.sqrt(disc)) / L2 if disc >= 0 and L2 > 0 else 1.0
            lam = min(max(lam, 0.0), 1.0)
            lg, final = s + lam * u, False
            if np.linalg.norm(lg - q) > p.planning_horizon * 1.0001:  # off the line by more than the horizon
                lg = q + p.planning_horizon * (g - q) / np.linalg.norm(g - q)
        view = self._view(r)
        if not occupied(view.grid, view.counts, view.origin, view.res, view.blocked, lg):
            return lg, final
        # an occupied local goal moves to the nearest free point along the line from q through it
        # (beyond it first: a point behind an obstacle would turn the plan back)
        d = lg - q
        dist = float(np.linalg.norm(d))
        if dist < 1e-9:
            return lg, final
        u = d / dist
        res = self.maps.resolution
        for s_ in range(1, int(3.0 / res) + 1):
            for cand in (lg + s_ * res * u, lg - s_ * res * u):
                if not occupied(view.grid, view.counts, view.origin, view.res, view.blocked, cand):
                    return cand, False
        return lg, final

    def _replan(self, r: int, k: int, t: float, x: np.ndarray, v: np.ndarray, first: bool = False,
                heard: np.ndarray | None = None) -> None:
        """One robot's replan (module docstring, 2-3), against the plans of the ideal network's
        board, or (``heard``) those robot ``r`` received."""
        p = self.params
        t_wall = time.perf_counter()
        dim = self._dim
        self._last[r] = k
        if first:
            q0, v0, a0 = x.copy(), v.copy(), np.zeros(dim)
        else:
            i = int(self._index(k)[r])
            q0, v0, a0 = self._Q[r, i].copy(), self._V[r, i].copy(), self._A[r, i].copy()
            if np.linalg.norm(q0 - x) > p.reset_lag:
                q0, v0, a0 = x.copy(), v.copy(), np.zeros(dim)
        lg, final = self._local_goal(r, q0)
        # initial path: the rest of the current plan, then straight to the local goal
        path = [q0[None]]
        if not first and self._plans[r] is not None and not self._braking[r]:
            i = int(self._index(k)[r])
            stride = max(1, int(round(0.1 / self.dt)))
            rest = self._Q[r, i + stride:int(self._len[r]):stride]
            if len(rest):  # up to its point nearest the new local goal (no doubling back)
                path.append(rest[: int(np.argmin(np.linalg.norm(rest - lg, axis=1))) + 1])
        path.append(lg[None])
        path = np.vstack(path)
        if self._retry[r] and p.retry_guide == "astar":  # ours: after a failed replan, seed from A*
            found = self.maps.search(r, q0, lg, p.max_expand)
            if found is not None and len(found) >= 2:
                path = found
                self._stats["astar_seeds"] += 1
        pts = resample(path, p.ctrl_spacing)
        if len(pts) < 2:
            pts = np.vstack([q0, lg])
        end_v = np.zeros(dim)
        if not final:
            tangent = pts[-1] - pts[-2]
            end_v = p.v_max * tangent / max(np.linalg.norm(tangent), 1e-9)
        dt = self._dt_knot
        start, end = (q0, v0, a0), (pts[-1], end_v, np.zeros(dim))  # the end: initial guess, then free
        guide = pts[2:-2] if not final else pts[2:-1]
        ctrl = np.vstack([boundary_points(*start, dt), guide.reshape(-1, dim), boundary_points(*end, dt)])
        view = self._view(r)
        if heard is None:
            others = np.array([j for j in range(len(self._plans)) if j != r and self._plans[j] is not None],
                              dtype=np.int64)
            sample = lambda times: self.board.sample(others, times, dim)  # noqa: E731
        else:
            others = [b for b in heard[r] if b is not None]
            sample = lambda times: sample_broadcasts(others, times, dim)  # noqa: E731

        def others_at(dt_knot: float, n_ctrl: int) -> np.ndarray:
            times = t + dt_knot * (np.arange(n_ctrl) - 1.0)
            return np.ascontiguousarray(sample(times)) if len(others) else np.zeros((0, n_ctrl, dim))

        def search(a: np.ndarray, b: np.ndarray):
            return self.maps.search(r, a, b, p.max_expand)

        out = rebound_optimize(ctrl, dt, self._w, view, search, others_at, p.max_rebound, p.max_iter, None if final else lg,
                               p.max_restart)
        if out.ok:
            out = reallocate(out, start, self._w, view, others_at, p.max_iter)
        s = self._stats
        s["plans"] += 1
        s["iterations"] += out.iterations
        s["rebounds"] += out.rebounds
        s["pairs"] += out.pairs
        s["failed_searches"] += out.failed_searches
        s["refined"] += int(out.refined)
        if out.ok and not p.force_fail:
            self._commit(r, k, t, SplinePlan(out.ctrl, out.dt, out.iterations), out.ctrl.shape[0], final)
            self._retry[r] = False
            self._braking[r] = False
        else:
            s["fallbacks"] += 1
            self._retry[r] = True
            hit = -1 if self._plans[r] is None else self._collides(r, k, p.emergency_time)
            if hit < 0 and self._plans[r] is not None and p.brake_on_swarm:
                hit = self._swarm_conflict(r, k, p.emergency_time, None if heard is None else heard[r])
            if self._plans[r] is None or (hit >= 0 and not self._braking[r]):
                s["brakes"] += 1
                i = int(self._index(k)[r])
                qb, vb = (x, v) if self._plans[r] is None else (self._Q[r, i], self._V[r, i])
                self._commit(r, k, t, BrakePlan(qb, vb, p.a_max), 2, False)
                self._braking[r] = True
        self._plan_ms.append(1e3 * (time.perf_counter() - t_wall))

    def _commit(self, r: int, k: int, t: float, plan, n_points: int, final: bool) -> None:
        """Make ``plan`` robot ``r``'s reference from step ``k`` and broadcast it."""
        length = int(math.ceil(plan.duration / self.dt)) + 1
        if length > self._Q.shape[1]:
            grow = length - self._Q.shape[1] + 64
            pad = lambda a, fill: np.concatenate([a, np.repeat(fill, grow, axis=1)], axis=1)  # noqa: E731
            self._Q = pad(self._Q, self._Q[:, -1:])
            self._V = pad(self._V, np.zeros_like(self._V[:, -1:]))
            self._A = pad(self._A, np.zeros_like(self._A[:, -1:]))
        q, vq, aq = plan.sample(self.dt * np.arange(length))
        q.flags.writeable = False  # it travels with the broadcast: never changed after it
        self._Q[r, :length], self._V[r, :length], self._A[r, :length] = q, vq, aq
        rows = sample_rows(length, self.dt)  # the reference just sampled, every 0.1 s of it
        self._log_plans.add(k, r, t + self.dt * rows, q[rows])
        self._k0[r], self._len[r], self._t0[r] = k, length, t
        self._final[r] = final
        self._plans[r] = plan
        self.board.publish(r, plan.sample, t, plan.duration, n_points, data=(k, q))
