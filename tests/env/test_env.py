"""swarmnav.env: the PettingZoo and Gymnasium environments, their vector form, the baselines as
policies and evaluate, through the public API only."""

from __future__ import annotations

import warnings

import gymnasium
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env
from pettingzoo.test import parallel_api_test

import swarmnav
import swarmnav.env as E
from swarmnav.errors import ConfigError, ScenarioError
from swarmnav.sensing import range_scan
from swarmnav.world.scenario import builtin_names

SCENES = builtin_names()


def _random_actions(env, rng):
    return {a: rng.uniform(-1.2, 1.2, env.action_space(a).shape) for a in env.agents}


# ------------------------------------------------------------------ the API checkers, every scene
@pytest.mark.parametrize("scene", SCENES)
def test_pettingzoo_and_gymnasium_checkers_pass_on_every_builtin_scene(scene):
    par = E.parallel_env(scene)
    parallel_api_test(par, num_cycles=10)
    obs, _ = par.reset(seed=3)
    assert set(obs) == set(par.possible_agents) and len(obs) == par.world.n
    for a, o in obs.items():
        assert par.observation_space(a).contains(o), a
    obs, *_ = par.step({a: par.action_space(a).sample() for a in par.agents})
    assert all(par.observation_space(a).contains(o) for a, o in obs.items())
    with warnings.catch_warnings():
        # the only warning allowed: velocities and offsets [m, m/s] are unbounded (the world does
        # not confine agents, as in the simulator), so those Box bounds are +-inf on purpose
        warnings.simplefilter("error")
        warnings.filterwarnings("ignore", message=".*Box observation space (minimum|maximum) value is")
        check_env(gymnasium.make(E.ENV_ID, scenario=scene).unwrapped, skip_render_check=True)


# ------------------------------------------------------------------ determinism
def test_same_seed_gives_identical_observations_rewards_and_infos_over_1000_random_steps():
    # one scene (default_corridor, N = 20) to keep the suite fast; 1000 steps = the step limit
    runs = []
    for _ in range(2):
        env = E.parallel_env("default_corridor")
        rng = np.random.default_rng(11)
        obs, infos = env.reset(seed=5)
        trace = [(obs, infos)]
        while env.agents:
            trace.append(env.step(_random_actions(env, rng)))
        assert env.step_count == 1000
        runs.append(trace)
    a, b = runs
    assert len(a) == len(b) == 1001
    for sa, sb in zip(a, b):
        for da, db in zip(sa, sb):
            assert da.keys() == db.keys()
            for key in da:
                if isinstance(da[key], np.ndarray):
                    assert np.array_equal(da[key], db[key])
                else:
                    assert da[key] == db[key]
    other = E.parallel_env("default_corridor").reset(seed=6)[0]
    assert not np.array_equal(other["uav_0"], a[0][0]["uav_0"])


# ------------------------------------------------------------------ observation: oracles
def test_lidar_part_is_the_pooled_ring_of_swarmnav_lidar_scan_and_neighbours_are_the_k_nearest():
    env = E.parallel_env("narrow_alternating_gates", n_rays=24, k_neighbors=4)
    obs, _ = env.reset(seed=2)
    p, d = env.positions, 2
    ring = swarmnav.lidar_scan(env.world, p, n_rays=360, max_range=20.0)
    want = ring.reshape(len(p), 24, 15).min(axis=2) / 20.0
    got = np.stack([obs[f"uav_{i}"] for i in range(len(p))])
    np.testing.assert_allclose(got[:, :24], want, rtol=1e-6)  # float32 observations
    np.testing.assert_allclose(got[:, 24 + d: 24 + 2 * d], env.world.goal_array - p, rtol=1e-6)
    dist = np.linalg.norm(p[:, None] - p[None], axis=2)
    np.fill_diagonal(dist, np.inf)
    near = np.argsort(dist, axis=1, kind="stable")[:, :4]
    rel = (p[near] - p[:, None]).reshape(len(p), 4 * d)
    np.testing.assert_allclose(got[:, 24 + 2 * d: 24 + 2 * d + 4 * d], rel, rtol=1e-6, atol=1e-6)
    assert (got[:, -4:] == 1.0).all()


def test_3d_ring_is_horizontal_and_padding_slots_are_masked():
    env = E.parallel_env("sph_cluttered_3d", n=3, n_rays=36, k_neighbors=4)
    obs, _ = env.reset(seed=1)
    p = env.positions
    t = 2 * np.pi * np.arange(360) / 360
    ring = range_scan(env.world.geometry, p, np.column_stack([np.cos(t), np.sin(t), np.zeros(360)]), 20.0)
    o = obs["uav_0"]
    assert o.shape == (36 + 6 + 4 * 7,) and env.action_space("uav_0").shape == (3,)
    np.testing.assert_allclose(o[:36], ring[0].reshape(36, 10).min(axis=1) / 20.0, rtol=1e-5, atol=1e-6)
    assert o[-4:].tolist() == [1.0, 1.0, 0.0, 0.0]  # two other agents, two padding slots
    assert not o[42 + 2 * 3: 42 + 4 * 3].any()  # padded relative positions are zeros


# ------------------------------------------------------------------ reward, termination, clipping
def test_reward_is_the_documented_sum_and_arrived_agents_terminate_and_hover():
    # straight at the goal through the gates: walls within d_safe, contacts, and arrivals in a
    # goal region of 30 m within the 80 steps
    env = E.parallel_env("narrow_alternating_gates", goal_radius=30.0)
    o = env.options
    obs, infos = env.reset(seed=4)
    dist = {a: infos[a]["distance_to_goal"] for a in env.agents}
    parked: dict[str, np.ndarray] = {}
    seen_arrival = seen_penalty = False
    for _ in range(80):
        if not env.agents:
            break
        goal = {a: obs[a][36 + 2: 36 + 4] for a in env.agents}
        acts = {a: g / max(np.linalg.norm(g), 1e-9) for a, g in goal.items()}
        acting = list(env.agents)
        obs, rew, term, trunc, infos = env.step(acts)
        assert set(rew) == set(acting)
        for a in acting:
            i = infos[a]
            want = (o.w_progress * (dist[a] - i["distance_to_goal"]) + o.w_goal * i["arrived"]
                    - o.dt * (o.w_contact * (i["obstacle_contact"] + i["agent_contact"]) + o.w_unsafe * i["unsafe"]))
            assert rew[a] == pytest.approx(want, abs=1e-9)
            assert term[a] == (i["distance_to_goal"] <= 30.0)
            seen_arrival |= term[a]
            seen_penalty |= i["unsafe"]
            dist[a] = i["distance_to_goal"]
            if term[a]:
                assert a not in env.agents
                parked[a] = env.positions[int(a.split("_")[1])]
        for a, x in parked.items():  # arrived agents hover where they arrived
            assert np.array_equal(env.positions[int(a.split("_")[1])], x)
    assert seen_arrival and seen_penalty and parked


def test_the_three_forms_step_the_same_swarm_and_without_termination_everyone_flies_on():
    kw = dict(goal_radius=30.0, terminate_at_goal=False, horizon=6.0)
    par = E.parallel_env("narrow_alternating_gates", **kw)
    gym = gymnasium.make(E.ENV_ID, scenario="narrow_alternating_gates", **kw)
    vec = E.SwarmVectorEnv(1, "narrow_alternating_gates", **kw)
    po, pi = par.reset(seed=8)
    go, _ = gym.reset(seed=8)
    vo, _ = vec.reset(seed=8)
    assert np.array_equal(np.stack([po[a] for a in par.possible_agents]), go) and np.array_equal(go, vo[0])
    o = par.options
    dist = np.array([pi[a]["distance_to_goal"] for a in par.possible_agents])
    arrived = np.zeros(20, dtype=bool)
    for k in range(60):
        goal = go[:, 38:40] / np.linalg.norm(go[:, 38:40], axis=1, keepdims=True)
        po, pr, pt, _, pi = par.step({a: goal[i] for i, a in enumerate(par.possible_agents)})
        go, gr, gt, _, gi = gym.step(goal)
        vo, vr, *_ = vec.step(goal[None])
        assert k == 59 or len(par.agents) == 20  # nobody leaves before the step limit
        assert not any(pt.values()) and not gt
        assert gr == pytest.approx(np.mean(list(pr.values())), abs=1e-12) and gr == vr[0]
        assert np.array_equal(gi["reward_agents"], [pr[a] for a in par.possible_agents])
        first = gi["arrived"] & ~arrived  # the arrival bonus, once per agent
        want = (o.w_progress * (dist - gi["distance_to_goal"]) + o.w_goal * first
                - o.dt * (o.w_contact * (gi["obstacle_contact"].astype(float) + gi["agent_contact"])
                          + o.w_unsafe * gi["unsafe"]))
        np.testing.assert_allclose(gi["reward_agents"], want, atol=1e-9)
        arrived |= gi["arrived"]
        dist = gi["distance_to_goal"]
    assert arrived.sum() >= 10 and (gi["distance_to_goal"][arrived] < 30.0 - 1.0).any()  # flew on inside


def test_out_of_bound_actions_are_clipped_to_norm_one():
    a = E.parallel_env("default_corridor")
    b = E.parallel_env("default_corridor")
    a.reset(seed=1)
    b.reset(seed=1)
    a.step({x: np.array([3.0, 4.0]) for x in a.agents})
    b.step({x: np.array([0.6, 0.8]) for x in b.agents})
    assert np.array_equal(a.positions, b.positions) and np.array_equal(a.velocities, b.velocities)
    # a = a_max * (0.6, 0.8): v' = a under the inverse-model damped dynamics
    np.testing.assert_allclose(b.velocities, np.tile([0.6 * 2.6 * 0.1, 0.8 * 2.6 * 0.1], (20, 1)))


# ------------------------------------------------------------------ vector form
def test_vector_copies_equal_single_envs_and_autoreset_draws_the_next_start():
    B, steps = 3, 7  # horizon 0.5 s: truncation after 5 steps, autoreset at the 6th
    vec = gymnasium.make_vec(E.ENV_ID, num_envs=B, vectorization_mode="vector_entry_point",
                             scenario="dense_cross_blocks", horizon=0.5)
    singles = [E.SwarmEnv("dense_cross_blocks", horizon=0.5) for _ in range(B)]
    obs, _ = vec.reset(seed=20)
    outs = [s.reset(seed=20 + b) for b, s in enumerate(singles)]
    assert all(np.array_equal(obs[b], outs[b][0]) for b in range(B))
    rng = np.random.default_rng(0)
    for k in range(steps):
        act = rng.uniform(-1, 1, (B, 20, 2))
        obs, rew, term, trunc, info = vec.step(act)
        for b, s in enumerate(singles):
            if k == 5:  # next-step autoreset: the copy's new start from its own generator
                o, _ = s.reset()
                assert rew[b] == 0.0 and not trunc[b]
            else:
                o, r, te, tr, i = s.step(act[b])
                assert rew[b] == r and trunc[b] == tr == (k == 4)
                assert np.array_equal(info["clearance"][b], i["clearance"])
            assert np.array_equal(obs[b], o)
    vec.close()


def test_same_step_autoreset_returns_the_new_start_and_keeps_the_last_observation():
    kw = dict(num_envs=2, scenario="off_axis_goal", horizon=0.3)  # truncation after 3 steps
    nxt = E.SwarmVectorEnv(**kw)
    same = E.SwarmVectorEnv(autoreset_mode="same_step", **kw)
    for v in (nxt, same):
        v.reset(seed=[4, 9])
    rng = np.random.default_rng(1)
    for k in range(3):
        act = rng.uniform(-1, 1, (2, 20, 2))
        o_next, r_next, _, tr_next, _ = nxt.step(act)
        o_same, r_same, _, tr_same, info = same.step(act)
        assert np.array_equal(r_next, r_same) and np.array_equal(tr_next, tr_same)
    assert tr_same.all() and np.array_equal(info["final_obs"], o_next)
    o_reset, r0, *_ = nxt.step(act)  # next-step mode starts the copies one step later
    assert np.array_equal(o_same, o_reset) and not r0.any()
    with pytest.raises(ConfigError, match="autoreset_mode must be next_step or same_step"):
        E.SwarmVectorEnv(2, "off_axis_goal", autoreset_mode="later")


# ------------------------------------------------------------------ baselines and evaluate
@pytest.mark.parametrize("method, horizon", [("apf", 100.0), ("hes", 15.0), ("ego-swarm", 6.0)])
def test_a_baseline_in_the_env_reproduces_swarmnav_run(method, horizon):
    # the method's dt and dynamics, nobody terminated at the goal: the env is the rollout
    res = E.evaluate(method, "default_corridor", [1], horizon=horizon, terminate_at_goal=False)[0]
    ref = swarmnav.run(method, "default_corridor", seed=1, horizon=horizon)
    assert res.positions.shape == ref.positions.shape
    # equal up to the division and multiplication by a_max of the normalised action
    np.testing.assert_allclose(res.positions, ref.positions, atol=1e-8)
    for key in ("Y", "R_goal", "R_unsafe", "d_clr_min", "collisions", "N_swarm", "E_mean", "flight_time"):
        assert res.metrics[key] == pytest.approx(ref.metrics[key], abs=1e-6), key


def test_evaluate_scores_any_policy_with_the_simulators_metrics_and_is_reproducible():
    def toward_goal(obs):  # a hand-written "learned" policy: the goal direction, from the observation
        return {a: o[36 + 2: 36 + 4] / max(np.linalg.norm(o[36 + 2: 36 + 4]), 1e-9) for a, o in obs.items()}

    r1, r2 = E.evaluate(toward_goal, "sph_narrow", [3, 3], horizon=20.0)
    rr = E.evaluate("random", "sph_narrow", [3], horizon=20.0)[0]
    assert np.array_equal(r1.positions, r2.positions) and r1.metrics == r2.metrics
    for key in ("Y", "R_goal", "R_unsafe", "collisions", "d_clr_min", "flight_time", "return_mean"):
        assert key in r1.metrics and np.isfinite(r1.metrics[key])
    assert r1.metrics["R_goal"] > rr.metrics["R_goal"] and r1.metrics["return_mean"] > rr.metrics["return_mean"]
    # the episode ends when every agent has arrived: recorded arrays stop there
    assert r1.positions.shape[0] == r1.metrics["episode_steps"] + 1 <= 201


def test_baseline_needs_its_own_dynamics_and_names_the_fix():
    env = E.parallel_env("default_corridor")
    with pytest.raises(ConfigError, match=r"sph flies its own step.*method_options\('sph'\)"):
        E.baseline_policy("sph", env)
    with pytest.raises(ConfigError, match="unknown baseline 'hse' \\(did you mean hes\\?\\)"):
        E.baseline_policy("hse", env)
    with pytest.raises(ConfigError, match="hes flies 2-D worlds"):
        E.baseline_policy("hes", E.parallel_env("sph_cluttered_3d"))
    assert E.method_options("sph") == {"dynamics": "saturated", "dt": 0.01, "a_max": 1.5, "v_max": 1.0}


# ------------------------------------------------------------------ bad input
@pytest.mark.parametrize("action, message", [
    (np.zeros(3), r"agent 'uav_2': action must be .* shape \(2,\); got shape \(3,\)"),
    (np.array(["a", "b"]), r"agent 'uav_2': action must be .*; got dtype <U1"),
    (np.array([1 + 1j, 0]), r"agent 'uav_2': .*got dtype complex128"),
    (np.array([np.nan, 0.0]), r"agent 'uav_2': action must be finite"),
    (np.array([0.0, np.inf]), r"agent 'uav_2': action must be finite"),
])
def test_bad_actions_name_the_agent_and_what_was_expected(action, message):
    env = E.parallel_env("default_corridor")
    env.reset(seed=0)
    acts = {a: np.zeros(2) for a in env.agents}
    acts["uav_2"] = action
    with pytest.raises(E.ActionError, match=message):
        env.step(acts)
    assert env.step_count == 0  # nothing was stepped


def test_unknown_missing_and_finished_agents_are_errors():
    env = E.parallel_env("default_corridor", horizon=0.1)
    env.reset(seed=0)
    zeros = {a: np.zeros(2) for a in env.agents}
    with pytest.raises(E.ActionError, match="agent 'uav_99' is not an agent of this environment"):
        env.step({**zeros, "uav_99": np.zeros(2)})
    with pytest.raises(E.ActionError, match="no action for live agent.*uav_19"):
        env.step({a: v for a, v in zeros.items() if a != "uav_19"})
    with pytest.raises(E.ActionError, match="unknown agent 'x'"):
        env.action_space("x")
    env.step(zeros)  # the one step of the episode: every agent truncated
    with pytest.raises(E.ActionError, match="no live agents"):
        env.step(zeros)
    assert issubclass(E.ActionError, ValueError) and issubclass(E.ActionError, swarmnav.SwarmnavError)


def test_gymnasium_forms_name_the_bad_row():
    env = E.SwarmEnv("default_corridor")
    env.reset(seed=0)
    a = np.zeros((20, 2))
    a[7, 1] = np.nan
    with pytest.raises(E.ActionError, match=r"agent 'uav_7' \(row 7\): action must be finite"):
        env.step(a)
    with pytest.raises(E.ActionError, match=r"shape \(20, 2\) .*got shape \(2, 20\)"):
        env.step(np.zeros((2, 20)))
    vec = E.SwarmVectorEnv(2, "default_corridor")
    vec.reset(seed=0)
    b = np.zeros((2, 20, 2))
    b[1, 3, 0] = np.inf
    with pytest.raises(E.ActionError, match=r"copy 1, agent 'uav_3'"):
        vec.step(b)


def test_unknown_scene_and_options_give_the_packages_one_line_errors():
    with pytest.raises(ScenarioError, match="unknown scene.*did you mean default_corridor"):
        E.parallel_env("default_coridor")
    with pytest.raises(ConfigError, match=r"env: unknown parameter 'n_ray' \(did you mean n_rays"):
        E.parallel_env("default_corridor", n_ray=36)
    with pytest.raises(ConfigError, match=r"env: dt must be in \[0.0001, 1\] s, got 5.0"):
        gymnasium.make(E.ENV_ID, scenario="default_corridor", dt=5.0)
    with pytest.raises(ConfigError, match="n_rays = 7 must divide lidar_rays = 360"):
        E.parallel_env("default_corridor", n_rays=7)
    with pytest.raises(ConfigError, match="v_max = 1 m/s needs dynamics='saturated'"):
        E.parallel_env("default_corridor", v_max=1.0)
    with pytest.raises(ConfigError, match="periodic world"):
        E.parallel_env("periodic_box:n=10,rho=1")
    with pytest.raises(ConfigError, match="unknown policy 'ppo'"):
        E.evaluate("ppo", "default_corridor", [1])
    for err in (ConfigError, ScenarioError):
        assert issubclass(err, swarmnav.SwarmnavError)  # what the CLI prints as one line, exit 2
