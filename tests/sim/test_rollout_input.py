"""The rollout rejects inputs numpy would choke on with a ConfigError (one line in the CLI)."""

import pytest

from swarmnav.errors import ConfigError
from swarmnav.sim import run


@pytest.mark.parametrize("seed", [-1, 1.5, True, "3"])
def test_run_rejects_a_seed_numpy_cannot_take(seed):
    with pytest.raises(ConfigError, match="seed must be an integer >= 0"):
        run("apf", "default_corridor", seed=seed, steps=2)


def test_run_rejects_zero_steps():
    with pytest.raises(ConfigError, match="steps must be an integer >= 1"):
        run("apf", "default_corridor", seed=1, steps=0)
