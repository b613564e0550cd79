"""The rollout's generic early stop: a method returning ``info["done"] = True`` ends the run
after that step, and the recorded arrays and metrics cover exactly the steps run."""

from dataclasses import dataclass

import numpy as np

import swarmnav
from swarmnav.dynamics import Kinematic
from swarmnav.experiments.runner import summarize


@dataclass(frozen=True, slots=True)
class _NoParams:
    pass


class _StopAt:
    """Flies +x at 1 m/s and declares its task done at step ``stop``."""

    name = "stop-at"
    params = _NoParams()
    dt = 1.0
    dims = (2,)

    def __init__(self, stop):
        self.stop = stop
        self.dynamics = Kinematic()
        self.calls = 0

    def reset(self, scenario, positions, velocities, rng):
        pass

    def act(self, obs, rng):
        self.calls += 1
        v = np.tile([1.0, 0.0], (len(obs.positions), 1))
        return v, ({"done": True} if obs.step == self.stop else {})

    def summary(self):
        return {}


def test_done_ends_the_run_after_that_step():
    m = _StopAt(stop=4)
    res = swarmnav.run(m, "default_corridor", seed=1, steps=50)
    assert m.calls == 5  # steps k = 0..4
    assert res.positions.shape[0] == 6 and res.velocities.shape[0] == 6 and res.labels.shape[0] == 6
    np.testing.assert_allclose(res.positions[-1] - res.positions[0], np.tile([5.0, 0.0], (res.positions.shape[1], 1)))
    assert res.metrics["L_mean"] > 0  # metrics computed on the truncated record


def test_without_done_the_run_has_all_steps():
    res = swarmnav.run(_StopAt(stop=-1), "default_corridor", seed=1, steps=7)
    assert res.positions.shape[0] == 8


def test_summary_quartiles_and_fractions():
    rows = [{"variant": "v", "status": "done", "k_con": float(k), "converged": float(k < 3)} for k in range(5)]
    (s,) = summarize(rows, [{"name": "v", "columns": {"variant": "v"}}])
    assert (s["k_con_p25"], s["k_con_p50"], s["k_con_p75"]) == (1.0, 2.0, 3.0)
    assert s["converged_fraction"] == 0.6 and s["k_con_mean"] == 2.0
