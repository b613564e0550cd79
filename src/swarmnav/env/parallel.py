"""The PettingZoo environment: one agent per UAV of a swarmnav scene (module ``swarmnav.env.core``
defines the observation, reward and dynamics)."""

from __future__ import annotations

import functools
from typing import Any

import numpy as np
from gymnasium import spaces
from pettingzoo import ParallelEnv

from swarmnav.env.core import StepOutcome, SwarmCore
from swarmnav.env.options import EnvOptions, env_options
from swarmnav.errors import ConfigError, SwarmnavError
from swarmnav.world.catalog import load_scenario
from swarmnav.world.scenario import Scenario


class ActionError(SwarmnavError, ValueError):
    """An action the environment cannot take: wrong shape or type, not finite, or for an agent
    that is not acting (unknown, or already terminated)."""


def make_core(scenario: str | Scenario, n: int | None, options: dict[str, Any]) -> SwarmCore:
    """The scene (by name, spec, path or object, resized to ``n``) and checked options."""
    opts = env_options(options)
    if isinstance(scenario, Scenario):
        scn = scenario if n is None else scenario.with_n(_positive(n))
    else:
        scn = load_scenario(scenario, n=None if n is None else _positive(n))
    return SwarmCore(scn, opts)


def _positive(n: Any) -> int:
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
        raise ConfigError(f"env: n must be an integer >= 1, got {n!r}")
    return int(n)


def typed_action(a: Any, shape: tuple[int, ...], lead: str, what: str) -> np.ndarray:
    """``a`` as float64 if it holds real numbers of ``shape``, else ActionError starting with
    ``lead`` and saying the action must be ``what`` (finiteness is the caller's check)."""
    arr = np.asarray(a)
    if arr.dtype.kind not in "fiu":
        raise ActionError(f"{lead}action must be {what}; got dtype {arr.dtype}")
    if arr.shape != shape:
        raise ActionError(f"{lead}action must be {what}; got shape {arr.shape}")
    return arr.astype(np.float64)


def check_action(a: Any, shape: tuple[int, ...], who: str) -> np.ndarray:
    """``a`` as a float64 array of ``shape``, or ActionError naming ``who`` and what was expected."""
    arr = typed_action(a, shape, f"{who}: ", f"a normalised acceleration, real numbers of shape {shape}")
    if not np.isfinite(arr).all():
        raise ActionError(f"{who}: action must be finite; got {np.array2string(arr, threshold=8)}")
    return arr


def agent_info(out: StepOutcome, b: int, i: int) -> dict[str, Any]:
    """The per-agent info of one step: the simulator's checks for agent ``i`` of copy ``b``."""
    return {
        "clearance": float(out.clearance[b, i]),
        "distance_to_goal": float(out.distance_to_goal[b, i]),
        "obstacle_contact": bool(out.obstacle_contact[b, i]),
        "agent_contact": bool(out.agent_contact[b, i]),
        "unsafe": bool(out.unsafe[b, i]),
        "arrived": bool(out.arrived[b, i]),
    }


def initial_outcome(core: SwarmCore, pos: np.ndarray, arrived: np.ndarray) -> StepOutcome:
    """The checks of a start state (B, N, d): what ``reset`` reports in its infos (reward 0)."""
    o = core.options
    clr = core.clearance(pos)
    near = core.neighbours(pos)[2]
    dist = np.linalg.norm(pos - core.goal, axis=2)
    return StepOutcome(np.zeros(arrived.shape), arrived, clr, clr < o.body_radius,
                       near < (2.0 * o.body_radius) ** 2, clr < o.d_safe, dist)


class SwarmParallelEnv(ParallelEnv):
    """PettingZoo ``ParallelEnv``: agents ``uav_0 .. uav_{N-1}`` of a swarmnav scene.

    Observation and action spaces are the same for every agent: ``Box(obs_dim,)`` float32 (see
    :mod:`swarmnav.env.core`) and ``Box(-1, 1, (d,))`` float64, a normalised acceleration (a
    row of norm above 1 is scaled to norm 1: out-of-bound actions are clipped, never rejected).
    An agent is terminated when it reaches the goal region (unless ``terminate_at_goal=False``);
    every live agent is truncated at the step limit round(horizon / dt).

    Beyond the PettingZoo API, the full state is readable (the privileged path of the
    baselines): ``positions``, ``velocities`` (N, d), ``arrived`` (N,), ``step_count``,
    ``world`` (the scene) and ``options``.
    """

    metadata = {"name": "swarmnav_v0", "render_modes": [], "is_parallelizable": True}

    def __init__(self, scenario: str | Scenario = "default_corridor", n: int | None = None,
                 render_mode: str | None = None, **options: Any):
        if render_mode is not None:
            raise ConfigError(f"env: render_mode {render_mode!r} is not supported (the environment runs "
                              "headless; plot a recorded run with swarmnav.viz)")
        self.render_mode = None
        self._core = make_core(scenario, n, options)
        c = self._core
        self.possible_agents = [f"uav_{i}" for i in range(c.n)]
        self.agents: list[str] = []
        self._index = {a: i for i, a in enumerate(self.possible_agents)}
        self._obs_space = spaces.Box(c.obs_low, c.obs_high, dtype=np.float32)
        self._act_space = spaces.Box(-1.0, 1.0, (c.dim,), dtype=np.float64)
        self.observation_spaces = dict.fromkeys(self.possible_agents, self._obs_space)
        self.action_spaces = dict.fromkeys(self.possible_agents, self._act_space)
        self._rng: np.random.Generator | None = None
        self._pos = np.zeros((1, c.n, c.dim))
        self._vel = np.zeros((1, c.n, c.dim))
        self._arrived = np.zeros((1, c.n), dtype=bool)
        self._k = 0

    # ------------------------------------------------------------------ PettingZoo API
    @functools.lru_cache(maxsize=None)  # noqa: B019 - the same object every call (PettingZoo's rule)
    def observation_space(self, agent: str) -> spaces.Box:
        self._agent_index(agent)
        return self._obs_space

    @functools.lru_cache(maxsize=None)  # noqa: B019
    def action_space(self, agent: str) -> spaces.Box:
        self._agent_index(agent)
        return self._act_space

    def reset(self, seed: int | None = None, options: dict | None = None) -> tuple[dict, dict]:
        """Spawn the swarm. ``seed`` seeds the episode's generator (None: continue the previous
        one, or fresh entropy at the first reset); ``options`` is accepted as PettingZoo asks
        and unused (the environment's options are fixed when it is made)."""
        if seed is not None or self._rng is None:
            self._rng = np.random.default_rng(seed)
        c = self._core
        self._pos = c.spawn(self._rng)[None].copy()
        self._vel = np.zeros_like(self._pos)
        self._arrived = np.linalg.norm(self._pos - c.goal, axis=2) <= c.options.goal_radius
        self._k = 0
        hover = self._arrived[0] & c.options.terminate_at_goal
        self.agents = [a for a, done in zip(self.possible_agents, hover) if not done]
        obs = c.observe(self._pos, self._vel)
        out = initial_outcome(c, self._pos, self._arrived)
        return ({a: obs[0, self._index[a]] for a in self.agents},
                {a: agent_info(out, 0, self._index[a]) for a in self.agents})

    def step(self, actions: dict[str, Any]) -> tuple[dict, dict, dict, dict, dict]:
        """One step of every live agent; ``actions`` maps each live agent to its action."""
        if not self.agents:
            raise ActionError("no live agents: call reset() first (the episode has ended)")
        if not isinstance(actions, dict):
            raise ActionError(f"actions must be a dict agent -> action, got {type(actions).__name__}")
        c = self._core
        act = np.zeros((1, c.n, c.dim))
        live = set(self.agents)
        for agent, a in actions.items():
            if agent not in live:
                why = "has terminated" if agent in self._index else "is not an agent of this environment"
                raise ActionError(f"agent {agent!r} {why}; live agents: {_names(self.agents)}")
            act[0, self._index[agent]] = check_action(a, (c.dim,), f"agent {agent!r}")
        missing = [a for a in self.agents if a not in actions]
        if missing:
            raise ActionError(f"no action for live agent(s) {_names(missing)}")
        self._pos, self._vel, out, idx = c.step(self._pos, self._vel, self._arrived, act)
        self._arrived = out.arrived
        self._k += 1
        truncated = self._k >= c.options.max_steps
        obs = c.observe(self._pos, self._vel, idx)
        acting = self.agents
        done = out.arrived[0] & c.options.terminate_at_goal
        res = (
            {a: obs[0, self._index[a]] for a in acting},
            {a: float(out.reward[0, self._index[a]]) for a in acting},
            {a: bool(done[self._index[a]]) for a in acting},
            dict.fromkeys(acting, truncated),
            {a: agent_info(out, 0, self._index[a]) for a in acting},
        )
        self.agents = [] if truncated else [a for a in acting if not done[self._index[a]]]
        return res

    def state(self) -> np.ndarray:
        """The global state: (N, 2 d) positions and velocities, float64."""
        return np.concatenate([self._pos[0], self._vel[0]], axis=1)

    def render(self) -> None:
        raise ConfigError("env: rendering is not part of the environment; record the run "
                          "(swarmnav.env.evaluate) and plot it with swarmnav.viz")

    def close(self) -> None:
        pass

    # ------------------------------------------------------------------ privileged state
    @property
    def positions(self) -> np.ndarray:
        return self._pos[0].copy()

    @property
    def velocities(self) -> np.ndarray:
        return self._vel[0].copy()

    @property
    def arrived(self) -> np.ndarray:
        return self._arrived[0].copy()

    @property
    def step_count(self) -> int:
        return self._k

    @property
    def world(self) -> Scenario:
        return self._core.scenario

    @property
    def options(self) -> EnvOptions:
        return self._core.options

    @property
    def core(self) -> SwarmCore:
        return self._core

    def _agent_index(self, agent: str) -> int:
        if agent not in self._index:
            raise ActionError(f"unknown agent {agent!r}; agents: {_names(self.possible_agents)}")
        return self._index[agent]


def _names(agents: list[str]) -> str:
    return ", ".join(agents) if len(agents) <= 6 else f"{', '.join(agents[:3])}, ..., {agents[-1]}"


def parallel_env(scenario: str | Scenario = "default_corridor", n: int | None = None,
                 **options: Any) -> SwarmParallelEnv:
    """A PettingZoo ``ParallelEnv`` of ``scenario`` with ``n`` agents (default: the scene's).

    Args:
        scenario: a built-in scene, generator spec, scene-file path or Scenario.
        n: swarm size (None: the scene's).
        **options: see :class:`swarmnav.env.EnvOptions` (docs/env.md); an unknown name or a
            value out of range raises ConfigError, an unknown scene ScenarioError.
    """
    return SwarmParallelEnv(scenario, n, **options)
