"""Reinforcement-learning environments of every swarmnav scene (docs/env.md).

- :func:`parallel_env`: a PettingZoo ``ParallelEnv``, one agent per UAV;
- ``gymnasium.make("swarmnav/Swarm-v0", scenario=...)``: the whole swarm as one agent
  (:class:`SwarmEnv`), registered when this module is imported; its vector form
  :class:`SwarmVectorEnv` (``gymnasium.make_vec(..., vectorization_mode="vector_entry_point")``)
  steps B copies as one array call;
- :func:`baseline_policy`: HES, SPH, APF and the Table II peers as policies (privileged path), :func:`random_policy`;
- :func:`evaluate`: any policy over seeds, scored with the simulator's metrics.

Options (:class:`EnvOptions`) are checked like method parameters: an unknown name or a value
out of range raises :class:`swarmnav.ConfigError`, an unknown scene :class:`swarmnav.ScenarioError`,
a bad action :class:`ActionError` (a ``ValueError``) naming the agent.
"""

from __future__ import annotations

try:
    import gymnasium
    import pettingzoo  # noqa: F401
except ImportError as e:  # the env extra is optional for the simulator
    raise ImportError(f"swarmnav.env needs Gymnasium and PettingZoo ({e}): pip install 'swarmnav[env]'") from e

from swarmnav.env.baselines import (
    BASELINES,
    BaselinePolicy,
    RandomPolicy,
    baseline_policy,
    evaluate,
    method_options,
    random_policy,
)
from swarmnav.env.gym import SwarmEnv, SwarmVectorEnv
from swarmnav.env.options import EnvOptions
from swarmnav.env.parallel import ActionError, SwarmParallelEnv, parallel_env

ENV_ID = "swarmnav/Swarm-v0"

if ENV_ID not in gymnasium.registry:
    gymnasium.register(id=ENV_ID, entry_point="swarmnav.env.gym:SwarmEnv",
                       vector_entry_point="swarmnav.env.gym:SwarmVectorEnv")

__all__ = [
    "BASELINES", "ENV_ID", "ActionError", "BaselinePolicy", "EnvOptions", "RandomPolicy", "SwarmEnv",
    "SwarmParallelEnv", "SwarmVectorEnv", "baseline_policy", "evaluate", "method_options",
    "parallel_env", "random_policy",
]
