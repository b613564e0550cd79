"""``lsc``: online distributed trajectory planning with linear safe corridors (Park, Kim, Jang and
Kim, "Online Distributed Trajectory Planning for Quadrotor Swarm with Feasibility Guarantee using
Linear Safe Corridor", IEEE RA-L 2022).

Every robot replans every segment time ``h`` (0.2 s), all at once from the same snapshot (the
paper's synchronous replanning). A replan of robot i at time t:

1. its previous plan, shifted to start at t (the segments not yet flown, then a segment resting
   at its end) is the *initial trajectory*; the new plan starts from its state at t;
2. goal planning (the paper's priority-based deadlock handling): agents nearer their goals have
   priority; a grid search on the robot's own map to its goal avoids the higher-priority agents,
   and the current goal is the farthest point of that path in line of sight from the initial
   trajectory's end; a robot closer than ``priority_dist`` to a higher-priority agent backs away;
3. safe flight corridor: for each segment, a box holding the initial trajectory's segment grown
   face by face through free cells of the robot's map (corridors.py);
4. linear safe corridor: for each other agent j and segment m, a plane between both agents'
   initial trajectories (solver.lsc_plane); both keep to their sides, so the new plans stay apart;
5. one QP (solver.py, OSQP): minimum jerk plus the squared error to the current goal, subject to
   the initial state, continuity, rest at the end of the horizon, the SFC and LSC, and the
   velocity and acceleration bounds. The initial trajectory satisfies every constraint, so the
   problem is feasible whenever the previous one was (the paper's guarantee); a solve that
   fails anyway (numerically) keeps the previous plan: a counted fallback.

The command is the shared tracking law (SPH eq. 13 without the swarm force) on the committed
plan, sampled at the control rate when it is committed.

On a network (docs/network.md) each committed plan travels as an immutable
:class:`~swarmnav.planning.messages.Broadcast` holding its control points and commit step
(``info["publish"]["trajectory"]``). Robot i's initial trajectory of robot j is the newest plan of
j it received, shifted to the present like its own (a late plan is still a plan in absolute time);
a robot heard but whose plan has not arrived rests where it was heard (every robot's first plan);
a robot never heard is not there. Each robot then draws its own LSC planes (step 4) against its
own picture, with the same formula the ideal path applies to the pair, and plans its goal (step 2)
among the robots it has heard. The paper assumes every plan arrives before the next replan; a late
one leaves the two robots on planes drawn from different pictures, and the guarantee is lost.
"""

from __future__ import annotations

import math
import time
from typing import Any

import numpy as np

from swarmnav.dynamics import SaturatedDoubleIntegrator
from swarmnav.methods.base import Observation, check_map_bytes, format_extent
from swarmnav.methods.lsc import corridors as C
from swarmnav.methods.lsc import solver as S
from swarmnav.methods.lsc.params import LscParams
from swarmnav.params import build
from swarmnav.planning.goals import goal_slots
from swarmnav.planning.maps import OccupancyMaps, bytes_per_cell, grid_cells, resample
from swarmnav.planning.messages import CommLog, TrajectoryBoard
from swarmnav.planning.plan_log import PlanLog, sample_rows
from swarmnav.planning.scanned import scanner
from swarmnav.planning.tracker import track
from swarmnav.world.scenario import Scenario
from swarmnav.planning.schedule import plan_time_summary

_MAX_MAP_BYTES = 2 * 1024**3


def shift(ctrl: np.ndarray, s: int) -> np.ndarray:
    """A plan (M, n + 1, D) advanced by ``s`` segments: segments s..M-1, then segments resting at
    its last control point (the previous plan from ``s`` segments later)."""
    M = ctrl.shape[0]
    s = int(min(max(s, 0), M))
    rest = np.broadcast_to(ctrl[-1, -1], (s,) + ctrl.shape[1:])
    return np.concatenate([ctrl[s:], rest], axis=0)


class LscMethod:
    """The LSC planner (see the module docstring)."""

    name = "lsc"
    dims = (2, 3)
    networked = True  # reads the others' plans only through what it received (module docstring)
    periodic = False  # a periodic box has no obstacles to plan around nor a goal: refused in one line
    map_sensor = True  # can build its maps from its own scans (sense.map = scans; docs/sensing.md)

    def __init__(self, **overrides: Any):
        p = build(LscParams, overrides, context="lsc")
        self.params = p
        self.dt = p.dt
        self.dynamics = SaturatedDoubleIntegrator(p.v_max, p.a_max)
        self._force_fail = False  # tests: every QP fails

    # ------------------------------------------------------------------ contract

    def reset(self, scenario: Scenario, positions: np.ndarray, velocities: np.ndarray,
              rng: np.random.Generator) -> None:
        p = self.params
        n, dim = scenario.n, scenario.dim
        self._map_need = grid_cells(scenario.bounds, p.grid_resolution) * bytes_per_cell(dim, n, False, True)
        check_map_bytes("lsc", f"a {format_extent(scenario.lower, scenario.upper)} world at "
                        f"{p.grid_resolution:g} m", self._map_need, _MAX_MAP_BYTES, "grid_resolution",
                        "use a coarser grid_resolution")
        self.dim = dim
        self.body = scenario.rules.body_radius
        self.radius = self.body + p.agent_margin  # r_i in the LSC
        infl = self.body + p.obstacle_margin
        # two thin bands just outside the inflation: the search's costly band (class 1) then holds
        # only what it marks, the higher-priority agents (planning/maps.py)
        self.maps = OccupancyMaps(scenario.solid_obstacles, scenario.bounds, n, p.grid_resolution, infl,
                                  p.sensing_range, margin=infl + 1e-3, wide=infl + 2e-3,
                                  wide_cost=p.priority_cost)
        self.blocked = len(self.maps.levels) + 1  # class of the cells within the inflation
        self.shape_xyz = np.array(list(reversed(self.maps.shape)) + [1] * (3 - dim), dtype=np.int64)
        self.every = max(1, int(round(p.segment_time / p.dt)))  # replanning period [steps]
        self.h = self.every * p.dt  # segment time [s], a whole number of control steps
        self.M, self.n = p.segments, p.degree
        x = np.asarray(positions, dtype=float)
        self.goals = goal_slots(scenario.goal_array, x, p.goal_disc)
        self.comm = CommLog()
        self.board = TrajectoryBoard(n, self.comm)
        self.ctrl = np.repeat(x[:, None, None, :], self.M * (self.n + 1), axis=1).reshape(n, self.M, self.n + 1, dim)
        # each plan's SFC boxes (sfc=shifted): at first a point box where each robot stands
        self.boxes = np.repeat(x[:, None, None, :], self.M * 2, axis=1).reshape(n, self.M, 2, dim)
        self._new_boxes: dict[int, np.ndarray] = {}
        self.commit_step = np.zeros(n, dtype=np.int64)
        length = self.M * self.every + 1
        self.ref_q = np.repeat(x[:, None, :], length, axis=1)
        self.ref_v = np.zeros((n, length, dim))
        self.ref_a = np.zeros((n, length, dim))
        self.ref_k0 = np.zeros(n, dtype=np.int64)
        self._log_plans = PlanLog(dim)
        for r in range(n):  # at rest where it stands
            self._commit(r, self.ctrl[r], 0)
        self.stats = {"plans": 0, "commits": 0, "fallbacks": 0, "iterations": 0, "planes": 0,
                      "search_failures": 0, "idle": 0, "backoffs": 0}
        self._plan_ms: list[float] = []
        self._steps = 0
        self._geom = scenario.geometry
        self._scanner = None  # maps from scans (sense.map = scans): made at the first step

    def act(self, obs: Observation, rng: np.random.Generator) -> tuple[np.ndarray, dict]:
        p = self.params
        k = obs.step
        x, v = obs.positions, obs.velocities
        if self._steps == 0 and obs.sensing is not None:
            self._scanner = scanner(obs, self._geom, self.maps, p.sensing_range, p.dt, budget=(
                "lsc", self._map_need, _MAX_MAP_BYTES, "grid_resolution"))
        if self._scanner is not None:  # each robot's map from its own scans
            self._scanner.sweep(obs, x)
        if k % self.every == 0:
            self._replan(k, x, obs)
        self._steps += 1
        idx = np.clip(k - self.ref_k0, 0, self.ref_q.shape[1] - 1)
        rr = np.arange(x.shape[0])
        a = track(x, v, self.ref_q[rr, idx], self.ref_v[rr, idx], self.ref_a[rr, idx], p.k_p, p.k_v)
        return a, {"publish": {"trajectory": tuple(self.board.records)}}

    def summary(self) -> dict[str, float]:
        s = self.stats
        return {
            "lsc_plans": float(s["plans"]),
            "lsc_commits": float(s["commits"]),
            "lsc_fallbacks": float(s["fallbacks"]),
            "lsc_search_failures": float(s["search_failures"]),
            "lsc_backoffs": float(s["backoffs"]),
            "lsc_iterations_mean": s["iterations"] / max(s["plans"], 1),
            "lsc_planes_mean": s["planes"] / max(s["plans"], 1),
            **self.comm.summary(self._steps * self.params.dt),
            **(self._scanner.summary() if self._scanner is not None else {}),
        }

    def plans(self) -> dict[str, np.ndarray]:
        """Every committed plan (the initial hover plans too), sampled every 0.1 s
        (:class:`~swarmnav.planning.plan_log.PlanLog`; docs/methods/contract.md)."""
        return self._log_plans.arrays()

    def timings(self) -> dict[str, float]:
        """Wall-clock planning time per robot per replan [ms] (not reproducible: not metrics)."""
        return plan_time_summary(self._plan_ms)

    # ------------------------------------------------------------------ commits

    def _commit(self, r: int, ctrl: np.ndarray, step: int) -> None:
        """Robot ``r`` commits ``ctrl`` starting at ``step``: broadcast it and sample its reference."""
        p = self.params
        self.ctrl[r], self.commit_step[r] = ctrl, step
        dur = self.M * self.h
        sent = ctrl.copy()
        sent.flags.writeable = False  # it travels with the broadcast: never changed after it
        self.board.publish(r, lambda tau, c=sent: self._sample(c, tau), step * p.dt, dur, ctrl.shape[0] * ctrl.shape[1],
                           data=(sent, step))
        tau = p.dt * np.arange(self.ref_q.shape[1])
        self.ref_q[r], self.ref_v[r], self.ref_a[r] = self._sample(ctrl, tau)
        self.ref_k0[r] = step
        rows = sample_rows(len(tau), p.dt)
        self._log_plans.add(step, r, (step + rows) * p.dt, self.ref_q[r][rows])

    def _sample(self, ctrl: np.ndarray, tau: np.ndarray):
        return tuple(S.evaluate(ctrl, self.h, tau, order) for order in range(3))

    # ------------------------------------------------------------------ planning

    def _pictures(self, k: int, prev: np.ndarray, obs: Observation) -> tuple[np.ndarray, np.ndarray]:
        """Each robot's initial trajectories of every robot, (N, N, M, n + 1, D), and which it
        has heard, (N, N) bool (module docstring): row r's own entry is its own plan."""
        N = prev.shape[0]
        got = obs.received("trajectory")
        kx, _, seen = obs.known()
        pic = np.repeat(prev[None], N, axis=0)  # unheard entries keep a filler, masked out
        present = seen.copy()
        for r in range(N):
            for j in range(N):
                if j == r or not seen[r, j]:
                    continue
                b = None if got is None else got[r, j]
                if b is None:  # heard, but no plan yet: at rest where it was heard
                    pic[r, j] = kx[r, j]
                else:
                    ctrl, step = b.data
                    pic[r, j] = shift(ctrl, (k - step) // self.every)
        np.fill_diagonal(present, True)
        return pic, present

    def _replan(self, k: int, x: np.ndarray, obs: Observation | None = None) -> None:
        """One synchronous replan of every robot from the snapshot of step ``k``; the new plans
        are committed together afterwards. Under a network (``obs.view``) each robot plans against
        its own picture of the others (:meth:`_pictures`)."""
        p = self.params
        N = x.shape[0]
        prev = np.stack([shift(self.ctrl[r], (k - self.commit_step[r]) // self.every) for r in range(N)])
        if obs is None or obs.view is None:
            pics, present = None, None
            planes = self._planes(prev)
        else:
            pics, present = self._pictures(k, prev, obs)
        new: list[tuple[int, np.ndarray]] = []
        for r in range(N):
            if np.linalg.norm(prev[r] - self.goals[r], axis=-1).max() <= p.goal_threshold:
                self.stats["idle"] += 1
                continue  # arrived: its whole plan lies within goal_threshold of its goal
            t0 = time.perf_counter()
            self.maps.observe(r, x[r])
            flown = (k - self.commit_step[r]) // self.every
            if pics is None:
                ctrl = self._plan(r, prev, planes[r], flown)
            else:
                ctrl = self._plan(r, pics[r], self._planes_of(r, pics[r], present[r]), flown, present[r])
            self.stats["plans"] += 1
            self._plan_ms.append(1e3 * (time.perf_counter() - t0))
            if ctrl is None:
                self.stats["fallbacks"] += 1
            else:
                new.append((r, ctrl))
        for r, ctrl in new:
            self._commit(r, ctrl, k)
            if r in self._new_boxes:
                self.boxes[r] = self._new_boxes[r]
            self.stats["commits"] += 1
        self._new_boxes.clear()

    def _planes(self, prev: np.ndarray) -> list[list[tuple[int, np.ndarray, np.ndarray]]]:
        """Per robot, its LSC planes (segment, normal, rhs per control point) against every agent
        whose plan could come near: a pair whose initial trajectories' boxes are apart on some
        axis by more than both can travel over the horizon (v_max per axis) plus both radii cannot
        meet, and gets none."""
        N = prev.shape[0]
        out: list[list] = [[] for _ in range(N)]
        box = self._boxes(prev)
        for i in range(N):
            for j in range(i + 1, N):
                for m, nrm, rhs_i, rhs_j in self._pair_planes(prev, i, j, box):
                    out[i].append((m, nrm, rhs_i))
                    out[j].append((m, -nrm, rhs_j))
        return out

    def _boxes(self, prev: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
        """Each robot's bounding box of its initial trajectory (lower, upper: (N, D) [m]) and the
        farthest two boxes can be apart and their robots still meet over the horizon [m]."""
        N, M = prev.shape[0], prev.shape[1]
        lo = prev.reshape(N, -1, self.dim).min(axis=1)
        hi = prev.reshape(N, -1, self.dim).max(axis=1)
        return lo, hi, 2.0 * self.params.v_max * M * self.h + 2.0 * self.radius

    def _pair_planes(self, prev: np.ndarray, i: int, j: int, box) -> list[tuple[int, np.ndarray, np.ndarray, np.ndarray]]:
        """The LSC planes of pair i < j per segment m: ``(m, nrm, rhs_i, rhs_j)``, robot i keeping
        ``nrm . c <= rhs_i`` and robot j ``-nrm . c <= rhs_j``; none for a pair out of reach."""
        lo, hi, reach = box
        gap = np.maximum(lo[j] - hi[i], lo[i] - hi[j]).max()
        if gap > reach:
            return []
        fallback = prev[j, 0, 0] - prev[i, 0, 0]
        if np.linalg.norm(fallback) < 1e-9:
            fallback = np.eye(self.dim)[0]
        out = []
        for m in range(prev.shape[1]):
            nrm, rhs_i, _ = S.lsc_plane(prev[i, m], prev[j, m], self.radius, fallback)
            mid = 0.5 * (prev[i, m] + prev[j, m]) @ nrm  # (n + 1,) the plane through the midpoints
            out.append((m, nrm, rhs_i, -mid - (mid - rhs_i)))  # j: -nrm . c <= -nrm . mid - d, d = mid - rhs_i
        return out

    def _planes_of(self, r: int, prev: np.ndarray, present: np.ndarray) -> list[tuple[int, np.ndarray, np.ndarray]]:
        """Robot ``r``'s LSC planes against the robots it has heard (``present``), from its own
        picture ``prev`` (N, M, n + 1, D): :meth:`_planes`' row r, each pair computed in the same
        order (lower index first) and by the same formula."""
        out: list = []
        box = self._boxes(prev)
        for o in np.flatnonzero(present):
            if o == r:
                continue
            i, j = (r, int(o)) if r < o else (int(o), r)
            for m, nrm, rhs_i, rhs_j in self._pair_planes(prev, i, j, box):
                out.append((m, nrm, rhs_i) if r == i else (m, -nrm, rhs_j))
        return out

    def _plan(self, r: int, prev: np.ndarray, planes, flown: int, present: np.ndarray | None = None) -> np.ndarray | None:
        """One robot's replan: goal planning, SFC, the QP; the new control points or None.
        ``prev``: the initial trajectories of every robot as robot ``r`` holds them; ``present``:
        which it has heard (None: all)."""
        p = self.params
        init = prev[r]
        q0 = init[0, 0]
        tau0 = np.zeros(1)
        v0 = S.evaluate(init, self.h, tau0, 1)[0]
        a0 = S.evaluate(init, self.h, tau0, 2)[0]
        goal = self._current_goal(r, prev, present)
        if p.sfc == "shifted":
            boxes = self._sfc_shifted(r, init, goal, flown)
            self._new_boxes[r] = boxes
        else:
            boxes = self._sfc(r, init)
        self.stats["planes"] += len(planes)
        if planes:
            seg = np.array([m for m, _, _ in planes], dtype=np.int64)
            nrm = np.array([n_ for _, n_, _ in planes])
            rhs = np.array([b for _, _, b in planes])
        else:
            seg, nrm, rhs = np.zeros(0, np.int64), np.zeros((0, self.dim)), np.zeros((0, self.n + 1))
        if self._force_fail:
            return None
        # the problem centred at the start: small offsets keep the solver's tolerances meaningful in metres
        pbc = S.Problem(self.M, self.n, self.h, np.zeros(self.dim), v0, a0, goal - q0, boxes - q0, seg, nrm,
                        rhs - (nrm @ q0)[:, None], p.v_max, p.a_max, p.limits, p.w_goal, p.w_jerk, p.phi,
                        p.continuity)
        res = S.solve(pbc, max_iter=p.max_iter, tol=p.qp_tol)
        self.stats["iterations"] += res.iterations
        if res.ctrl is None:
            return None
        return res.ctrl + q0

    def _current_goal(self, r: int, prev: np.ndarray, present: np.ndarray | None = None) -> np.ndarray:
        """The paper's priority-based goal planning (module docstring, step 2), among the robots
        robot ``r`` has heard (``present``; None: all)."""
        p = self.params
        q = prev[:, 0, 0]
        goal = self.goals[r]
        d_me = float(np.linalg.norm(q[r] - goal))
        if p.priority:
            d_goal = np.linalg.norm(q - self.goals, axis=1)
            motion = prev[:, -1, -1] - prev[:, 0, 0]
            away = np.einsum("ij,ij->i", motion, q - q[r]) > 0  # moving away from this robot
            high = (d_goal > p.goal_threshold) & ~away & ((d_me < p.goal_threshold) | (d_goal < d_me))
            high[r] = False
            if present is not None:
                high &= present
            idx = np.flatnonzero(high)
        else:
            idx = np.zeros(0, dtype=np.int64)
        if len(idx):
            dist = np.linalg.norm(q[idx] - q[r], axis=1)
            j = int(idx[np.argmin(dist)])
            if dist.min() < p.priority_dist:  # too close to a higher-priority agent: back away
                self.stats["backoffs"] += 1
                away_dir = q[r] - q[j]
                return q[r] + away_dir / max(float(np.linalg.norm(away_dir)), 1e-9) * (p.priority_dist + 0.1)
        path = None
        if len(idx):
            path = self.maps.search(r, q[r], goal, p.max_expand, others=q[idx], others_radius=2.0 * self.radius)
        if path is None:
            path = self.maps.search(r, q[r], goal, p.max_expand)
        if path is None:
            self.stats["search_failures"] += 1
            return goal
        path = resample(path, p.grid_resolution)
        occ = C.as3(self.maps.grids[r])
        i = C.last_visible(occ, self.maps.origin, self.maps.resolution, prev[r, -1, -1].copy(),
                           np.ascontiguousarray(path), self.blocked)
        return path[i] if i >= 0 else path[min(1, len(path) - 1)]

    def _sfc(self, r: int, init: np.ndarray) -> np.ndarray:
        """(M, 2, D) boxes: each segment's initial control points' bounding box grown through the
        free cells of robot ``r``'s map, at most ``sfc_growth`` per face."""
        p = self.params
        res, origin = self.maps.resolution, self.maps.origin
        occ = C.as3(self.maps.grids[r])
        grow = int(math.floor(p.sfc_growth / res))
        dims = self.dim
        boxes = np.empty((self.M, 2, self.dim))
        for m in range(self.M):
            lo_m, hi_m = init[m].min(axis=0), init[m].max(axis=0)
            lo_i = C.to_index(lo_m, origin, res, self.shape_xyz)
            hi_i = C.to_index(hi_m, origin, res, self.shape_xyz)
            lim_lo = np.maximum(lo_i - grow, 0)
            lim_hi = np.minimum(hi_i + grow, self.shape_xyz - 1)
            glo, ghi = C.grow_box(occ, lo_i, hi_i, lim_lo, lim_hi, dims, self.blocked)
            boxes[m, 0] = np.minimum(lo_m, origin + res * glo[:dims])
            boxes[m, 1] = np.maximum(hi_m, origin + res * ghi[:dims])
        return boxes

    def _sfc_shifted(self, r: int, init: np.ndarray, goal: np.ndarray, flown: int) -> np.ndarray:
        """(M, 2, D) boxes, the authors' scheme: the committed plan's boxes shifted by the segments
        flown (each still holds its segment of the initial trajectory), and a new last box grown
        from the initial trajectory's end, first through the faces towards the current goal (up to
        the goal), then every face in turn, at most ``sfc_growth`` per face."""
        p = self.params
        res, origin = self.maps.resolution, self.maps.origin
        occ = C.as3(self.maps.grids[r])
        old = self.boxes[r]
        s = int(min(max(flown, 0), self.M))
        boxes = np.concatenate([old[s:], np.repeat(old[-1:], s, axis=0)], axis=0)
        end = init[-1, -1]
        seed = C.to_index(end, origin, res, self.shape_xyz)
        gi = C.to_index(goal, origin, res, self.shape_xyz)
        grow = int(math.floor(p.sfc_growth / res))
        lim_lo = np.maximum(seed - grow, 0)
        lim_hi = np.minimum(seed + grow, self.shape_xyz - 1)
        # towards the goal only: the other faces frozen at the seed, the goal faces up to the goal
        to_lo = np.where(gi < seed, np.maximum(gi, lim_lo), seed)
        to_hi = np.where(gi > seed, np.minimum(gi, lim_hi), seed)
        glo, ghi = C.grow_box(occ, seed, seed, to_lo, to_hi, self.dim, self.blocked)
        glo, ghi = C.grow_box(occ, glo, ghi, lim_lo, lim_hi, self.dim, self.blocked)
        boxes[-1, 0] = np.minimum(end, origin + res * glo[:self.dim])
        boxes[-1, 1] = np.maximum(end, origin + res * ghi[:self.dim])
        return boxes
