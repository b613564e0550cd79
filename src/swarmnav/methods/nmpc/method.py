"""``nmpc``: the predictive swarm of Soria, Schiano & Floreano (Nature Machine Intelligence 2021),
distributed: every control step (``control_dt``) each robot solves its own nonlinear MPC
(solver.py) from its state, with

1. its migration direction ``u_ref`` (towards its goal slot) and speed ``v_ref``;
2. the predicted trajectories its neighbours broadcast at the previous control step (shifted by
   one step to the present clock): the ``max_neig`` closest within ``sensing_range`` in the
   separation / cohesion terms, the ``col_neig`` closest as hard distance constraints;
3. the ``max_obs`` nearest obstacles within ``sensing_range``: discs, cylinders and balls as
   themselves (the paper's cylinders), every other obstacle (boxes, polygons, walls) as the
   half-space beyond the tangent plane at its nearest point.

The robot applies the first acceleration for one control step (zero-order hold) and broadcasts
its predicted positions (one trajectory message of H + 1 points, counted in the CommLog). A failed
solve is a counted fallback (``nmpc_fallbacks``): the previous prediction's next acceleration, or a
brake once that is used up.

On a network (docs/network.md) the predictions travel as ``info["publish"]``: ``prediction`` (N, H,
D) [m] and the control step each was made at, ``prediction_step``, in the messages that carry the
states. Robot i picks its neighbours by the states it received (item 2), guards their reach from
them, and reads each neighbour's newest prediction received at the present control steps: a
prediction m control steps old is shifted by m (the paper's shift by one is m = 1), beyond its end
extended at its last velocity; a neighbour heard before any prediction arrived moves at constant
velocity from its received state, from when that state was sent. A robot never heard is not there.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from swarmnav.dynamics import SaturatedDoubleIntegrator
from swarmnav.methods.base import Observation
from swarmnav.methods.nmpc import solver as S
from swarmnav.methods.nmpc.params import NmpcParams
from swarmnav.params import build
from swarmnav.planning.goals import goal_slots
from swarmnav.planning.messages import CommLog, trajectory_bytes
from swarmnav.planning.plan_log import PlanLog
from swarmnav.sensing.geometry import nearest_obstacle
from swarmnav.world.obstacles import Circle, Cylinder, Geometry, Sphere
from swarmnav.world.scenario import Scenario
from swarmnav.planning.schedule import plan_time_summary


def _clip_norm(a: np.ndarray, bound: float) -> np.ndarray:
    n = np.linalg.norm(a, axis=-1, keepdims=True)
    return np.where(n > bound, a * (bound / np.maximum(n, 1e-300)), a)


#: [m] the least predicted gap beyond contact the crowd rule keeps (ours)
CONTACT_GAP = 0.005


def crowded(gap: float, clearance: float, floor: float, shrink: float, contact: float) -> float:
    """The clearance [m] kept from a neighbour or obstacle now ``gap`` away (our crowd rule,
    ``crowd_shrink``, after MADER's): ``clearance`` if the gap holds it; else max(shrink x gap,
    ``floor``), or below the floor max(shrink x gap, contact + CONTACT_GAP): a start or a squeeze
    inside the clearance stays feasible, and the kept clearance never ratchets into contact.
    ``shrink`` = 0: off."""
    if shrink <= 0 or gap >= clearance:
        return clearance
    if gap >= floor:
        return max(shrink * gap, floor)
    return max(shrink * gap, contact + CONTACT_GAP)


def _directions(D: int, n: int = 48) -> np.ndarray:
    """(n, D) unit vectors spread evenly (a circle; a Fibonacci sphere in 3-D), fixed: deterministic."""
    if D == 2:
        a = 2 * np.pi * np.arange(n) / n
        return np.stack([np.cos(a), np.sin(a)], axis=1)
    k = np.arange(n) + 0.5
    z = 1 - 2 * k / n
    r = np.sqrt(1 - z * z)
    a = np.pi * (1 + 5**0.5) * k
    return np.stack([r * np.cos(a), r * np.sin(a), z], axis=1)


def guarded_fallback(pb: S.Problem, u_brake: np.ndarray) -> np.ndarray:
    """The reach guard on a failed solve's acceleration (ours): among the brake ``u_brake`` and a
    fixed grid of accelerations within a_max (48 directions x 3 magnitudes, and 0), the one nearest
    the brake whose first step keeps every obstacle slot and every reach guard of ``pb``. If none
    keeps them all: among those that keep the obstacles (a sure contact) the one with the largest
    least guard margin (a neighbour's worst case); if none keeps the obstacles, the one with the
    largest least margin of all [m]. Held for one control step like a solved plan's."""
    D = pb.p0.shape[0]
    dirs = _directions(D)
    cand = np.vstack([u_brake[None], np.zeros((1, D)),
                      *(f * pb.a_max * dirs for f in (1.0, 2 / 3, 1 / 3))])
    p1 = pb.p0 + pb.h * pb.v0 + 0.5 * pb.h**2 * cand  # (C, D) the first predicted position
    rc, rr = pb.reach()
    guarded = rr > 0
    guard = np.min(np.linalg.norm(p1[:, None, :] - rc[None, guarded], axis=2) - rr[None, guarded], axis=1,
                   initial=np.inf)
    r = p1[:, None, :] - pb.obs_c[None]  # (C, M, D)
    disc = np.linalg.norm(pb.obs_s[None] * r, axis=2) - pb.obs_rho[None]
    half = np.einsum("cmd,md->cm", r, pb.obs_n) - pb.obs_rho[None]
    obst = np.min(np.where(pb.obs_alpha[None] == 1.0, disc, half), axis=1, initial=np.inf)
    ok = (guard >= 0) & (obst >= 0)
    if ok.any():
        dist = np.where(ok, np.linalg.norm(cand - u_brake, axis=1), np.inf)
        return cand[int(np.argmin(dist))]
    clear = obst >= 0
    if clear.any():
        return cand[int(np.argmax(np.where(clear, guard, -np.inf)))]
    return cand[int(np.argmax(np.minimum(guard, obst)))]


class ObstacleSlots:
    """The obstacles of a world as each robot's MPC sees them (module docstring, item 3)."""

    def __init__(self, obstacles, dim: int):
        self.dim = dim
        self.kind = []  # per obstacle: (alpha, centre, mask, radius) for a round one, None otherwise
        self.geoms = []
        lo, hi = [], []
        for o in obstacles:
            g = Geometry.from_obstacles([o], dim=dim)
            self.geoms.append(g)
            lo.append(g.bbox_lo[0])
            hi.append(g.bbox_hi[0])
            if isinstance(o, Circle) and dim == 2:
                self.kind.append((np.array(o.center, float), np.ones(2), float(o.radius)))
            elif isinstance(o, Cylinder):
                self.kind.append((np.array([*o.center, 0.0]), np.array([1.0, 1.0, 0.0]), float(o.radius)))
            elif isinstance(o, Sphere):
                self.kind.append((np.array(o.center, float), np.ones(3), float(o.radius)))
            else:
                self.kind.append(None)
        self.lo = np.array(lo, float).reshape(-1, dim)
        self.hi = np.array(hi, float).reshape(-1, dim)

    def slots(self, p: np.ndarray, M: int, sensing_range: float, clearance: float, floor: float, shrink: float,
              contact: float):
        """(c, s, n, rho, alpha), each (M, ...), for a robot at ``p``: the M obstacles nearest by
        bounding box within ``sensing_range``, each kept ``clearance`` away (or less, by
        :func:`crowded`); empty slots are always met."""
        D = self.dim
        c, s, n = np.zeros((M, D)), np.zeros((M, D)), np.zeros((M, D))
        rho, alpha = np.full(M, -1.0), np.zeros(M)
        if len(self.lo):
            gap = np.linalg.norm(np.maximum(0.0, np.maximum(self.lo - p, p - self.hi)), axis=1)
            order = np.argsort(gap, kind="stable")
            order = order[gap[order] <= sensing_range][:M]
            for m, o in enumerate(order):
                kd = self.kind[o]
                if kd is not None:  # the paper's cylinder: |s o (p - c)| >= r + clearance
                    centre, mask, r = kd
                    now = float(np.linalg.norm(mask * (p - centre)))
                    need = r + crowded(now - r, clearance, floor, shrink, contact)
                    c[m], s[m], rho[m], alpha[m] = centre, mask, need, 1.0
                else:  # tangent half-space at the nearest point
                    d, u = nearest_obstacle(self.geoms[o], p[None])
                    d, u = float(d[0]), u[0]
                    q = p + abs(d) * u  # u points to the boundary point (outward from inside)
                    normal = -u if d > 0 else u  # inside: the free side is beyond q, so the slot is unmet
                    c[m], n[m], rho[m] = q, normal, crowded(d, clearance, floor, shrink, contact)
        return c, s, n, rho, alpha


class NmpcMethod:
    """The distributed NMPC swarm (see the module docstring)."""

    name = "nmpc"
    dims = (2, 3)
    networked = True  # reads the others only through what it received (module docstring)
    periodic = False  # obstacles and a goal to migrate to: a periodic box is refused in one line

    def __init__(self, **overrides: Any):
        p = build(NmpcParams, overrides, context="nmpc")
        self.params = p
        self.dt = p.dt
        self.dynamics = SaturatedDoubleIntegrator(p.v_max, p.a_max)
        self.H = p.steps()
        self.every = int(round(p.control_dt / p.dt))
        self.weights = S.Weights(p.w_sep, p.w_coh, p.w_dir, p.w_nav, p.w_u, p.d_ref, p.eps_v,
                                 p.direction == "signed")
        self.options = S.Options(p.max_iter, p.tol, warm_dual=p.warm_start == "primal-dual")
        n_sub = self.every
        #: [m] the reach guard's least distance to a neighbour's free motion one control step on: contact,
        #: CONTACT_GAP, the neighbour's reach in the plant (|a| <= a_max held for n substeps of the
        #: semi-implicit Euler plant: a_max h^2 (n+1) / 2n) and this robot's plant-vs-model offset (a_max h^2 / 2n)
        self.reach_extra = CONTACT_GAP + p.a_max * p.control_dt**2 * (n_sub + 2) / (2 * n_sub)

    # ------------------------------------------------------------------ contract

    def reset(self, scenario: Scenario, positions: np.ndarray, velocities: np.ndarray,
              rng: np.random.Generator) -> None:
        p = self.params
        x = np.asarray(positions, dtype=float)
        n, dim = x.shape
        self.dim = dim
        self.body = scenario.rules.body_radius
        self.reach_radius = 2 * self.body + self.reach_extra
        self.obstacles = ObstacleSlots(scenario.solid_obstacles, dim)
        self.goals = goal_slots(scenario.goal_array, x, p.goal_disc)
        self.comm = CommLog()
        self.log = PlanLog(dim)
        H = self.H
        self.U = np.zeros((n, H, dim))  # each robot's last accepted plan (accelerations)
        self.last: list[S.Result | None] = [None] * n  # each robot's last accepted solve (its multipliers)
        self.pred = None  # (n, H, dim): predicted positions broadcast at the last control step
        self.age = np.zeros(n, dtype=np.int64)  # control steps since the plan was solved
        self.u_hold = np.zeros((n, dim))
        self.stats = {"solves": 0, "fallbacks": 0, "brakes": 0, "iterations": 0}
        self._solve_ms: list[float] = []
        self._steps = 0

    def act(self, obs: Observation, rng: np.random.Generator) -> tuple[np.ndarray, dict]:
        if obs.step % self.every == 0:
            self._control(obs.step, obs.positions, obs.velocities, obs)
            info = {"publish": {"prediction": self.pred,
                                "prediction_step": np.full(len(self.pred), float(obs.step))}}
        else:
            info = {}
        self._steps += 1
        return self.u_hold.copy(), info

    def summary(self) -> dict[str, float]:
        s = self.stats
        return {
            "nmpc_solves": float(s["solves"]),
            "nmpc_fallbacks": float(s["fallbacks"]),
            "nmpc_brakes": float(s["brakes"]),
            "nmpc_iterations_mean": s["iterations"] / max(s["solves"], 1),
            **self.comm.summary(self._steps * self.params.dt),
        }

    def plans(self) -> dict[str, np.ndarray]:
        """Every robot's predicted trajectory at every control step (its present position first)."""
        return self.log.arrays()

    def timings(self) -> dict[str, float]:
        """Wall-clock solve time per robot per control step [ms] (not reproducible: not metrics)."""
        return plan_time_summary(self._solve_ms)

    # ------------------------------------------------------------------ control

    def neighbour_predictions(self, x: np.ndarray, v: np.ndarray) -> np.ndarray:
        """(n, H, dim) every robot's predicted positions at control steps 1..H from now, as the
        others hold them: last step's broadcast shifted by one step (its last point extended at its
        last velocity); before any broadcast, constant velocity from the present state."""
        h, H = self.params.control_dt, self.H
        if self.pred is None:
            return x[:, None, :] + h * np.arange(1, H + 1)[None, :, None] * v[:, None, :]
        last = self.pred[:, -1]
        prev = self.pred[:, -2] if H > 1 else x
        return np.concatenate([self.pred[:, 1:], (2 * last - prev)[:, None]], axis=1)

    def received_predictions(self, step: int, obs: Observation) -> np.ndarray:
        """(n, n, H, dim): robot i's picture of every robot's positions at control steps 1..H
        from ``step`` (module docstring), from what it received; NaN for a robot it never heard."""
        h, H = self.params.control_dt, self.H
        kx, kv, heard = obs.known()
        n, D = kx.shape[1], kx.shape[2]
        out = np.full((n, n, H, D), np.nan)
        pred, made = obs.received("prediction"), obs.received("prediction_step")
        c = np.arange(1, H + 1)
        for i in range(n):
            for j in np.flatnonzero(heard[i]):
                if made is None or not np.isfinite(made[i, j]):  # no prediction yet: constant velocity
                    age = float(obs.view.age[i, j])
                    out[i, j] = kx[i, j][None, :] + (age + h * c)[:, None] * kv[i, j][None, :]
                    continue
                P = pred[i, j]
                m = int(round((step - made[i, j]) / self.every))  # control steps since it was made
                # its points at control steps m + 1 .. m + H of its own; beyond H at its last velocity
                last = P[-1]
                prev = P[-2] if H > 1 else kx[i, j]
                keep = P[m:]
                e = np.arange(1, m + 1 - max(0, m - H))[:, None] + max(0, m - H)
                out[i, j] = np.concatenate([keep, (e + 1) * last - e * prev], axis=0)[:H]
        return out

    def problem(self, i: int, x: np.ndarray, v: np.ndarray, q_all: np.ndarray,
                heard: np.ndarray | None = None) -> S.Problem:
        """Robot ``i``'s MPC problem at the present state ``x``, ``v`` (n, dim) with the others'
        predictions ``q_all`` (n, H, dim); ``heard``: the robots it has heard (None: all), the
        others are not there."""
        p = self.params
        n, D = x.shape
        K, M = p.col_neig, p.max_obs
        H = self.H
        xi = x[i]
        to_goal = self.goals[i] - xi
        dist = float(np.linalg.norm(to_goal))
        u_ref = to_goal / dist if dist > 1e-9 else np.zeros(D)
        v_ref = p.v_ref * min(1.0, dist / p.slow_radius)
        d = np.linalg.norm(x - xi, axis=1)
        d[i] = np.inf
        if heard is not None:
            d[~heard] = np.inf
        order = np.argsort(d, kind="stable")
        order = order[d[order] <= p.sensing_range][:K]
        q = np.repeat(xi[None, None, :], K, axis=0) + np.zeros((K, H, D))
        c_cost = np.zeros(K)
        rho = np.zeros(K)
        rc, rr = np.zeros((K, D)), np.zeros(K)
        need, floor = 2 * self.body + p.col_margin, 2 * self.body + p.col_margin / 2
        for s, j in enumerate(order):
            q[s] = q_all[j]
            rho[s] = crowded(float(d[j]), need, floor, p.crowd_shrink, 2 * self.body)
            if p.reach_guard == "on":
                rc[s], rr[s] = x[j] + p.control_dt * v[j], self.reach_radius
        ncost = min(p.max_neig, len(order))
        c_cost[:ncost] = 1.0 / max(ncost, 1)
        oc, os_, on, orho, oal = self.obstacles.slots(xi, M, p.sensing_range, self.body + p.obs_margin,
                                                        self.body + p.obs_margin / 2, p.crowd_shrink, self.body)
        return S.Problem(xi.copy(), v[i].copy(), p.control_dt, p.v_max, p.a_max, u_ref, v_ref, q, c_cost, rho,
                         oc, os_, on, orho, oal, rc, rr)

    def _control(self, step: int, x: np.ndarray, v: np.ndarray, obs: Observation | None = None) -> None:
        p = self.params
        n, D = x.shape
        H, h = self.H, p.control_dt
        networked = obs is not None and obs.view is not None
        if networked:
            kx, kv, heard = obs.known()
            q_pic = self.received_predictions(step, obs)
        else:
            q_all = self.neighbour_predictions(x, v)
        new_pred = np.empty((n, H, D))
        for i in range(n):
            if networked:
                pb = self.problem(i, kx[i], kv[i], q_pic[i], heard[i])
            else:
                pb = self.problem(i, x, v, q_all)
            warm = np.concatenate([self.U[i, 1:], self.U[i, -1:]], axis=0)
            t0 = time.perf_counter()
            res = S.solve(pb, self.weights, warm, feas_tol=p.feas_tol, options=self.options,
                          duals=S.shift_duals(self.last[i], H, p.col_neig, D))
            self._solve_ms.append(1e3 * (time.perf_counter() - t0))
            self.stats["solves"] += 1
            self.stats["iterations"] += res.iterations
            if res.U is not None:
                self.U[i], self.age[i], self.last[i] = res.U, 0, res
                new_pred[i] = res.positions
            else:
                self.stats["fallbacks"] += 1
                self.last[i] = None
                self.age[i] += 1
                if p.fallback == "shift" and self.age[i] < H:
                    self.U[i] = warm  # the previous plan, one step on (its last acceleration held)
                else:  # brake: cancel the velocity within a_max, then hold still
                    self.stats["brakes"] += 1
                    self.U[i] = 0.0
                    self.U[i, 0] = _clip_norm(-v[i] / h, p.a_max)
                    if p.reach_guard == "on":
                        self.U[i, 0] = guarded_fallback(pb, self.U[i, 0])
                ps, _ = S.rollout(x[i], v[i], self.U[i], h)
                new_pred[i] = np.array(ps)
            self.u_hold[i] = _clip_norm(self.U[i, 0], p.a_max)
            self.log.add(step, i, step * p.dt + h * np.arange(H + 1), np.vstack([x[i], new_pred[i]]))
        self.pred = new_pred
        self.comm.send(n, trajectory_bytes(H + 1))
