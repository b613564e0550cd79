"""The papers' methods as policies of the environment, and one evaluation for any policy.

A policy is either a callable ``policy(observations) -> actions`` (dicts keyed by agent, as
:class:`~swarmnav.env.parallel.SwarmParallelEnv` uses them: a learned policy) or an object with
``act(observations) -> actions`` and ``reset(env, seed)``, called after every ``env.reset``.

**The baselines take the privileged path.** HES, SPH and APF are registered methods whose
``act`` reads the whole swarm's state (HES: leader election, sub-swarm reports and slot
assignment over all agents; SPH: every robot's plan and the visibility graph; APF: each
agent's full 360-ray ring and its neighbours' exact positions). None of them can be rebuilt
from the per-agent observation (a 36-ray pooled ring, k neighbours) without changing the method,
so :class:`BaselinePolicy` runs the method's own ``reset`` / ``act`` on the environment's full
state (``env.positions``, ``env.velocities``, ``env.world``) and returns its commands as the
environment's actions (divided by ``a_max``). Their commands then pass through the same action
clipping, dynamics, goal test and contact checks as any other policy's. With the
environment made with :func:`method_options` (the method's own dt and dynamics) and a goal
radius no agent reaches, a baseline reproduces ``swarmnav.run`` of that method and seed.
"""

from __future__ import annotations

from typing import Any, Callable, Sequence

import numpy as np

from swarmnav.dynamics import DampedDoubleIntegrator, SaturatedDoubleIntegrator
from swarmnav.env.parallel import SwarmParallelEnv, parallel_env
from swarmnav.errors import ConfigError
from swarmnav.methods import registry
from swarmnav.methods.base import Observation
from swarmnav.metrics.flight import FlightParams, flight_metrics
from swarmnav.metrics.navigation import MetricParams, goal_reached, navigation_metrics
from swarmnav.params import as_dict
from swarmnav.sim.result import RunResult
from swarmnav.world.scenario import Scenario

#: The methods :func:`baseline_policy` knows.
BASELINES = ("hes", "sph", "apf", "ego-swarm", "mader", "lsc", "nmpc", "olfati-saber", "vasarhelyi")


def method_options(name: str, **params: Any) -> dict[str, Any]:
    """The environment options that give method ``name`` its own step and dynamics.

    HES and APF fly the damped double integrator at dt = 0.1 s (the environment's defaults);
    SPH its saturated double integrator at dt = 0.01 s with v_max = 1 m/s, a_max = 1.5 m/s^2.
    """
    m = registry.make(name, **params)
    dyn = m.dynamics
    if isinstance(dyn, SaturatedDoubleIntegrator):
        return {"dynamics": "saturated", "dt": float(m.dt), "a_max": float(dyn.a_max),
                "v_max": None if not np.isfinite(dyn.v_max) else float(dyn.v_max)}
    if isinstance(dyn, DampedDoubleIntegrator) and dyn == DampedDoubleIntegrator():
        return {"dynamics": "damped", "dt": float(m.dt), "a_max": float(getattr(m.params, "a_max", 2.6))}
    raise ConfigError(f"{name}: its dynamics ({type(dyn).__name__}) is not one the environment has "
                      "(damped or saturated double integrator)")


class BaselinePolicy:
    """A registered method acting in a :class:`SwarmParallelEnv` through the privileged path
    (module docstring). ``info`` is the method's last info dict (sub-swarm ``labels``,
    ``events``); ``summary()`` its run summary."""

    def __init__(self, name: str, env: SwarmParallelEnv, **params: Any):
        if name not in BASELINES:
            import difflib

            close = difflib.get_close_matches(str(name), BASELINES, n=1)
            hint = f" (did you mean {close[0]}?)" if close else ""
            raise ConfigError(f"unknown baseline '{name}'{hint}; known: {', '.join(BASELINES)}")
        self.name = name
        self.params = dict(params)
        registry.make(name, **params)  # unknown or out-of-range parameters fail here, at once
        self.env = env
        self._check(env)
        self.method = None
        self.info: dict = {}
        self._rng: np.random.Generator | None = None

    def _check(self, env: SwarmParallelEnv) -> None:
        if not isinstance(env, SwarmParallelEnv):
            raise ConfigError(f"{self.name}: a baseline acts in swarmnav.env.parallel_env, got {type(env).__name__}")
        want = method_options(self.name, **self.params)
        o = env.options
        have = {k: getattr(o, k) for k in want}
        if have != want:
            diff = ", ".join(f"{k}={have[k]!r} (needs {want[k]!r})" for k in want if have[k] != want[k])
            raise ConfigError(f"{self.name} flies its own step and dynamics, the environment has {diff}; "
                              f"make it with parallel_env(scenario, **swarmnav.env.method_options({self.name!r}))")
        dims = registry.make(self.name, **self.params).dims
        if env.world.dim not in dims:
            raise ConfigError(f"{self.name} flies {' or '.join(f'{d}-D' for d in dims)} worlds; "
                              f"{env.world.name} is {env.world.dim}-D")

    def reset(self, env: SwarmParallelEnv | None = None, seed: int | None = None) -> None:
        """Start the method on ``env``'s current (just reset) state. Its generator is
        ``default_rng(seed)`` advanced past the spawn draw, the generator ``swarmnav.run``
        hands the method for the same seed."""
        if env is not None and env is not self.env:
            self._check(env)
            self.env = env
        e = self.env
        rng = np.random.default_rng(seed)
        e.world.spawn_positions(rng)  # the draw swarmnav.run makes before the method's first
        self._rng = rng
        self.method = registry.make(self.name, **self.params)
        self.method.reset(e.world, e.positions, e.velocities, rng)
        self.info = {}

    def act(self, observations: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        """The method's commands for the live agents, as normalised actions."""
        if self.method is None:
            self.reset()
        e = self.env
        k = e.step_count
        cmd, self.info = self.method.act(Observation(k, k * e.options.dt, e.positions, e.velocities), self._rng)
        a = np.asarray(cmd, dtype=np.float64) / e.options.a_max
        index = {name: i for i, name in enumerate(e.possible_agents)}
        return {agent: a[index[agent]] for agent in observations}

    __call__ = act

    def summary(self) -> dict[str, float]:
        return dict(self.method.summary()) if self.method is not None else {}


def baseline_policy(name: str, env: SwarmParallelEnv, **params: Any) -> BaselinePolicy:
    """HES, SPH, APF or a Table II peer (``name``, one of :data:`BASELINES`) as a policy of ``env`` (privileged path: see the module
    docstring). ``env`` must have the method's step and dynamics (:func:`method_options`);
    ``**params`` are the method's parameters (``swarmnav methods NAME``)."""
    return BaselinePolicy(name, env, **params)


class RandomPolicy:
    """Uniform random actions in each agent's action box, from ``default_rng(seed)``."""

    def __init__(self, env: SwarmParallelEnv):
        self.env = env
        self._rng = np.random.default_rng()

    def reset(self, env: SwarmParallelEnv | None = None, seed: int | None = None) -> None:
        self.env = env if env is not None else self.env
        self._rng = np.random.default_rng(seed)

    def act(self, observations: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        d = self.env.world.dim
        a = self._rng.uniform(-1.0, 1.0, (len(observations), d))
        return dict(zip(observations, a))

    __call__ = act


def random_policy(env: SwarmParallelEnv) -> RandomPolicy:
    """Uniform random actions: the floor every learned policy should beat."""
    return RandomPolicy(env)


def evaluate(policy: str | Callable | Any, scenario: str | Scenario, seeds: Sequence[int], *,
             n: int | None = None, **options: Any) -> list[RunResult]:
    """Run ``policy`` for one episode per seed and score each with the simulator's metrics.

    Args:
        policy: ``"random"``, a baseline name (``"hes"``, ``"sph"``, ``"apf"``: its
            :func:`method_options` are applied under ``options``), a policy object
            (``reset(env, seed)`` + ``act(obs)``) or a callable ``obs -> actions``.
        scenario: the scene, as :func:`parallel_env` takes it.
        seeds: one episode per seed; the swarm spawns as ``swarmnav.run`` spawns it.
        n: swarm size (None: the scene's).
        **options: environment options (docs/env.md).

    Returns:
        One :class:`swarmnav.RunResult` per seed: the recorded positions, velocities, clearance
        and sub-swarm labels (a baseline's; 0 otherwise), and ``metrics`` computed by
        :func:`swarmnav.metrics.navigation_metrics` and the flight metrics exactly as
        ``swarmnav run`` computes them (Y, R_goal, R_unsafe, collisions, ...), plus
        ``return_mean`` (the agents' mean episode return) and ``episode_steps``. The goal
        radius, d_safe and body radius of the metrics are the environment's.
    """
    if isinstance(policy, str):
        if policy not in (*BASELINES, "random"):
            raise ConfigError(f"unknown policy '{policy}'; known: random, {', '.join(BASELINES)} "
                              "(or pass a policy object or callable)")
        if policy != "random":
            options = {**method_options(policy), **options}
    env = parallel_env(scenario, n=n, **options)
    if isinstance(policy, str):
        pol = random_policy(env) if policy == "random" else baseline_policy(policy, env)
        label = policy
    else:
        pol = policy
        label = getattr(policy, "name", type(policy).__name__)
    return [_episode(env, pol, int(s), label) for s in seeds]


def _episode(env: SwarmParallelEnv, policy: Any, seed: int, label: str) -> RunResult:
    o = env.options
    obs, _ = env.reset(seed=seed)
    if hasattr(policy, "reset"):
        policy.reset(env, seed)
    act = policy.act if hasattr(policy, "act") else policy
    N, d, K = env.world.n, env.world.dim, o.max_steps
    P = np.empty((K + 1, N, d))
    V = np.empty((K + 1, N, d))
    C = np.empty((K + 1, N))
    lab = np.zeros((K + 1, N), dtype=np.int64)
    P[0], V[0] = env.positions, env.velocities
    C[0] = env.core.clearance(P[:1])[0]
    ret = np.zeros(N)
    index = {a: i for i, a in enumerate(env.possible_agents)}
    events: list[dict] = []
    k = 0
    while env.agents:
        live = {a: obs[a] for a in env.agents}  # the step's observations include the just-arrived
        obs, rew, *_ = env.step(act(live))
        k += 1
        P[k], V[k] = env.positions, env.velocities
        for a, r in rew.items():
            ret[index[a]] += r
        C[k] = env.core.clearance(P[k: k + 1])[0]  # every agent's, hovering ones included
        info = getattr(policy, "info", None) or {}
        lab[k] = info.get("labels", lab[k - 1])
        events += [{"step": k - 1, **ev} for ev in info.get("events", ())]
    P, V, C, lab = P[: k + 1], V[: k + 1], C[: k + 1], lab[: k + 1]
    lab[0] = lab[min(1, k)]
    result = RunResult(
        config={"policy": label, "scenario": env.world.to_dict(), "seed": seed, "steps": k, "dt": o.dt,
                "horizon": o.horizon, "env_options": as_dict(o)},
        positions=P, velocities=V, clearance=C, labels=lab, events=events,
    )
    mp = MetricParams(r_succ=o.goal_radius, d_safe=o.d_safe, body_radius=o.body_radius)
    n_struct = sum(1 for e in events if e.get("action") in ("split", "merge"))
    m = navigation_metrics(P, C, env.world.goal_array, result.n_subswarms, n_struct, mp,
                           reached=goal_reached(env.world, P[-1], goal_radius=o.goal_radius))
    m.update(flight_metrics(P, V, C, env.world.goal_array, o.dt, FlightParams(body_radius=o.body_radius),
                            min_pair=m["min_inter_agent_distance"]))
    m["return_mean"] = float(ret.mean())
    m["episode_steps"] = float(k)
    if hasattr(policy, "summary"):
        m.update(policy.summary())
    result.metrics = m
    return result
