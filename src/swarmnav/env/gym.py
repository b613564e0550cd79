"""Gymnasium environments: the whole swarm as one agent (``swarmnav/Swarm-v0``), and its vector
form stepping B copies in one array call (``gymnasium.make_vec("swarmnav/Swarm-v0", num_envs=B,
vectorization_mode="vector_entry_point")`` or :class:`SwarmVectorEnv`)."""

from __future__ import annotations

from typing import Any

import gymnasium
import numpy as np
from gymnasium import spaces
from gymnasium.vector import AutoresetMode, VectorEnv

from swarmnav.env.core import StepOutcome
from swarmnav.env.parallel import check_action, initial_outcome, make_core, typed_action
from swarmnav.errors import ConfigError
from swarmnav.world.scenario import Scenario

#: Keys of the info dicts: (N,) per copy in SwarmEnv, (B, N) in SwarmVectorEnv.
INFO_KEYS = ("reward_agents", "arrived", "clearance", "distance_to_goal", "obstacle_contact",
             "agent_contact", "unsafe")


def _infos(out: StepOutcome) -> dict[str, np.ndarray]:
    return {
        "reward_agents": out.reward, "arrived": out.arrived, "clearance": out.clearance,
        "distance_to_goal": out.distance_to_goal, "obstacle_contact": out.obstacle_contact,
        "agent_contact": out.agent_contact, "unsafe": out.unsafe,
    }


def _no_render(render_mode: str | None) -> None:
    if render_mode is not None:
        raise ConfigError(f"env: render_mode {render_mode!r} is not supported (the environment runs "
                          "headless; plot a recorded run with swarmnav.viz)")


def _check_batch(action: Any, shape: tuple[int, ...], prefix: str) -> np.ndarray:
    """(…, N, d) actions as float64; ActionError naming the first bad agent (and copy)."""
    arr = typed_action(action, shape, prefix,
                       f"normalised accelerations, real numbers of shape {shape} (one row per agent)")
    bad = ~np.isfinite(arr).all(axis=-1)
    if bad.any():
        where = np.argwhere(bad)[0]
        copy = f"copy {where[0]}, " if len(where) == 2 else ""
        i = int(where[-1])
        return check_action(arr[tuple(where)], shape[-1:], f"{prefix}{copy}agent 'uav_{i}' (row {i})")
    return arr


class SwarmEnv(gymnasium.Env):
    """The whole swarm as one agent: observation (N, obs_dim) float32, the PettingZoo
    environment's per-agent observations stacked; action (N, d) in [-1, 1], one normalised
    acceleration per agent (a row of norm above 1 is scaled to 1).

    The reward is the mean over the N agents of their rewards (hovering arrived agents
    contribute 0); ``terminated`` when every agent has arrived (never with
    ``terminate_at_goal=False``), ``truncated`` at the step limit. ``info``
    holds (N,) arrays: the per-agent rewards and the simulator's checks (:data:`INFO_KEYS`).
    """

    metadata = {"render_modes": []}

    def __init__(self, scenario: str | Scenario = "default_corridor", n: int | None = None,
                 render_mode: str | None = None, **options: Any):
        _no_render(render_mode)
        self.render_mode = None
        self.core = c = make_core(scenario, n, options)
        self.observation_space = spaces.Box(np.tile(c.obs_low, (c.n, 1)), np.tile(c.obs_high, (c.n, 1)),
                                            dtype=np.float32)
        self.action_space = spaces.Box(-1.0, 1.0, (c.n, c.dim), dtype=np.float64)
        self._pos = np.zeros((1, c.n, c.dim))
        self._vel = np.zeros((1, c.n, c.dim))
        self._arrived = np.zeros((1, c.n), dtype=bool)
        self._k = 0

    def reset(self, *, seed: int | None = None, options: dict | None = None) -> tuple[np.ndarray, dict]:
        super().reset(seed=seed)  # self.np_random: default_rng(seed), as swarmnav.run draws
        if options:
            raise ConfigError(f"env: reset options are not used, got {sorted(options)}; the environment's "
                              "options are given when it is made")
        c = self.core
        self._pos = c.spawn(self.np_random)[None].copy()
        self._vel = np.zeros_like(self._pos)
        self._arrived = np.linalg.norm(self._pos - c.goal, axis=2) <= c.options.goal_radius
        self._k = 0
        info = {k: v[0] for k, v in _infos(initial_outcome(c, self._pos, self._arrived)).items()}
        return c.observe(self._pos, self._vel)[0], info

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict]:
        c = self.core
        act = _check_batch(action, (c.n, c.dim), "")
        self._pos, self._vel, out, idx = c.step(self._pos, self._vel, self._arrived, act[None])
        self._arrived = out.arrived
        self._k += 1
        obs = c.observe(self._pos, self._vel, idx)[0]
        info = {k: v[0] for k, v in _infos(out).items()}
        return (obs, float(out.reward[0].mean()), bool(out.arrived[0].all() and c.options.terminate_at_goal),
                self._k >= c.options.max_steps, info)

    @property
    def positions(self) -> np.ndarray:
        return self._pos[0].copy()

    @property
    def velocities(self) -> np.ndarray:
        return self._vel[0].copy()


class SwarmVectorEnv(VectorEnv):
    """``num_envs`` copies of :class:`SwarmEnv` on one scene, stepped as (B, N, d) arrays.

    One ``step`` integrates, senses (one LiDAR kernel call for all B N rings) and scores every
    copy at once. ``reset(seed=s)`` seeds copy b with ``s + b`` (or ``seed=[s_0, .., s_{B-1}]``),
    so copy b starts exactly as ``SwarmEnv.reset(seed=s + b)``. A copy that terminates or
    truncates is reset at its next ``step`` (Gymnasium's next-step autoreset: that step
    ignores its action and returns its first observation with reward 0), drawing its new start
    from its own generator. With ``autoreset_mode="same_step"`` it is reset within the step
    that ends it: the step returns its first observation and ``info["final_obs"]`` holds the
    last one (what Stable-Baselines3 and most PPO loops expect).
    """

    metadata = {"render_modes": [], "autoreset_mode": AutoresetMode.NEXT_STEP}

    def __init__(self, num_envs: int = 1, scenario: str | Scenario = "default_corridor", n: int | None = None,
                 render_mode: str | None = None, autoreset_mode: str | AutoresetMode = AutoresetMode.NEXT_STEP,
                 **options: Any):
        _no_render(render_mode)
        modes = {"next_step": AutoresetMode.NEXT_STEP, "same_step": AutoresetMode.SAME_STEP}
        mode = next((m for name, m in modes.items() if autoreset_mode in (m, m.value, name)), None)
        if mode is None:
            raise ConfigError(f"env: autoreset_mode must be next_step or same_step, got {autoreset_mode!r}")
        self.metadata = {**self.metadata, "autoreset_mode": mode}
        if isinstance(num_envs, bool) or not isinstance(num_envs, (int, np.integer)) or num_envs < 1:
            raise ConfigError(f"env: num_envs must be an integer >= 1, got {num_envs!r}")
        self.render_mode = None
        self.num_envs = B = int(num_envs)
        self.core = c = make_core(scenario, n, options)
        self.single_observation_space = spaces.Box(np.tile(c.obs_low, (c.n, 1)), np.tile(c.obs_high, (c.n, 1)),
                                                   dtype=np.float32)
        self.single_action_space = spaces.Box(-1.0, 1.0, (c.n, c.dim), dtype=np.float64)
        self.observation_space = gymnasium.vector.utils.batch_space(self.single_observation_space, B)
        self.action_space = gymnasium.vector.utils.batch_space(self.single_action_space, B)
        self._pos = np.zeros((B, c.n, c.dim))
        self._vel = np.zeros((B, c.n, c.dim))
        self._arrived = np.zeros((B, c.n), dtype=bool)
        self._k = np.zeros(B, dtype=np.int64)
        self._rngs: list[np.random.Generator] = []
        self._autoreset = np.zeros(B, dtype=bool)

    def reset(self, *, seed: int | list[int] | None = None, options: dict | None = None
              ) -> tuple[np.ndarray, dict]:
        if options:
            raise ConfigError(f"env: reset options are not used, got {sorted(options)}")
        B = self.num_envs
        if seed is None:
            seeds: list[int | None] = [None] * B
        elif isinstance(seed, (int, np.integer)) and not isinstance(seed, bool):
            seeds = [int(seed) + b for b in range(B)]
        else:
            seeds = list(seed)
            if len(seeds) != B:
                raise ConfigError(f"env: {len(seeds)} seeds for {B} copies")
        if seed is not None or not self._rngs:
            self._rngs = [np.random.default_rng(s) for s in seeds]
        for b in range(B):
            self._respawn(b)
        self._autoreset[:] = False
        c = self.core
        return c.observe(self._pos, self._vel), _infos(initial_outcome(c, self._pos, self._arrived))

    def _respawn(self, b: int) -> None:
        c = self.core
        self._pos[b] = c.spawn(self._rngs[b])
        self._vel[b] = 0.0
        self._arrived[b] = np.linalg.norm(self._pos[b] - c.goal, axis=1) <= c.options.goal_radius
        self._k[b] = 0

    def step(self, actions: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict]:
        c = self.core
        B = self.num_envs
        act = _check_batch(actions, (B, c.n, c.dim), "")
        self._pos, self._vel, out, idx = c.step(self._pos, self._vel, self._arrived, act)
        self._arrived = out.arrived
        self._k += 1
        reward = out.reward.mean(axis=1)
        terminated = out.arrived.all(axis=1) & c.options.terminate_at_goal
        truncated = self._k >= c.options.max_steps
        reset = np.flatnonzero(self._autoreset)
        if len(reset):  # copies that ended last step start anew: their step above is discarded
            for b in reset:
                self._respawn(b)
            fresh = initial_outcome(c, self._pos[reset], self._arrived[reset])
            for f in ("reward", "arrived", "clearance", "obstacle_contact", "agent_contact", "unsafe",
                      "distance_to_goal"):
                getattr(out, f)[reset] = getattr(fresh, f)
            reward[reset] = 0.0
            terminated[reset] = False
            truncated[reset] = False
            idx = c.neighbours(self._pos)[0]
        obs = c.observe(self._pos, self._vel, idx)
        ended = terminated | truncated
        infos = _infos(out)
        infos.update({f"_{k}": np.ones(B, dtype=bool) for k in INFO_KEYS})
        if self.metadata["autoreset_mode"] is AutoresetMode.SAME_STEP:
            if ended.any():
                infos["final_obs"] = obs.copy()
                infos["_final_obs"] = ended.copy()
                for b in np.flatnonzero(ended):
                    self._respawn(b)
                obs = c.observe(self._pos, self._vel)
        else:
            self._autoreset = ended
        return obs, reward, terminated, truncated, infos

    @property
    def positions(self) -> np.ndarray:
        return self._pos.copy()

    @property
    def velocities(self) -> np.ndarray:
        return self._vel.copy()
