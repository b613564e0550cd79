"""``sph``: swarm navigation based on smoothed particle hydrodynamics (Li et al., RA-L 2025).

Every control step (Algorithm 2):

1. raycast visibility: the neighbours within R whose line of sight is free interact; the
   connected components of that graph are the sub-swarms (labels, split/merge events);
2. SPH coordination force over the visible neighbours (Algorithm 1): density/pressure,
   1/r repulsion, viscosity, plus the ESDF environment force (eqs. 5-6);
3. every T_p each robot replans its own uniform cubic B-spline (eqs. 7-12) from a grid-search
   path on its own occupancy map, and the spline is sampled at the control rate;
4. the command is the tracking law of eq. (13):
   ``a_i = F_i / m + k_p (q* - q_i) + k_v (v* - v_i) + a*``, saturated by the dynamics (eq. 2).

Planning is per robot (by design of the paper: each UAV plans independently), in a loop over
robots or, with ``threads`` > 1, on a pool of threads (the compiled search and optimiser release
the GIL; results are collected by robot index, so they are identical for any thread count); the
coordination force and visibility are array operations.

The same code flies planar and 3-D scenes (the paper's Fig. 3 (C, D)): positions, forces,
splines and references are (N, d) with d = ``scenario.dim``; only the field (bilinear or
trilinear ESDF) and the grid search (8- or 26-connected) differ, chosen by the scene.
"""

from __future__ import annotations

import itertools
import time
from concurrent.futures import ThreadPoolExecutor
from typing import Any, NamedTuple

import numpy as np

from swarmnav.dynamics import SaturatedDoubleIntegrator
from swarmnav.errors import ConfigError
from swarmnav.methods.base import Observation, check_map_bytes, format_extent
from swarmnav.methods.sph.kernel import environment_force, released_environment_force, sph_forces
from swarmnav.methods.sph.params import SphParams, for_dim
from swarmnav.methods.sph.visibility import components, link_changes, structural_events, visible_pairs
from swarmnav.methods.sph.parts.guard import band_guard
from swarmnav.methods.sph.networked import directed_forces, directed_yield_rates, heard_pairs
from swarmnav.methods.sph.parts.pairs import bound_rows, pair_guard, pair_guard_known, pair_reach
from swarmnav.methods.sph.parts.retime import retimed
from swarmnav.methods.sph.parts.yielding import goal_distance_field, yield_rates
from swarmnav.params import build
from swarmnav.planning.bspline import SplineCosts, optimize
from swarmnav.planning.maps import OccupancyMaps, bytes_per_cell, grid_cells, resample
from swarmnav.planning.messages import POSITION_BYTES, CommLog
from swarmnav.planning.plan_log import PlanLog, sample_times
from swarmnav.planning.scanned import scanner
from swarmnav.planning.schedule import MAX_PLAN_STEPS, ReplanSchedule, plan_time_summary
from swarmnav.planning.tracker import References, track
from swarmnav.sensing.esdf import Esdf, grid_nodes
from swarmnav.sensing.geometry import surfaces_within
from swarmnav.world.scenario import Scenario


#: Peak bytes per node of building the yield field (parts/yielding.goal_distance_field: the node graph
#: and its Dijkstra; measured with tracemalloc on 0.5-5 M nodes), 8 of which stay as the field
_YIELD_BYTES = {2: 330, 3: 970}


def map_bytes(scenario: Scenario, p: SphParams) -> float:
    """Memory [B] the maps of an SPH run on ``scenario`` take at once: the ESDF (8 B a node at
    ``esdf_resolution``), the robots' occupancy grids with their searches
    (:func:`~swarmnav.planning.maps.bytes_per_cell` at ``grid_resolution``, one set of search
    work arrays per planning thread) and, with yielding on, the yield field being built (at
    ``yield_resolution``)."""
    b, d = scenario.bounds, scenario.dim
    need = 8.0 * grid_nodes(b, p.esdf_resolution)
    need += grid_cells(b, p.grid_resolution) * bytes_per_cell(d, scenario.n, p.search_3d == "field",
                                                              p.plan_neighbours > 0, p.threads)
    if p.yield_range > 0:
        step = max(1, int(round(p.yield_resolution / p.esdf_resolution)))
        need += _YIELD_BYTES[d] * grid_nodes(b, p.esdf_resolution * step)
    return need


class AxisClampedDoubleIntegrator:
    """The released controller's bound (``sph_zhang_3d.cpp``, ``parallelUpdateParticlePositions``):
    ``v_{k+1} = clamp(v_k + dt clamp(a, a_max), v_max)``, ``p_{k+1} = p_k + dt v_{k+1}``, every
    clamp per axis (eq. 2 bounds the Euclidean norms instead)."""

    __slots__ = ("v_max", "a_max")

    def __init__(self, v_max: float, a_max: float):
        self.v_max = v_max  # [m/s], per axis
        self.a_max = a_max  # [m/s^2], per axis

    def step(self, p: np.ndarray, v: np.ndarray, a_cmd: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
        v_new = np.clip(v + dt * np.clip(a_cmd, -self.a_max, self.a_max), -self.v_max, self.v_max)
        return p + dt * v_new, v_new


class _Planned(NamedTuple):
    """One robot's replan, as :meth:`Sph._plan_one` returns it: its spline and what the run
    counts of it (added up by robot index, whatever thread planned it)."""

    plan: Any  # SplinePlan
    failed: bool  # the grid search found no path (the spline heads straight for the goal)
    reaches_end: bool  # the local plan ends at the robot's goal
    iterations: int  # optimiser iterations, re-timing included
    retimed: bool
    ms: float  # wall-clock time of the replan [ms]


class Sph:
    """The SPH navigation method (see module docstring)."""

    name = "sph"
    dims = (2, 3)  # flies planar and 3-D scenes natively: every array is (N, d), d from the scene
    networked = True  # reads the others only through Observation.known (docs/network.md)
    map_sensor = True  # can build its maps from its own scans (sense.map = scans; docs/sensing.md)

    def __init__(self, **overrides: Any):
        p = build(SphParams, overrides, context="sph")
        self.params = p
        self.dt = p.dt
        if p.clip == "norm":
            self.dynamics = SaturatedDoubleIntegrator(p.v_max, p.a_max)
        else:
            self.dynamics = AxisClampedDoubleIntegrator(p.v_max, p.a_max)
        # the planner's bounds (the released code plans slower than its controller may fly)
        self._plan_v = p.plan_v_max or p.v_max
        plan_a = p.plan_a_max or p.a_max
        self._costs = SplineCosts(p.lambda_s, p.lambda_c, p.lambda_f, p.d_thr, self._plan_v, plan_a)
        # knot span [s]: control points ctrl_spacing apart at plan_speed * (planner's) v_max
        self._dt_knot = p.ctrl_spacing / (p.plan_speed * self._plan_v)
        if not self._dt_knot / p.dt <= MAX_PLAN_STEPS:  # near-zero speeds (plan_speed = 1e-308) overflow the spline
            raise ConfigError(f"sph: control points ctrl_spacing = {p.ctrl_spacing:g} m apart at plan_speed x v_max = "
                              f"{p.plan_speed * self._plan_v:.3g} m/s are {self._dt_knot:.3g} s apart, "
                              f"{self._dt_knot / p.dt:.3g} control steps of dt (at most {MAX_PLAN_STEPS:.0e}); "
                              "raise plan_speed or v_max")
        self._pool: ThreadPoolExecutor | None = None  # the planning threads of a run (threads > 1)

    # ------------------------------------------------------------------ contract

    def reset(self, scenario: Scenario, positions: np.ndarray, velocities: np.ndarray,
              rng: np.random.Generator) -> None:
        p = self.flown = for_dim(self.params, scenario.dim, scenario.n)  # by_dim: the set of the scene's dimension and size
        self.scenario = scenario
        self.geom = scenario.geometry
        n = scenario.n
        res = (f"{p.esdf_resolution:g} m" if p.esdf_resolution == p.grid_resolution else
               f"{p.esdf_resolution:g} m (ESDF) and {p.grid_resolution:g} m (grid)")
        check_map_bytes("sph", f"a {format_extent(scenario.lower, scenario.upper)} world at {res} resolution",
                        map_bytes(scenario, p), p.max_map_bytes, "max_map_bytes",
                        "use a coarser resolution or a smaller world")
        self.esdf = Esdf.build(self.geom, scenario.bounds, p.esdf_resolution)
        self.maps = OccupancyMaps(scenario.solid_obstacles, scenario.bounds, n, p.grid_resolution, p.inflation, p.R,
                                  margin=p.d_thr, wide=p.plan_clearance, wide_cost=p.plan_clearance_cost,
                                  weight_3d=p.search_weight_3d, field_3d=p.search_3d == "field")
        x = np.asarray(positions, dtype=float)
        self.goals = scenario.goal_array + p.goal_spread * (x - x.mean(axis=0))
        self._schedule = ReplanSchedule(p.T_p, p.dt)
        if p.yield_range > 0:  # the order of yielding: the way to the goal through free space
            self._to_goal = goal_distance_field(self.esdf, scenario.goal_array, p.inflation,
                                                p.yield_resolution)
        self.references = References()  # every robot's plan sampled at the control rate (public: tests read it)
        self._comm = CommLog()  # every robot broadcasts its position at broadcast_hz (Section IV-A)
        self._final = np.zeros(n, dtype=bool)  # each robot's last local plan ended at its goal
        self._hold = np.zeros(n)  # steps each robot's reference clock stood still (since the last plan)
        self._yield_steps = 0.0  # robot-steps with a slowed reference clock
        self._pair_guarded = 0  # robot-steps whose command the pair guard changed
        self._pair_infeasible = 0  # of them, robot-steps no command met every pair constraint
        self._prev_labels: np.ndarray | None = None
        self._prev_visible = np.zeros(0, dtype=np.int64)
        self._plans = 0
        self._search_failures = 0
        self._retimes = 0
        self._iterations = 0
        self._link_merges = 0
        self._link_splits = 0
        self._neighbours = 0.0
        self._steps = 0
        self._plan_ms: list[float] = []
        self._coord_ms: list[float] = []
        self._log_plans = PlanLog(scenario.dim)
        self._scanner = None  # maps from scans (sense.map = scans): made at the first step
        self.close()  # a pool of an earlier run that was not closed
        if p.threads > 1:  # threads - 1 helpers: the stepping thread plans too
            self._pool = ThreadPoolExecutor(p.threads - 1, thread_name_prefix="sph-plan")

    def close(self) -> None:
        """End the run's planning threads (the rollout calls it when the run ends; a later
        :meth:`reset` starts new ones)."""
        if self._pool is not None:
            self._pool.shutdown(wait=True)
            self._pool = None

    def act(self, obs: Observation, rng: np.random.Generator) -> tuple[np.ndarray, dict]:
        p = self.flown
        x, v = obs.positions, obs.velocities
        n = x.shape[0]
        t0 = time.perf_counter()
        view = obs.view  # None: the ideal network, every robot's true state (docs/network.md)
        if obs.step == 0 and obs.sensing is not None:
            body = self.scenario.rules.body_radius  # the field is read up to the widest band of a term
            reach = max(p.d_thr, p.env_safe + p.env_inflation, p.start_clearance, body + p.pair_margin,
                        p.yield_clearance if p.yield_range > 0 else 0.0)
            self._scanner = scanner(obs, self.geom, self.maps, p.R, p.dt, reach,
                                    ("sph", map_bytes(self.scenario, p), p.max_map_bytes, "max_map_bytes"))
        if self._scanner is not None:  # each robot's map and distance field from its own scans
            self._scanner.sweep(obs, x)
        # Algorithm 2: raycast visibility, sub-swarms, split / merge
        if view is None:
            i, j, vis = visible_pairs(self.geom, x, p.R)
        else:  # each robot's own directed pairs, from what it received
            kx, kv, heard = obs.known()
            i, j, vis = heard_pairs(self.geom, x, kx, heard, p.R)
        vi, vj = i[vis], j[vis]
        labels = components(n, vi, vj)
        keys = i * n + j
        events: list[dict] = []
        if self._prev_labels is not None:
            events = structural_events(self._prev_labels, labels)
            merges, splits = link_changes(self._prev_visible, keys, vis)
            self._link_merges += merges
            self._link_splits += splits
        self._prev_labels = labels
        self._prev_visible = keys[vis]
        # Algorithm 1 over the visible neighbours, plus the ESDF environment force
        terms = dict(h=p.h, c=p.c, m=p.m, k_den=p.k_den, k_rep=p.k_rep, k_vis=p.k_vis, rho0=p.rho0, gamma=p.gamma,
                     kind=p.kernel, r_floor=p.r_floor, rep_cutoff=p.rep_cutoff)
        if view is None:
            _, _, parts = sph_forces(x, v, vi, vj, **terms)
        else:
            parts = directed_forces(x, v, kx, kv, vi, vj, **terms)
        d, grad = self._field(x)
        push = parts["density"] + parts["repulsive"]
        if p.crowd_guard:  # ours: the swarm's push may not press a robot in the band into the obstacle
            push = band_guard(push, d, grad, p.d_thr)
        force = push + parts["viscosity"]  # sph_forces' own sum, in its order
        if not p.swarm_vertical and x.shape[1] == 3:  # released 3-D: Algorithm 1 acts in x, y only
            force[:, 2] = 0.0
        if p.env_law == "paper":
            force += environment_force(d, grad, p.k_env, p.d_thr)
        else:
            force += released_environment_force(d - p.env_inflation, grad, p.k_force, p.env_safe)
        self._coord_ms.append(1e3 * (time.perf_counter() - t0))
        self._neighbours += 2.0 * len(vi) / max(n, 1)
        self._steps += 1
        self._comm.periodic(obs.step, p.dt, p.broadcast_hz, n, POSITION_BYTES)
        # trajectory planning every T_p (or once, Fig. 3B protocol)
        if self.references.empty or (not p.plan_once and self._schedule.due(obs.step)):
            self._visible = (vi, vj)
            self._seen = None if view is None else kx
            self._replan(obs.step, x, v, d)
        q_ref, v_ref, a_ref = self._reference(obs.step)
        hold = p.once_hold if p.plan_once else p.ref_hold
        # The reference clock (ours, the hook of the waiting parts): each robot's reference runs at
        # the rate phi in [0, 1]; time scaling gives v* = phi v(tau), a* = phi^2 a(tau).
        phi = np.ones(n)
        if hold > 0:
            # The reference waits for a held robot (with plan_once the paper only says the robots
            # follow the "trajectory trends"): the clock slows as the lag grows past hold / 2 and
            # stops at hold.
            lag = np.linalg.norm(q_ref - x, axis=1)
            phi = np.clip(2.0 - 2.0 * lag / hold, 0.0, 1.0)
        if p.yield_range > 0:  # a queue in narrow places (parts/yielding.py)
            to_goal, _ = self._to_goal.query(x)
            if view is None:
                phi = np.minimum(phi, yield_rates(to_goal, x, d, vi, vj, p.yield_range, p.yield_clearance))
            else:  # each robot judges its neighbours where it believes them to be
                seen = np.ascontiguousarray(kx[vi, vj])
                to_goal_of = self._to_goal.query(seen)[0] if len(vi) else np.zeros(0)
                clear_of = self.esdf.query(seen)[0] if len(vi) else np.zeros(0)
                phi = np.minimum(phi, directed_yield_rates(to_goal, to_goal_of, x, seen, d, clear_of, vi, vj,
                                                           p.yield_range, p.yield_clearance))
        if hold > 0 or p.yield_range > 0:
            self._hold += 1.0 - phi
            self._yield_steps += float(np.sum(phi < 1.0))
            v_ref = phi[:, None] * v_ref
            a_ref = (phi * phi)[:, None] * a_ref
        if hold > 0:
            # a waiting clock cannot bring back a reference that has ended (the goal) or a robot pushed
            # aside: the position error is bounded by hold, as ref_clamp bounds it at a replan
            far = lag > hold
            q_ref = q_ref.copy()
            q_ref[far] = x[far] + (q_ref[far] - x[far]) * (hold / lag[far])[:, None]
        # eq. (13)
        if p.band_guard:
            a = force / p.m + band_guard(track(x, v, q_ref, v_ref, a_ref, p.k_p, p.k_v), d, grad, p.d_thr)
        else:
            a = track(x, v, q_ref, v_ref, a_ref, p.k_p, p.k_v, feedforward=force / p.m)
        if p.pair_guard:  # ours: no command drives a robot into another (parts/pairs.py)
            body = self.scenario.rules.body_radius
            safe = 2.0 * body + p.pair_margin
            walls = None
            if p.pair_obstacles and x.shape[1] == 2 and self._scanner is None:
                # a row for every obstacle near a robot, from the known map (the world's geometry)
                robots, gap, toward = surfaces_within(self.geom, x, pair_reach(body + p.pair_margin, p.pair_decel,
                                                                               p.pair_gamma, p.a_max, p.v_max))
                walls = (gap, -toward, body + p.pair_margin, robots)
            elif p.pair_obstacles:  # 3-D, or maps from scans: the nearest obstacle, from the robot's field
                walls = (d, grad, body + p.pair_margin)
            bound = bound_rows(x.shape[1], p.a_max, p.clip) if p.pair_bound else None
            if view is None:
                a, changed, infeasible = pair_guard(a, x, v, safe, p.pair_decel, p.pair_gamma, p.a_max, p.v_max, p.dt,
                                                    walls, bound)
            else:
                a, changed, infeasible = pair_guard_known(a, x, v, kx, kv, heard, safe, p.pair_decel, p.pair_gamma,
                                                          p.a_max, p.v_max, p.dt, walls, bound)
            self._pair_guarded += changed
            self._pair_infeasible += infeasible
        return a, {"labels": labels, "events": events}

    def summary(self) -> dict[str, float]:
        """Deterministic method metrics (wall-clock times are in :meth:`timings`)."""
        return {
            "sph_plans": float(self._plans),
            "sph_search_failures": float(self._search_failures),
            "sph_retimes": float(self._retimes),
            "sph_opt_iterations_mean": self._iterations / max(self._plans, 1),
            "sph_link_merges": float(self._link_merges),
            "sph_link_splits": float(self._link_splits),
            "sph_visible_neighbours_mean": self._neighbours / max(self._steps, 1),
            "sph_waiting_fraction": self._yield_steps / max(self._steps * len(self._hold), 1),
            **({"sph_pair_guarded_fraction": self._pair_guarded / max(self._steps * len(self._hold), 1),
                "sph_pair_infeasible_steps": float(self._pair_infeasible)} if self.flown.pair_guard else {}),
            **self._comm.summary(self._steps * self.params.dt),
            **(self._scanner.summary() if self._scanner is not None else {}),
        }

    def timings(self) -> dict[str, float]:
        """Wall-clock figures of this run [ms]: planning time per robot per replan (median,
        95th percentile, max) and the coordination (visibility + SPH + ESDF force) time per
        control step for the whole swarm (median). Not reproducible, so not metrics."""
        coord = np.array(self._coord_ms) if self._coord_ms else np.zeros(1)
        return {**plan_time_summary(self._plan_ms), "coord_ms_median": float(np.median(coord))}

    def plans(self) -> dict[str, np.ndarray]:
        """Every robot's spline of every replan, whole, sampled every 0.1 s
        (:class:`~swarmnav.planning.plan_log.PlanLog`; docs/methods/contract.md). A robot flies
        the first ``T_p`` of each before the next replan replaces it."""
        return self._log_plans.arrays()

    # ------------------------------------------------------------------ planning

    def _field(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Distance [m] and gradient of each robot's obstacle field at its row of ``x`` (N, d): the
        world's ESDF, or (maps from scans) each robot's own field from its scans."""
        if self._scanner is not None:
            return self.maps.query(x)
        return self.esdf.query(x)

    def _esdf_of(self, r: int) -> Esdf:
        """The distance field robot ``r``'s spline is optimised in (eq. 10): the world's ESDF, or
        (maps from scans) its own."""
        return self.esdf if self._scanner is None else self.maps.esdf(r)

    def _reference(self, step: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Reference samples ``tau_j = t_k + j dt`` (eq. 13) for the current step."""
        return self.references.at(step, np.round(self._hold).astype(np.int64))

    def _replan(self, step: int, x: np.ndarray, v: np.ndarray, clearance: np.ndarray) -> None:
        p = self.flown
        n, dim = x.shape
        if self.references.empty:
            start_q, start_v, start_a = x.copy(), v.copy(), np.zeros_like(x)
        else:
            start_q, start_v, start_a = (r.copy() for r in self._reference(step))
            if p.replan_from == "state":
                start_q, start_v = x.copy(), v.copy()
            else:  # released behaviour: continue the reference unless the robot is far from it
                lag = np.linalg.norm(start_q - x, axis=1)
                reset = np.full(n, p.ref_reset)
                if p.goal_reset > 0:  # ours: the final approach needs no headroom for obstacles
                    reset[self._final & (clearance > p.plan_clearance)] = p.goal_reset
                off = lag > reset
                if p.ref_clamp:  # ours: pull the start back to the bound from the robot (no jump to 0)
                    start_q[off] = x[off] + (start_q[off] - x[off]) * (reset[off] / lag[off])[:, None]
                else:  # released: restart at the robot
                    start_q[off] = x[off]
                if p.reset_velocity:  # ours: restart from the measured velocity as well
                    start_v[off] = v[off]
            if p.start_clearance > 0:  # ours: a reference at an obstacle is no start (docs: A start at an obstacle)
                bad = self._field(start_q)[0] < p.start_clearance
                start_q[bad], start_v[bad], start_a[bad] = x[bad], v[bad], 0.0
        plans = []
        near = None
        if p.plan_neighbours > 0 and self._seen is None:  # visible neighbours within plan_neighbours_range, by robot
            vi, vj = self._visible
            dist = np.linalg.norm(x[vi] - x[vj], axis=1)
            close = dist < p.plan_neighbours_range
            a, b = vi[close], vj[close]
            near = [x[np.concatenate([b[a == r], a[b == r]])] for r in range(n)]
        elif p.plan_neighbours > 0:  # on a network: where each robot believes its visible neighbours are
            vi, vj = self._visible
            seen = self._seen[vi, vj]
            close = np.linalg.norm(x[vi] - seen, axis=1) < p.plan_neighbours_range
            near = [seen[close & (vi == r)] for r in range(n)]
        jobs = [(r, start_q[r], start_v[r], start_a[r], near[r] if near is not None else None) for r in range(n)]
        if self._pool is None:
            done = [self._plan_one(*job) for job in jobs]
        elif self.maps.order_dependent:  # the 3-D field search: paths in robot order, splines in parallel
            paths = [self._path(*job) for job in jobs]
            done = self._in_parallel(lambda r: self._spline(jobs[r], paths[r]), n)
        else:
            done = self._in_parallel(lambda r: self._plan_one(*jobs[r]), n)
        for r, out in enumerate(done):
            plans.append(out.plan)
            self._search_failures += out.failed
            self._final[r] = out.reaches_end
            self._plans += 1
            self._iterations += out.iterations
            self._retimes += out.retimed
            self._plan_ms.append(out.ms)
        if p.plan_once:
            length = int(np.ceil(max(pl.duration for pl in plans) / p.dt)) + 1
        else:
            length = self._schedule.every
        self.references.load([pl.sample for pl in plans], step, length, p.dt, dim)
        for r, pl in enumerate(plans):
            tau = sample_times(pl.duration)
            self._log_plans.add(step, r, step * p.dt + tau, pl.sample(tau)[0])
        self._schedule.done(step)
        if not p.plan_once:
            self._hold[:] = 0.0  # the new reference starts at this step

    def _in_parallel(self, plan: Any, n: int) -> list[_Planned]:
        """``[plan(0), ..., plan(n - 1)]``, computed by this thread and the pool's together: each
        takes the next robot index from a shared counter (a robot per pull, so a long search does not
        hold up the others), and each result is stored at its robot's index, whatever thread made it."""
        out: list[Any] = [None] * n
        ticket = itertools.count()  # next() on it is atomic under the GIL

        def work() -> None:
            r = next(ticket)
            while r < n:
                out[r] = plan(r)
                r = next(ticket)

        helpers = [self._pool.submit(work) for _ in range(self.flown.threads - 1)]
        try:
            work()
        finally:
            for h in helpers:
                h.result()  # wait for every helper (and raise a helper's error)
        return out

    def _guide(self, pts: np.ndarray, reaches_end: bool) -> np.ndarray:
        """Initial interior control points C_3 .. C_{K-3} from path points ``pts`` (ctrl_spacing apart)."""
        p = self.flown
        if p.ctrl_seed == "knots":
            # C_2 already stands for the path point one knot ahead (q + v dt, eq. 12) and, with a
            # moving end, C_{K-2} for the one a knot before the end: seed the interior points
            # with the path points at the knots between, so the reference runs at the knot speed
            # ctrl_spacing / dt_knot = v_max instead of repeating those two points.
            return pts[2:-1] if reaches_end or p.end_state == "rest" else pts[2:-2]
        return pts[1:-1]  # released: C_3 .. C_{K-3} = path[1] .. path[-2] (two knots on repeated points)

    def _plan_one(self, r: int, q: np.ndarray, v: np.ndarray, a: np.ndarray,
                  others: np.ndarray | None = None) -> _Planned:
        """One robot's replan: update its map, grid search to its goal, optimise the spline. It
        touches only robot ``r``'s map and the maps' locked caches, so robots may plan in parallel."""
        return self._spline((r, q, v, a, others), self._path(r, q, v, a, others))

    def _path(self, r: int, q: np.ndarray, v: np.ndarray, a: np.ndarray,
              others: np.ndarray | None = None) -> tuple[np.ndarray | None, float]:
        """Robot ``r``'s map update and grid search from ``q`` to its goal: ``(path or None, ms)``."""
        t0 = time.perf_counter()
        p = self.flown
        self.maps.observe(r, q)
        path = self.maps.search(r, q, self.goals[r], p.max_expand, others, p.plan_neighbours)
        return path, 1e3 * (time.perf_counter() - t0)

    def _spline(self, job: tuple, searched: tuple[np.ndarray | None, float]) -> _Planned:
        """The spline of robot ``r`` (``job = (r, q, v, a, others)``) along its searched path."""
        t0 = time.perf_counter()
        p = self.flown
        r, q, v, a, _ = job
        path, search_ms = searched
        goal = self.goals[r]
        failed = path is None
        if failed:  # no path on the robot's map: head straight for the goal
            path = np.vstack([q, goal])
        pts = resample(path, p.ctrl_spacing)
        if len(pts) < 2:
            pts = np.vstack([q, path[-1]])
        reaches_end = p.plan_once or p.horizon_points == 0 or len(pts) - 1 <= p.horizon_points
        if not reaches_end:
            pts = pts[: p.horizon_points + 1]
        end_v = np.zeros_like(q)
        if not reaches_end and p.end_state == "moving":
            tangent = pts[-1] - pts[-2]
            end_v = self._plan_v * tangent / max(np.linalg.norm(tangent), 1e-9)
        end = (pts[-1], end_v, np.zeros_like(q))
        guide = self._guide(pts, reaches_end)
        esdf = self._esdf_of(r)
        plan = optimize((q, v, a), end, guide, self._dt_knot, esdf, self._costs, p.max_iter)
        iterations = plan.iterations
        again = None
        if p.retime > 0 and len(guide):
            again = retimed(plan, (q, v, a), end, pts, p.retime, p.ctrl_spacing,
                            lambda curve: self._guide(curve, reaches_end), self._dt_knot, esdf, self._costs,
                            p.max_iter)
            if again is not None:
                iterations += again.iterations
                plan = again
        return _Planned(plan, failed, bool(reaches_end), int(iterations), again is not None,
                        search_ms + 1e3 * (time.perf_counter() - t0))
