"""A run between two steps, copyable, and the lookahead a method's oracle flies in copies of it.

:class:`Flight` holds what a run's future depends on -- the method (with its memory), the state
arrays, the random generator, the referee's crash record -- and :meth:`Flight.step` advances it by
one step exactly as :func:`swarmnav.sim.rollout.run` does (the method acts, the dynamics
integrate, the referee judges). :meth:`Flight.copy` gives an independent continuation: a copy and
its original fly on bit-identically (tests/methods/hes/test_copy.py checks both against ``run``).
It flies the ideal network with perfect perception and the point vehicle (the run's defaults).

:class:`Lookahead` is what :func:`run` hands a method that decides by looking ahead (its
optional ``oracle`` hook, docs/oracle.md): at the start of every step it keeps a copy of the run,
and asked at a decision point it flies a copy of that step with the decision forced, then on
under the method's own rule, and reports the outcome.
"""

from __future__ import annotations

import copy
import time
from dataclasses import dataclass
from typing import Any

import numpy as np
from numba import njit

from swarmnav.errors import ConfigError, DivergedError, ScenarioError
from swarmnav.methods import registry
from swarmnav.methods.base import Method, Observation
from swarmnav.metrics.navigation import MetricParams, goal_reached
from swarmnav.sensing import PreparedGeometry
from swarmnav.sim.referee import Referee
from swarmnav.world.catalog import load_scenario
from swarmnav.world.scenario import Scenario


@njit(cache=True)
def inside_walls(P, lo, hi, clearance):
    """Lower each agent's clearance to its signed distance to the outside of the world's box
    (negative beyond the bounds). Inside the bounds the walls give the same distance; beyond the
    walls' far side this keeps an agent that left the world from reading as clear."""
    n, d = P.shape
    for i in range(n):
        m = np.inf
        for c in range(d):
            m = min(m, P[i, c] - lo[c], hi[c] - P[i, c])
        if m < clearance[i]:
            clearance[i] = m


def world_of(scn: Scenario, dims: tuple[int, ...], z_fly: Any, name: str) -> tuple[Scenario, float | None]:
    """The scene the method flies and the altitude of its plane (None: the scene itself)."""
    if scn.dim in dims:
        if z_fly is not None:
            raise ConfigError(f"z_fly applies only to a planar method on a 3-D scene ({name} flies "
                              f"this {scn.dim}-D scene as it is)")
        return scn, None
    if scn.dim == 2:
        raise ConfigError(f"{name} flies 3-D scenes only; {scn.name} is planar")
    if z_fly is None:
        z = scn.default_altitude()
    else:
        try:
            z = float(z_fly)
        except (TypeError, ValueError):
            raise ConfigError(f"z_fly must be a number [m], got {z_fly!r}") from None
    try:
        return scn.planar_slice(z), z
    except ScenarioError as e:
        raise ConfigError(str(e)) from None


class Flight:
    """One run's state between steps (see the module docstring).

    Attributes:
        method: the method object, mid-run.
        k: the next step to fly; pos, vel: (N, d) the method's state [m], [m/s].
        rng: the run's generator; referee: the crash rule (None under ``contact = "count"``).
        scene: the scene as recorded (3-D for a planar method on a 3-D scene); plane_z: the
            altitude of a planar method's slice (None: the scene itself).
    """

    def __init__(self, method: Method, scene: Scenario, k: int, pos: np.ndarray, vel: np.ndarray,
                 rng: np.random.Generator, referee: Referee | None, plane_z: float | None = None,
                 prepared: PreparedGeometry | None = None):
        self.method, self.scene, self.k = method, scene, int(k)
        self.pos, self.vel, self.rng, self.referee, self.plane_z = pos, vel, rng, referee, plane_z
        self.dt = float(method.dt)
        # the scene's obstacles converted once for the clearance queries, shared by every copy
        self._prepared = prepared if prepared is not None or scene.geometry.is_empty else PreparedGeometry(scene.geometry)

    @classmethod
    def start(cls, method: str | Method, scenario: str | Scenario, *, seed: int, **params: Any) -> Flight:
        """The state :func:`swarmnav.run` starts from with the same arguments (ideal network,
        perfect perception; the scene's rules; ``params`` are the method's)."""
        scn = load_scenario(scenario) if not isinstance(scenario, Scenario) else scenario
        m = registry.make(method, **params) if isinstance(method, str) else method
        world, plane_z = world_of(scn, m.dims, None, m.name)
        if world.periodic:
            raise ConfigError(f"a Flight flies walled or open worlds; {scn.name} is periodic")
        rng = np.random.default_rng(seed)
        pos = world.spawn_positions(rng)
        vel = np.zeros_like(pos)
        m.reset(world, pos.copy(), vel.copy(), rng)
        referee = None
        if scn.contact == "crash":
            referee = Referee(scn.n, scn.rules.body_radius, None, bounds=world.bounds if scn.boundary == "wall" else None)
        f = cls(m, scn, 0, pos, vel, rng, referee, plane_z)
        if referee is not None:
            referee.judge(0, f.recorded(pos), f.clearance(f.recorded(pos)), pos)
        return f

    # ------------------------------------------------------------------ what the run records
    def recorded(self, pos: np.ndarray) -> np.ndarray:
        """The positions as the run records them (lifted to the slice's altitude for a planar method)."""
        if self.plane_z is None:
            return pos
        return np.column_stack([pos, np.full(len(pos), self.plane_z)])

    def clearance(self, P: np.ndarray) -> np.ndarray:
        """(N,) clearance of recorded positions ``P`` [m], as the run measures it (walls included)."""
        P = np.ascontiguousarray(P, dtype=np.float64)
        c = np.full(len(P), np.inf) if self._prepared is None else self._prepared.distance_into(P, np.empty(len(P)))
        if self.scene.boundary == "wall":
            inside_walls(P, self.scene.lower, self.scene.upper, c)
        return c

    # ------------------------------------------------------------------ one step, a copy
    def step(self) -> tuple[dict, np.ndarray]:
        """Fly step ``k`` as :func:`run` does; returns the method's info and the new clearance (N,) [m]."""
        m, k, dt = self.method, self.k, self.dt
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
            cmd, info = m.act(Observation(k, k * dt, self.pos, self.vel, None), self.rng)
            pos, vel = m.dynamics.step(self.pos, self.vel, cmd, dt)
            if self.referee is not None:
                self.referee.hold(pos, vel)
            if not (np.isfinite(pos).all() and np.isfinite(vel).all()):
                raise DivergedError(f"{m.name} diverged at step {k + 1} (t = {(k + 1) * dt:g} s) in a copied run")
            P = self.recorded(pos)
            c = self.clearance(P)
            if self.referee is not None:
                self.referee.judge(k + 1, P, c, pos)
        self.pos, self.vel, self.k = pos, vel, k + 1
        return info, c

    def copy(self) -> Flight:
        """An independent continuation of this run (the method through its ``clone()`` if it has
        one, else ``copy.deepcopy``; the arrays, the generator and the referee copied)."""
        clone = getattr(self.method, "clone", None)
        m = clone() if callable(clone) else copy.deepcopy(self.method)
        return Flight(m, self.scene, self.k, self.pos.copy(), self.vel.copy(), copy.deepcopy(self.rng),
                      copy.deepcopy(self.referee), self.plane_z, self._prepared)


@dataclass(frozen=True, slots=True)
class Outcome:
    """What one lookahead flight achieved (the inputs of an oracle's objective).

    Attributes:
        action: the structural action forced at the decision step (one the method's Pi_feas keeps).
        steps: steps flown (the horizon, or fewer when the run ends first).
        progress: mean over agents of the decrease of its distance to the goal region
            (max(||p_i - g|| - goal_radius, 0)) over the flight [m].
        reached: fraction of agents at the goal at the end, as the run's R_goal judges it [-].
        success: 1.0 if ``reached`` meets the mission threshold (the run's Y), else 0.0.
        crashed: fraction of agents that crashed during the flight [-].
        unsafe: fraction of agent-steps with clearance below the scene's d_safe [-].
    """

    action: str
    steps: int
    progress: float
    reached: float
    success: float
    crashed: float
    unsafe: float


class Lookahead:
    """The simulator :func:`run` hands a method's ``oracle`` hook (see the module docstring).

    ``mark`` keeps a copy of the run at the start of step k; the method's oracle then calls
    ``lookahead(action, k, steps)`` from inside its own step k to fly a copy of that step with
    ``action`` forced (the copy's oracle hook's ``force(k, action)``), then on for up to ``steps``
    steps in all (never past the run's last step), deciding by its rule."""

    def __init__(self, scene: Scenario, last_step: int, plane_z: float | None = None):
        self.scene, self.last_step, self.plane_z = scene, int(last_step), plane_z
        self.goal = scene.goal_array if scene.has_goal else None
        self.tau = MetricParams().tau_ms
        self._start: Flight | None = None
        self._prepared = None if scene.geometry.is_empty else PreparedGeometry(scene.geometry)
        self.steps = 0  # simulated lookahead steps in all
        self.copy_wall = 0.0  # [s] wall time of the copies kept at the start of every step

    def mark(self, method: Method, k: int, pos: np.ndarray, vel: np.ndarray, rng: np.random.Generator,
             referee: Referee | None) -> None:
        """Keep a copy of the run at the start of step ``k`` (called by the run before the method acts)."""
        t0 = time.perf_counter()
        self._start = Flight(method, self.scene, k, pos, vel, rng, referee, self.plane_z, self._prepared).copy()
        self.copy_wall += time.perf_counter() - t0

    def __call__(self, action: str, k: int, steps: int) -> Outcome:
        if self._start is None or self._start.k != k:
            raise RuntimeError(f"lookahead asked about step {k} without a copy of the run at that step")
        if self.goal is None:
            raise ConfigError(f"an oracle scores progress to the goal; {self.scene.name} has none")
        f = self._start.copy()
        f.method.oracle.force(k, action)
        n = f.pos.shape[0]
        r = self.scene.rules
        d0 = self._gap(f.recorded(f.pos))
        crashed0 = 0 if f.referee is None else int(f.referee.crashed.sum())
        unsafe = flown = 0
        for _ in range(max(1, min(int(steps), self.last_step - k))):
            info, c = f.step()
            flown += 1
            unsafe += int(np.count_nonzero(c < r.d_safe))
            if info.get("done") or (f.referee is not None and f.referee.crashed.all()):
                break
        P = f.recorded(f.pos)
        crashed = f.referee.crashed if f.referee is not None else np.zeros(n, dtype=bool)
        reached = float(np.mean(goal_reached(self.scene, P, crashed)))
        self.steps += flown
        return Outcome(action=action, steps=flown, progress=float(np.mean(d0 - self._gap(P))), reached=reached,
                       success=float(reached >= self.tau), crashed=(int(crashed.sum()) - crashed0) / n,
                       unsafe=unsafe / (n * flown))

    def _gap(self, P: np.ndarray) -> np.ndarray:
        """(N,) each agent's distance to the goal region [m] (0 inside the goal radius)."""
        return np.maximum(np.linalg.norm(P - self.goal, axis=1) - self.scene.rules.goal_radius, 0.0)
