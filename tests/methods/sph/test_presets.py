"""SPH presets (``preset=paper`` / ``preset=released``) and the released parts they switch on:
the quadratic obstacle force, the per-axis clamp, the planner's own speed bound."""

import dataclasses
import json

import numpy as np
import pytest

import swarmnav
from swarmnav.cli import main
from swarmnav.methods import registry
from swarmnav.methods.sph.kernel import environment_force, released_environment_force
from swarmnav.methods.sph.method import AxisClampedDoubleIntegrator
from swarmnav.world import from_dict

from _helpers.sph import LONE, cruise_reference_speed


def test_swarmnav_is_the_default_build_and_released_has_the_launch_file_values():
    assert registry.make("sph", preset="swarmnav").params == registry.make("sph").params
    assert registry.make("sph", preset="paper").params != registry.make("sph").params
    p = registry.make("sph", preset="released").params
    # water_swarm/launch/sph.launch: k_rep, k_fri, k_p, k_d, v_max, a_max, planv_max, plana_max, updateInterval
    assert (p.k_rep, p.k_vis, p.k_p, p.k_v, p.v_max, p.a_max) == (1.1, 1.8, 15.0, 6.5, 2.5, 3.5)
    assert (p.plan_v_max, p.plan_a_max, p.dt) == (1.2, 1.5, 0.02)
    assert (p.kernel, p.env_law, p.clip, p.k_force, p.env_safe) == ("released", "released", "axis", 1000.0, 0.4)
    # Table I values the launch file does not change stay
    assert (p.h, p.k_den, p.rho0, p.T_p) == (10.0, 1.0, 1e6, 0.2)
    # headroom: the paper build with the planner at 0.8 v_max and the position pull capped at a_max
    h = registry.make("sph", preset="headroom").params
    assert (h.plan_v_max, h.ref_reset, h.k_p * h.ref_reset) == (0.8, 0.3, pytest.approx(h.a_max))
    # guard: queue with the final approach's pull at Table I's bound and the band guard
    q, g = registry.make("sph", preset="queue").params, registry.make("sph", preset="guard").params
    assert (g.goal_reset, g.band_guard, q.goal_reset, q.band_guard) == (0.5, True, 0.0, False)
    assert (g.plan_v_max, g.ref_reset, g.yield_range) == (q.plan_v_max, q.ref_reset, q.yield_range) == (0.8, 0.3, 1.2)
    # retime: queue with re-timed local plans, nothing else
    r = registry.make("sph", preset="retime").params
    assert (r.retime, q.retime) == (0.8, 0.0)
    assert dataclasses.replace(r, retime=0.0) == q
    # the default build holds both sets and flies the one of the scene's dimension (by_dim)
    d = registry.make("sph").params
    assert d.by_dim and not any(registry.make("sph", preset=k).params.by_dim
                                for k in ("paper", "headroom", "queue", "guard", "retime", "released"))
    # ... and, on 2-D swarms of 30 robots or more, the crowd parts (rep_cutoff, crowd_guard, pair_guard
    # with its obstacle rows)
    assert (d.rep_cutoff, d.crowd_guard, d.pair_guard, d.pair_obstacles, d.crowd_size) == (3.0, True, True, True, 30)
    for k in ("paper", "headroom", "queue", "guard", "retime", "released"):
        e = registry.make("sph", preset=k).params
        assert not (e.rep_cutoff or e.crowd_guard or e.pair_guard), k
    no_crowd = dataclasses.replace(d, rep_cutoff=0.0, crowd_guard=False, pair_guard=False, pair_obstacles=False)
    assert dataclasses.replace(no_crowd, retime=0.0, by_dim=False) == g
    assert dataclasses.replace(no_crowd, goal_reset=0.0, band_guard=False, by_dim=False) == r
    # the released 3-D controller has no SPH term in z; the paper's Algorithm 1 acts in every axis
    assert (p.swarm_vertical, q.swarm_vertical, registry.make("sph", preset="paper").params.swarm_vertical) == (False, True, True)
    # an explicit value applies on top of the preset
    assert registry.make("sph", preset="released", k_p=7.0).params.k_p == 7.0
    with pytest.raises(swarmnav.ConfigError, match="unknown preset 'relased'"):
        registry.make("sph", preset="relased")


def test_cli_preset_reaches_the_stored_configuration(tmp_path, capsys):
    out = tmp_path / "r"
    assert main(["run", "--method", "sph", "--scenario-file", _scene(tmp_path), "--steps", "5",
                 "--out", str(out), "--set", "preset=released"]) == 0
    cfg = json.loads((out / "config.json").read_text())
    assert cfg["params"]["k_p"] == 15.0 and cfg["params"]["clip"] == "axis" and cfg["dt"] == 0.02
    assert main(["methods", "sph"]) == 0
    listing = capsys.readouterr().out
    assert "released" in listing and "paper" in listing


def _scene(tmp_path) -> str:
    from swarmnav.world import load_scenario

    f = tmp_path / "lone.toml"
    f.write_text(from_dict(LONE).to_toml())
    assert load_scenario(str(f)).n == 1
    return str(f)


def _loop_released_force(d, g, k_force, d_safe):
    """Plain per-robot evaluation of calcGradForce (bspline_opt_3d.cpp), the oracle."""
    out = np.zeros_like(g)
    for i in range(len(d)):
        if d[i] > d_safe:
            continue
        out[i] = k_force * (d[i] - d_safe) ** 2 * g[i] / np.linalg.norm(g[i])
    return out


@pytest.mark.parametrize("dim", [2, 3])
def test_released_obstacle_force_against_a_loop(dim):
    rng = np.random.default_rng(4)
    d = rng.uniform(-0.1, 0.8, 40)
    g = rng.normal(size=(40, dim)) * rng.uniform(0.5, 2.0, (40, 1))  # not unit: the law normalises
    np.testing.assert_allclose(released_environment_force(d, g, 1000.0, 0.4), _loop_released_force(d, g, 1000.0, 0.4))


def test_released_obstacle_force_is_quadratic_where_the_papers_is_linear():
    g = np.tile([1.0, 0.0], (4, 1))
    d = np.array([0.35, 0.2, 0.0, 0.45])
    rel = released_environment_force(d, g, 1000.0, 0.4)[:, 0]
    np.testing.assert_allclose(rel, [2.5, 40.0, 160.0, 0.0])  # k_force (d - 0.4)^2, zero beyond
    lin = environment_force(d, g, 10.0, 0.5)[:, 0]
    np.testing.assert_allclose(lin, [3.0, 6.0, 10.0, 1.0])  # eqs. (5)-(6): 2 k_env (d_thr - d)


def test_axis_clamp_bounds_each_axis_not_the_norm():
    dyn = AxisClampedDoubleIntegrator(v_max=2.5, a_max=3.5)
    p, v = np.zeros((3, 2)), np.array([[2.4, 2.4], [0.0, 0.0], [-3.0, 0.5]])
    a = np.array([[10.0, 10.0], [1.0, -9.0], [0.0, 0.0]])
    p1, v1 = dyn.step(p, v, a, 0.02)
    expect_v = np.clip(v + 0.02 * np.clip(a, -3.5, 3.5), -2.5, 2.5)
    np.testing.assert_allclose(v1, expect_v)
    np.testing.assert_allclose(p1, 0.02 * expect_v)
    assert np.linalg.norm(v1[0]) > 2.5  # both axes at the bound: the norm is sqrt(2) x 2.5


def test_planner_speed_bound_sets_the_reference_speed():
    # The planner plans at plan_v_max (the knot span is ctrl_spacing / plan_v_max), below the
    # controller's v_max: a held-back robot has the difference to catch up with.
    speed, res = cruise_reference_speed(plan_v_max=0.8)
    assert speed == pytest.approx(0.8, abs=0.05)
    cruise = np.linalg.norm(res.velocities[400:800, 0], axis=1)
    assert cruise.max() <= 1.0 + 1e-9 and cruise.mean() == pytest.approx(0.8, abs=0.06)


@pytest.mark.parametrize("scene, same_as", [
    ("sph_narrow", "guard"),
    ("random_forest_3d:density=0.15,seed=1,n=6,length=8", "retime"),
])
def test_default_build_flies_the_recommended_set_of_the_scenes_dimension(scene, same_as):
    """Oracle: the default build (by_dim) on a 2-D scene gives guard's arrays bit for bit, on a
    3-D scene retime's; the stored parameters are the declared ones."""
    from swarmnav.sim import run
    from swarmnav.world import load_scenario

    scn = load_scenario(scene)
    default = run("sph", scn, seed=3, steps=400)
    other = run("sph", scn, seed=3, steps=400, preset=same_as)
    np.testing.assert_array_equal(default.positions, other.positions)
    np.testing.assert_array_equal(default.velocities, other.velocities)
    assert not np.array_equal(default.positions, run("sph", scn, seed=3, steps=400, preset="paper").positions)
    assert default.config["params"]["by_dim"] is True and default.config["params"]["band_guard"] is True
