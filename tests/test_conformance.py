"""Every registered method on every built-in scene: runs headless, stays finite, is
deterministic for a seed, and keeps the RunResult contract. New methods and scenes are picked
up automatically from the registries."""

import math

import numpy as np
import pytest

import swarmnav
from swarmnav.methods import registry
from swarmnav.world.scenario import builtin_names

STEPS = 40
MIN_TIME = 2.0  # [s]: a fast controller (SPH at 100 Hz) gets enough steps to show it moves, and a
#                 planner starting from rest time to get going (EGO-Swarm's jerk-minimal start: 0.09 m in
#                 0.8 s; MADER commits its first plan after its 0.2 s replan latency and plans 4 m ahead from
#                 rest: 0.09 m in 1.2 s, 0.4 m in 2 s on the test's forest)


def _steps(method: str) -> int:
    return max(STEPS, math.ceil(MIN_TIME / registry.make(method).dt))
NAV_SCENES = [s for s in builtin_names()] + ["random_forest:density=0.25,seed=1"]


@pytest.mark.parametrize("method", [m for m in registry.names() if registry.spec(m).navigation])
@pytest.mark.parametrize("scene", NAV_SCENES)
def test_method_on_scene(method, scene):
    steps = _steps(method)
    a = swarmnav.run(method, scene, seed=7, steps=steps)
    b = swarmnav.run(method, scene, seed=7, steps=steps)
    n = a.config["scenario"]["swarm"]["n"]
    dim = len(a.config["scenario"]["goal"]["position"])
    assert a.positions.shape == (steps + 1, n, dim)
    if dim == 3 and 3 not in registry.make(method).dims:  # a planar method keeps its altitude
        z = a.config["plane"]["z_fly"]
        assert np.all(a.positions[:, :, 2] == z) and np.all(a.velocities[:, :, 2] == 0.0)
    assert np.all(np.isfinite(a.positions)) and np.all(np.isfinite(a.velocities))
    np.testing.assert_array_equal(a.positions, b.positions)
    np.testing.assert_array_equal(a.labels, b.labels)
    assert a.metrics == b.metrics
    assert all(isinstance(v, float) for v in a.metrics.values())
    # agents moved: a navigation method is not a stub
    assert np.linalg.norm(a.positions[-1] - a.positions[0], axis=1).mean() > 0.1
    c = swarmnav.run(method, scene, seed=8, steps=steps)
    assert not np.array_equal(a.positions[0], c.positions[0])


def test_registry_lists_apf_and_rejects_unknown():
    assert "apf" in registry.names()
    with pytest.raises(swarmnav.ConfigError, match="unknown method"):
        registry.make("nope")
    with pytest.raises(swarmnav.ConfigError, match="unknown parameter 'k_attt'"):
        registry.make("apf", k_attt=1.0)


def _flies_periodic(method: str) -> bool:
    return getattr(registry.make(method), "periodic", True)


@pytest.mark.parametrize("method", [m for m in registry.names() if not _flies_periodic(m)])
def test_method_that_cannot_fly_a_periodic_box_refuses_it_in_one_line(method):
    with pytest.raises(swarmnav.ConfigError, match="cannot fly a periodic world"):
        swarmnav.run(method, "periodic_box:n=10,rho=1.0", seed=2, steps=3)


@pytest.mark.parametrize("method", [m for m in registry.names() if registry.spec(m).navigation
                                    and _flies_periodic(m)])
def test_periodic_world_wraps_positions(method):
    res = swarmnav.run(method, "periodic_box:n=30,rho=1.0", seed=2, steps=30)
    side = res.config["scenario"]["world"]["bounds"][2]
    assert np.all((res.positions >= 0) & (res.positions < side))
    assert np.isfinite(res.metrics["min_inter_agent_distance"])
