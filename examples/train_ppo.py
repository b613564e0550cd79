"""Train a small PPO policy on a swarmnav scene and score it beside the papers' methods.

Needs the ``rl`` extra (``pip install -e '.[rl]'``: Stable-Baselines3 with PyTorch). The
policy is shared by all agents (parameter sharing): each agent is one sample of the
PettingZoo environment, so PPO sees N = 20 transitions per swarm step, through 8 vectorised
copies stepped in one array call.

    python examples/train_ppo.py --scene default_corridor --steps 200000 --out runs/ppo

Then ``evaluate`` scores the trained policy with the simulator's metrics on the same seeds as
the baselines (docs/env.md).
"""

from __future__ import annotations

import argparse

import numpy as np
from gymnasium import spaces
from stable_baselines3 import PPO
from stable_baselines3.common.vec_env import VecEnv

import swarmnav.env as E


class AgentsAsEnvs(VecEnv):
    """B copies of a swarm of N agents as B N single-agent environments for Stable-Baselines3:
    one shared policy, one agent per row. Steps SwarmVectorEnv (one array call for all copies)
    with same-step autoreset: a copy that ends starts anew within the step, its last
    observation kept for PPO's bootstrap at the time limit."""

    def __init__(self, scene: str, copies: int, seed: int, **options):
        self.vec = E.SwarmVectorEnv(copies, scene, autoreset_mode="same_step", **options)
        self.B, self.N = copies, self.vec.core.n
        single_obs = self.vec.single_observation_space
        obs_space = spaces.Box(single_obs.low[0], single_obs.high[0], dtype=np.float32)
        act_space = spaces.Box(-1.0, 1.0, (self.vec.core.dim,), dtype=np.float32)
        super().__init__(self.B * self.N, obs_space, act_space)
        self._seed = seed
        self._actions = None

    def reset(self):
        obs, _ = self.vec.reset(seed=self._seed)
        return obs.reshape(self.B * self.N, -1)

    def step_async(self, actions):
        self._actions = np.asarray(actions, dtype=np.float64).reshape(self.B, self.N, -1)

    def step_wait(self):
        obs, _, term, trunc, info = self.vec.step(self._actions)
        rew = info["reward_agents"].reshape(-1).astype(np.float32)
        dones = np.repeat(term | trunc, self.N)
        infos = [{} for _ in range(self.B * self.N)]
        for b in np.flatnonzero(term | trunc):
            for i in range(self.N):
                infos[b * self.N + i] = {"terminal_observation": info["final_obs"][b, i],
                                         "TimeLimit.truncated": bool(trunc[b] and not term[b])}
        return obs.reshape(self.B * self.N, -1), rew, dones, infos

    def close(self):
        self.vec.close()

    def get_attr(self, attr_name, indices=None):
        return [getattr(self, attr_name)] * len(self._get_indices(indices))

    def set_attr(self, attr_name, value, indices=None):
        setattr(self, attr_name, value)

    def env_method(self, method_name, *args, indices=None, **kwargs):
        raise NotImplementedError(method_name)

    def env_is_wrapped(self, wrapper_class, indices=None):
        return [False] * len(self._get_indices(indices))

    def _get_indices(self, indices):
        return range(self.num_envs) if indices is None else ([indices] if isinstance(indices, int) else indices)


class SharedPolicy:
    """The trained network as a swarmnav.env policy: observations dict -> actions dict."""

    name = "ppo"

    def __init__(self, model: PPO):
        self.model = model

    def act(self, observations):
        names = list(observations)
        obs = np.stack([observations[a] for a in names])
        act, _ = self.model.predict(obs, deterministic=True)
        return dict(zip(names, np.asarray(act, dtype=np.float64)))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", default="default_corridor")
    ap.add_argument("--steps", type=int, default=200_000, help="agent transitions to train on")
    ap.add_argument("--copies", type=int, default=8)
    ap.add_argument("--seeds", default="1-10", help="evaluation seeds")
    ap.add_argument("--out", default="runs/ppo")
    a = ap.parse_args()
    # every agent flies the whole 100 s episode (as the evaluation below scores it)
    venv = AgentsAsEnvs(a.scene, a.copies, seed=0, terminate_at_goal=False)
    model = PPO("MlpPolicy", venv, n_steps=64, batch_size=1024, learning_rate=3e-4, gamma=0.99, seed=0, verbose=1)
    model.learn(total_timesteps=a.steps)
    model.save(f"{a.out}/model")
    lo, _, hi = a.seeds.partition("-")
    seeds = range(int(lo), int(hi or lo) + 1)
    policy = SharedPolicy(model)
    for name, pol in (("ppo", policy), ("apf", "apf"), ("hes", "hes")):
        runs = E.evaluate(pol, a.scene, seeds, terminate_at_goal=False)
        mean = {k: np.mean([r.metrics[k] for r in runs]) for k in ("Y", "R_goal", "R_unsafe", "collisions")}
        print(name, {k: round(float(v), 3) for k, v in mean.items()})


if __name__ == "__main__":
    main()
