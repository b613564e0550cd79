"""``mader``: MADER, trajectory planning in multi-agent and dynamic environments (Tordesillas &
How, T-RO 2021), for static obstacles and other agents.

Each robot replans continuously and asynchronously. A replan started at step ``k_in``:

1. point A: the robot's committed trajectory at ``t_in + replan_time`` (where the new plan will
   start, since the robot keeps flying the committed one meanwhile);
2. local goal G: the point ``Ra`` along a grid-search path on the robot's own map (or its goal
   when closer); the path also seeds the free control points (our stand-in for Octopus Search);
3. the problem (solver.py): the convex hull of each segment's B-spline control points must be
   separated by a plane from every obstacle polyhedron the robot knows near the seed and from
   every other agent's committed trajectory hull over that segment's time interval (the
   snapshot of ``k_in``); the planes are decision variables; IPOPT (CasADi) solves it, or NLopt;
4. check (at ``t_in + replan_time``): the new plan is tested against every trajectory another
   robot committed after ``k_in`` (it could not be in the problem); a conflict, or a failed
   optimisation, keeps the committed trajectory (a fallback) and the robot replans again.
   Recheck: commits of one step are processed one robot after the other, each check seeing the
   commits before it, so no commit can slip in between a check and its commit.

The command is the shared tracking law (SPH eq. 13 without the swarm force) on the committed
trajectory, which is sampled at the control rate when it is committed.

On a network (docs/network.md) each committed trajectory travels as an immutable
:class:`~swarmnav.planning.messages.Broadcast` (``info["publish"]["trajectory"]``: control points,
knot span, start time, commit step). A robot plans (3) against the newest trajectory it received of
each other robot, in absolute time (a late one is still the trajectory its robot flies); a robot
heard but whose trajectory has not arrived rests where it was heard (the hover plan every robot
starts from); a robot never heard is not there. The check (4) tests the new plan against every
trajectory that *arrived* since the replan started, late ones included. MADER assumes none is
late: a trajectory committed before the check but still in flight is not seen, and two robots can
commit conflicting plans (the failure Robust MADER's delay check addresses; not part of MADER).
"""

from __future__ import annotations

import math
import time
from typing import Any

import numpy as np

from swarmnav.dynamics import SaturatedDoubleIntegrator
from swarmnav.errors import ConfigError
from swarmnav.methods.base import Observation, check_map_bytes, format_extent
from swarmnav.methods.mader import solver as S
from swarmnav.methods.mader.params import MaderParams
from swarmnav.params import build
from swarmnav.planning import bspline, clamped
from swarmnav.planning.hulls import hull_vertices, inflate_points, interval_points, obstacle_vertices, pad, seed_planes, segment_points
from swarmnav.planning.goals import goal_slots
from swarmnav.planning.maps import OccupancyMaps, bytes_per_cell, grid_cells
from swarmnav.planning.messages import Broadcast, CommLog, TrajectoryBoard, sample_broadcasts
from swarmnav.planning.plan_log import PlanLog, sample_rows
from swarmnav.planning.tracker import track
from swarmnav.world.scenario import Scenario
from swarmnav.planning.schedule import plan_time_summary

_MAX_MAP_BYTES = 2 * 1024**3


def min_time(dist: np.ndarray, v_max: float, a_max: float) -> np.ndarray:
    """Rest-to-rest minimum time [s] of a double integrator over ``dist`` [m] per axis (trapezoid
    or triangle velocity profile)."""
    dist = np.abs(dist)
    tri = dist < v_max * v_max / a_max
    return np.where(tri, 2.0 * np.sqrt(dist / a_max), dist / v_max + v_max / a_max)


class MaderMethod:
    """The MADER planner (see the module docstring)."""

    name = "mader"
    dims = (2, 3)
    networked = True  # reads the others' trajectories only through what it received (module docstring)
    periodic = False  # a periodic box has no obstacles to plan around nor a goal: refused in one line

    def __init__(self, **overrides: Any):
        p = build(MaderParams, overrides, context="mader")
        self.params = p
        self.dt = p.dt
        self.dynamics = SaturatedDoubleIntegrator(p.v_max, p.a_max)
        self._force_fail = False  # tests: every optimisation fails

    # ------------------------------------------------------------------ contract

    def reset(self, scenario: Scenario, positions: np.ndarray, velocities: np.ndarray,
              rng: np.random.Generator) -> None:
        p = self.params
        if p.basis != "bspline" and p.algorithm != "ipopt":
            raise ConfigError("mader: basis=bezier needs algorithm=ipopt")
        if p.algorithm != "ipopt" and p.limits != "axis":
            raise ConfigError(f"mader: algorithm={p.algorithm} needs limits=axis (the NLopt path bounds each axis)")
        if p.algorithm != "ipopt" and p.clearance != "box":
            raise ConfigError(f"mader: algorithm={p.algorithm} needs clearance=box (the NLopt path has no ball bound)")
        if p.algorithm != "ipopt" and p.knots != "uniform":
            raise ConfigError(f"mader: algorithm={p.algorithm} needs knots=uniform (the NLopt path is uniform only)")
        if p.algorithm != "ipopt" and S.nlopt is None:  # pragma: no cover
            raise ConfigError("mader: needs the nlopt package (pip install nlopt)")
        n, dim = scenario.n, scenario.dim
        check_map_bytes("mader", f"a {format_extent(scenario.lower, scenario.upper)} world at "
                        f"{p.grid_resolution:g} m", grid_cells(scenario.bounds, p.grid_resolution)
                        * bytes_per_cell(dim, n, False, False), _MAX_MAP_BYTES, "grid_resolution",
                        "use a coarser grid_resolution")
        self.scenario = scenario
        self.dim = dim
        self.body = scenario.rules.body_radius
        obstacles = scenario.solid_obstacles
        self.maps = OccupancyMaps(obstacles, scenario.bounds, n, p.grid_resolution, p.inflation, p.sensing_range)
        zr = (scenario.lower[2], scenario.upper[2]) if dim == 3 else (-1e3, 1e3)
        ball = p.clearance == "ball"  # ball: the planes keep the clearance, the polyhedra are not grown
        self.polys = [obstacle_vertices(o, dim, 0.0 if ball else p.inflation, zr) for o in obstacles]
        grow = p.inflation if ball else 0.0
        self.poly_lo = np.array([v.min(axis=0) - grow for v in self.polys]).reshape(-1, dim)
        self.poly_hi = np.array([v.max(axis=0) + grow for v in self.polys]).reshape(-1, dim)
        x = np.asarray(positions, dtype=float)
        self.goals = goal_slots(scenario.goal_array, x, p.goal_disc)
        self.comm = CommLog()
        self.board = TrajectoryBoard(n, self.comm)
        self.L = max(1, int(round(p.replan_time / p.dt)))  # replan latency [steps]
        # committed plans: control points, knot span, start time [s], commit step
        self.ctrl: list[np.ndarray] = []
        self.dtk = np.ones(n)
        self.t0 = np.zeros(n)
        self.commit_step = np.zeros(n, dtype=np.int64)
        self.ref_q = np.zeros((n, 1, dim))
        self.ref_v = np.zeros((n, 1, dim))
        self.ref_a = np.zeros((n, 1, dim))
        self.ref_k0 = np.zeros(n, dtype=np.int64)
        self.ref_len = np.ones(n, dtype=np.int64)
        self._log_plans = PlanLog(dim)
        for r in range(n):  # at rest where it stands
            self.ctrl.append(np.repeat(x[r][None], p.num_pol + 3, axis=0))
            self._commit(r, self.ctrl[r], 1.0, 0)
        # asynchronous replans: robot r starts its first at step r L / n
        self.next_event = (np.arange(n) * self.L) // max(n, 1)
        self.pending: list[dict | None] = [None] * n
        self.stats = {"plans": 0, "commits": 0, "fallbacks": 0, "check_fails": 0, "evals": 0, "planes": 0,
                      "search_failures": 0, "idle": 0, "infeasible_starts": 0}
        self._plan_ms: list[float] = []
        self._steps = 0

    def act(self, obs: Observation, rng: np.random.Generator) -> tuple[np.ndarray, dict]:
        p = self.params
        k = obs.step
        x, v = obs.positions, obs.velocities
        for r in np.nonzero(self.next_event <= k)[0]:  # robot order: the recheck's serialisation
            heard = None if obs.view is None else self._picture(int(r), obs)
            if self.pending[r] is not None:
                self._check_commit(int(r), k, heard)
            self._start_replan(int(r), k, x[r], heard)
            self.next_event[r] = k + self.L
        self._steps += 1
        idx = np.clip(k - self.ref_k0, 0, self.ref_len - 1)
        rr = np.arange(x.shape[0])
        a = track(x, v, self.ref_q[rr, idx], self.ref_v[rr, idx], self.ref_a[rr, idx], p.k_p, p.k_v)
        return a, {"publish": {"trajectory": tuple(self.board.records)}}

    def summary(self) -> dict[str, float]:
        s = self.stats
        return {
            "mader_plans": float(s["plans"]),
            "mader_commits": float(s["commits"]),
            "mader_fallbacks": float(s["fallbacks"]),
            "mader_check_fails": float(s["check_fails"]),
            "mader_search_failures": float(s["search_failures"]),
            "mader_infeasible_starts": float(s["infeasible_starts"]),
            "mader_evals_mean": s["evals"] / max(s["plans"], 1),
            "mader_planes_mean": s["planes"] / max(s["plans"], 1),
            **self.comm.summary(self._steps * self.params.dt),
        }

    def plans(self) -> dict[str, np.ndarray]:
        """Every committed trajectory (the initial hover plans too), sampled every 0.1 s
        (:class:`~swarmnav.planning.plan_log.PlanLog`; docs/methods/contract.md)."""
        return self._log_plans.arrays()

    def timings(self) -> dict[str, float]:
        """Wall-clock planning time per robot per replan [ms] (not reproducible: not metrics)."""
        return plan_time_summary(self._plan_ms)

    # ------------------------------------------------------------------ commits

    def _commit(self, r: int, ctrl: np.ndarray, dtk: float, step: int) -> None:
        """Robot ``r`` commits ``ctrl`` starting at ``step``: broadcast it and sample its reference."""
        p = self.params
        ctrl.flags.writeable = False  # it travels with the broadcast: never changed after it
        self.ctrl[r], self.dtk[r], self.t0[r], self.commit_step[r] = ctrl, dtk, step * p.dt, step
        dur = (ctrl.shape[0] - 3) * dtk
        self.board.publish(r, lambda tau, c=ctrl, h=dtk: (self._pos(c, h, tau),), step * p.dt, dur, ctrl.shape[0],
                           data=(ctrl, float(dtk), step * p.dt, step))
        length = int(math.ceil(dur / p.dt)) + 1
        if length > self.ref_q.shape[1]:  # grow the buffers, holding each robot's last sample
            extra = length - self.ref_q.shape[1]
            self.ref_q = np.concatenate([self.ref_q, np.repeat(self.ref_q[:, -1:], extra, axis=1)], axis=1)
            self.ref_v = np.concatenate([self.ref_v, np.zeros((self.ref_v.shape[0], extra, self.dim))], axis=1)
            self.ref_a = np.concatenate([self.ref_a, np.zeros((self.ref_a.shape[0], extra, self.dim))], axis=1)
        q, vv, aa = self._eval(ctrl, dtk, p.dt * np.arange(length))
        self.ref_q[r, :length], self.ref_v[r, :length], self.ref_a[r, :length] = q, vv, aa
        self.ref_k0[r], self.ref_len[r] = step, length
        rows = sample_rows(length, p.dt)  # the reference just sampled, every 0.1 s: no second evaluation
        self._log_plans.add(step, r, (step + rows) * p.dt, q[rows])

    def _eval(self, ctrl: np.ndarray, dtk: float, tau: np.ndarray):
        """Position, velocity, acceleration of a plan at times ``tau`` [s] from its start."""
        if self.params.knots == "clamped":
            return clamped.evaluate(ctrl, dtk, tau)
        return bspline.evaluate(ctrl, dtk, tau)

    def _pos(self, ctrl: np.ndarray, dtk: float, tau: np.ndarray) -> np.ndarray:
        """Position of a plan at times ``tau`` [s] from its start (``_eval``'s first array)."""
        if self.params.knots == "clamped":
            return clamped.position(ctrl, dtk, tau)
        return bspline.evaluate(ctrl, dtk, tau)[0]

    def _state(self, r: int, t: float):
        q, v, a = self._eval(self.ctrl[r], self.dtk[r], np.array([t - self.t0[r]]))
        return q[0], v[0], a[0]

    def _picture(self, r: int, obs: Observation) -> list:
        """Robot ``r``'s picture of every robot's committed trajectory (None: never heard; its own
        entry None): the newest it received, or for a robot heard whose trajectory has not arrived
        the hover plan at where it was heard (data commit step -1)."""
        n = len(self.ctrl)
        got = obs.received("trajectory")
        kx, _, seen = obs.known()
        out: list = [None] * n
        for j in np.flatnonzero(seen[r]):
            if j == r:
                continue
            b = None if got is None else got[r, j]
            if b is None:  # at rest where it was heard, as the hover plan every robot starts from
                c = np.repeat(kx[r, j][None], self.params.num_pol + 3, axis=0)
                b = Broadcast(lambda tau, c=c: (self._pos(c, 1.0, tau),), 0.0, float(self.params.num_pol), (c, 1.0, 0.0, -1))
            out[j] = b
        return out

    def _check_commit(self, r: int, k: int, heard: list | None = None) -> None:
        """Check the pending plan against the trajectories committed since it started (``heard``:
        robot ``r``'s picture now; then those that arrived since it started); commit it if it is
        clear, else keep the committed one (a fallback)."""
        p = self.params
        pend = self.pending[r]
        self.pending[r] = None
        if heard is None:
            others = [j for j in range(len(self.ctrl)) if j != r and self.commit_step[j] > pend["k_in"]]
        else:
            was = pend["heard"]
            others = [b for j, b in enumerate(heard) if b is not None and (
                was[j] is None or (b.data[3] >= 0 and b is not was[j]))]
        if others:
            ctrl, dtk = pend["ctrl"], pend["dtk"]
            dur = (ctrl.shape[0] - 3) * dtk
            t = k * p.dt + np.arange(0.0, dur + p.check_step, p.check_step)
            mine = self._pos(ctrl, dtk, t - k * p.dt)
            if heard is None:
                theirs = self.board.sample(np.array(others), t, self.dim)  # (J, T, D)
            else:
                theirs = sample_broadcasts(others, t, self.dim)
            if p.check_norm == "box":  # the optimisation's own measure: each pair's inflation
                gaps = self._gap(theirs - mine[None])  # (J, T)
                need = self._pair_inflation(gaps[:, 0])[:, None]
            else:
                gaps = np.linalg.norm(theirs - mine[None], axis=2)
                need = 2 * self.body + p.check_margin
            if np.any(gaps < need):
                self.stats["check_fails"] += 1
                self.stats["fallbacks"] += 1
                return
        self._commit(r, pend["ctrl"], pend["dtk"], k)
        self.stats["commits"] += 1

    # ------------------------------------------------------------------ planning

    def _start_replan(self, r: int, k: int, pos: np.ndarray, heard: list | None = None) -> None:
        p = self.params
        goal = self.goals[r]
        end = self.ctrl[r][-1]
        if np.linalg.norm(end - goal) <= p.goal_tol and np.allclose(self.ctrl[r][-3:], end):
            self.stats["idle"] += 1
            return  # arrived: its committed plan rests at its goal
        t0 = time.perf_counter()
        k_c = k + self.L
        qa, va, aa = self._state(r, k_c * p.dt)
        self.maps.observe(r, pos)
        result = self._plan(r, qa, va, aa, goal, k_c * p.dt, heard)
        self.stats["plans"] += 1
        self._plan_ms.append(1e3 * (time.perf_counter() - t0))
        if result is None:
            self.stats["fallbacks"] += 1
            return
        self.pending[r] = {"ctrl": result[0], "dtk": result[1], "k_in": k, "heard": heard}

    def _plan(self, r: int, q: np.ndarray, v: np.ndarray, a: np.ndarray, goal: np.ndarray, t_a: float,
              heard: list | None = None):
        """One MADER optimisation from state (q, v, a) at time ``t_a`` [s] against the others'
        committed trajectories (``heard``: robot ``r``'s picture of them; None: the ideal network's):
        (ctrl, dt_knot) or None."""
        p = self.params
        dim = self.dim
        path = self.maps.search(r, q, goal, p.max_expand)
        if path is None:
            self.stats["search_failures"] += 1
            path = np.vstack([q, goal])
        path = np.vstack([q, path[1:]]) if len(path) > 1 else np.vstack([q, goal])
        seg_len = np.linalg.norm(np.diff(path, axis=0), axis=1)
        cum = np.concatenate([[0.0], np.cumsum(seg_len)])
        horizon = min(p.Ra, cum[-1])
        # local goal G: Ra along the path (the goal if closer)
        G = _along(path, cum, horizon)
        factor = p.factor_alloc_close if np.linalg.norm(q - goal) < p.dist_factor_alloc_close else p.factor_alloc
        T = factor * float(min_time(G - q, p.v_max, p.a_max).max())
        T = max(T, p.num_pol * 4 * p.dt, float(np.abs(v).max()) / p.a_max)
        dtk = T / p.num_pol
        if p.knots == "clamped" and p.cap_span:
            # the start fixes V_1 = v + a dt / 2 (planning/clamped.py): a span so long that V_1 leaves
            # the per-axis bound makes every problem infeasible; shorten it to where V_1 = +-v_max
            if p.limits == "norm":  # the largest span with |v + a dt / 2| <= v_max (a quadratic in dt / 2)
                aa_, va_, vv_ = float(a @ a), float(v @ a), float(v @ v)
                disc = va_ * va_ - aa_ * (vv_ - p.v_max**2)
                cap = (2.0 * (-va_ + math.sqrt(max(disc, 0.0))) / aa_) if aa_ > 1e-24 and vv_ < p.v_max**2 else (
                    math.inf if aa_ <= 1e-24 else 0.0)
            else:
                room = np.where(a > 0, p.v_max - v, np.where(a < 0, p.v_max + v, np.inf))
                cap = float(np.min(2.0 * np.maximum(room, 0.0) / np.maximum(np.abs(a), 1e-12)))
            dtk = max(min(dtk, cap), 4 * p.dt)
        if p.knots == "clamped":
            start = clamped.boundary_points(q, v, a, dtk, p.num_pol)
        else:
            start = bspline.boundary_points(q, v, a, dtk)
        F = p.num_pol - 2
        frac = np.arange(1, F + 1) / F  # free interior points spread along the path, q_f at G
        free0 = np.array([_along(path, cum, horizon * f) for f in frac])
        free0[-1] = G
        seed = np.vstack([start, free0])
        lo, hi = seed.min(axis=0) - p.obstacle_margin, seed.max(axis=0) + p.obstacle_margin
        C0 = np.vstack([start, free0[:-1], np.repeat(free0[-1:], 3, axis=0)])
        sp = segment_points(C0)
        segs, sets, rad = self._obstacles(r, q, sp.min(axis=1) - p.obstacle_margin, sp.max(axis=1) + p.obstacle_margin,
                                     t_a, dtk, heard)
        # the problem in coordinates centred at A: plane offsets d stay small (SLSQP's conditioning)
        pb = S.Problem(start - q, G - q, dtk, p.num_pol, segs, pad(sets, dim, 4) - q, p.weight, p.v_max, p.a_max, rad,
                       p.limits == "norm")
        free0, C0 = free0 - q, C0 - q
        hulls = segment_points(C0)
        hulls = np.einsum("sij,sjd->sid", S.hull_matrices(p.num_pol, p.basis, p.knots), hulls)
        n0, d0, _ = seed_planes(hulls[segs], pb.verts) if len(segs) else (np.zeros((0, dim)), np.zeros(0), 0)
        self.stats["planes"] += len(segs)
        if self._force_fail:
            return None
        if p.algorithm == "ipopt":
            res = S.solve_ipopt(pb, free0, n0, d0, p.max_iter, p.eps_tol, p.basis, p.Ra + 4.0, p.plane_bound, p.knots,
                                precheck=p.precheck)
            self.stats["infeasible_starts"] += res.status == "infeasible-start"
        else:
            res = S.solve(pb, free0, n0, d0, p.max_eval, p.eps_tol, p.xtol_rel, p.ftol_rel, p.algorithm, p.Ra + 4.0,
                          p.plane_bound)
        self.stats["evals"] += res.evaluations
        if res.ctrl is None:
            return None
        ctrl = res.ctrl + q
        # obstacles the solution reached that were not in the problem: reject (the next replan sees them)
        lo2, hi2 = ctrl.min(axis=0), ctrl.max(axis=0)
        if np.any(lo2 < lo) or np.any(hi2 > hi):
            big_lo = np.minimum(lo, lo2 - p.obstacle_margin)
            big_hi = np.maximum(hi, hi2 + p.obstacle_margin)
            segs2, _, _ = self._obstacles(r, q, np.repeat(big_lo[None], p.num_pol, 0), np.repeat(big_hi[None], p.num_pol, 0),
                                       t_a, dtk, heard)
            if len(segs2) > len(segs):
                return None
        return ctrl, dtk

    def _gap(self, diff: np.ndarray) -> np.ndarray:
        """Gap [m] of displacements ``diff`` (..., D) in the clearance's measure: per axis for a box,
        Euclidean for a ball."""
        if self.params.clearance == "ball":
            return np.linalg.norm(diff, axis=-1)
        return np.abs(diff).max(axis=-1)

    def _pair_inflation(self, gap: np.ndarray) -> np.ndarray:
        """Inflation [m] of other agents' hulls whose gap to this robot is ``gap`` [m] now (in the
        clearance's measure): ``agent_inflation``. With ``crowd_shrink`` = s > 0, a pair already
        closer than that (the tracker lags its plan) keeps max(s x gap, 2 body radii +
        check_margin / 2); a pair between contact and that floor cannot plan apart from the other
        (a fallback: it waits for the tracker to catch up); and a pair already in contact gets no
        closer than s x gap (a spawn with overlapping bodies no plane could separate otherwise).
        Shrinking never plans a pair below the floor, so repeated replans cannot creep into contact."""
        p = self.params
        gap = np.asarray(gap, dtype=float)
        if p.crowd_shrink <= 0.0:
            return np.full(np.shape(gap), p.agent_inflation)
        contact = 2.0 * self.body
        floor = contact + 0.5 * p.check_margin
        keep = np.where(gap >= contact, np.maximum(p.crowd_shrink * gap, floor), p.crowd_shrink * gap)
        return np.minimum(p.agent_inflation, keep)

    def _obstacles(self, r: int, me: np.ndarray, lo: np.ndarray, hi: np.ndarray, t_a: float, dtk: float,
                   heard: list | None = None):
        """(segment of each plane, vertex set of each plane): for each segment s, the known obstacle
        polyhedra meeting its box [lo[s], hi[s]], and each other agent's committed trajectory hull
        (``heard``: as robot ``r`` received it; None: every one) over the segment's interval, grown
        by ``agent_inflation``, where it meets the box."""
        p = self.params
        ball = p.clearance == "ball"
        segs, sets, rad = [], [], []
        for s in range(p.num_pol):
            near = self.maps.known[r] & np.all(self.poly_lo <= hi[s], axis=1) & np.all(self.poly_hi >= lo[s], axis=1)
            for o in np.nonzero(near)[0]:
                segs.append(s)
                sets.append(self.polys[o])
                rad.append(p.inflation)
        if heard is None:
            plans = [(self.ctrl[j], self.dtk[j], self.t0[j]) for j in range(len(self.ctrl)) if j != r]
        else:
            plans = [b.data[:3] for b in heard if b is not None]
        for ctrl_j, dtk_j, t0_j in plans:
            infl = p.agent_inflation
            if p.crowd_shrink > 0.0:  # the pair's gap at point A (me: this robot's start there)
                there = self._pos(ctrl_j, dtk_j, np.array([t_a - t0_j]))[0]
                infl = float(self._pair_inflation(self._gap(there - me)))
            for s in range(p.num_pol):
                pts = interval_points(ctrl_j, dtk_j, t0_j, t_a + s * dtk, t_a + (s + 1) * dtk)
                if np.any(pts.min(axis=0) - infl > hi[s]) or np.any(pts.max(axis=0) + infl < lo[s]):
                    continue
                segs.append(s)
                sets.append(hull_vertices(_unique_rows(pts)) if ball else inflate_points(_unique_rows(pts), infl))
                rad.append(infl)
        return np.array(segs, dtype=np.int64), sets, (np.array(rad) if ball else None)


def _unique_rows(pts: np.ndarray) -> np.ndarray:
    keep = np.ones(len(pts), dtype=bool)
    keep[1:] = np.any(np.abs(np.diff(pts, axis=0)) > 1e-12, axis=1)
    return pts[keep]


def _along(path: np.ndarray, cum: np.ndarray, s: float) -> np.ndarray:
    """The point at arc length ``s`` along a polyline with cumulative lengths ``cum``."""
    if cum[-1] <= 0:
        return path[-1].copy()
    s = min(max(s, 0.0), cum[-1])
    i = int(np.clip(np.searchsorted(cum, s, side="right") - 1, 0, len(path) - 2))
    w = (s - cum[i]) / max(cum[i + 1] - cum[i], 1e-12)
    return path[i] + w * (path[i + 1] - path[i])
