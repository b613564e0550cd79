"""The ``sph`` method end to end: parameters, a short open-space flight, the released kernel."""

import numpy as np
import pytest

import swarmnav
from swarmnav.methods import registry
from swarmnav.world import from_dict

from _helpers.sph import LONE, cruise_reference_speed

OPEN = {"name": "open", "swarm": {"n": 6, "spawn": [-2.0, -2.0, 2.0, 2.0]}, "goal": {"position": [8.0, 0.0]},
        "world": {"bounds": [-6.0, -8.0, 14.0, 8.0]},
        "obstacles": [{"type": "circle", "center": [4.0, 5.0], "radius": 1.0}]}


def test_table_i_defaults_and_strict_parameters():
    m = registry.make("sph")
    p = m.params
    assert (p.c, p.R, p.h, p.m, p.k_den, p.k_rep, p.k_vis, p.k_env) == (54.97, 20.0, 10.0, 1.0, 1.0, 1.0, 1.5, 10.0)
    assert (p.v_max, p.a_max, p.rho0, p.T_p, p.gamma) == (1.0, 1.5, 1e6, 0.2, 7.0)
    assert (p.lambda_s, p.lambda_c, p.lambda_f, p.k_p, p.k_v, p.d_thr) == (5.0, 1000.0, 1.0, 5.0, 3.5, 0.5)
    assert p.kernel == "paper"
    with pytest.raises(swarmnav.ConfigError, match="unknown parameter 'k_dne'"):
        registry.make("sph", k_dne=1.0)
    with pytest.raises(swarmnav.ConfigError, match=r"T_p must be in \(0, inf\) s"):
        registry.make("sph", T_p=0.0)
    with pytest.raises(swarmnav.ConfigError, match="kernel"):
        registry.make("sph", kernel="cpp")


def test_open_flight_reaches_the_goal_without_contact():
    dt = registry.make("sph").dt
    res = swarmnav.run("sph", from_dict(OPEN), seed=2, steps=round(18.0 / dt))  # 18 s
    m = res.metrics
    assert m["sph_success"] == 1.0 and m["collisions"] == 0.0
    assert m["min_inter_robot_distance"] >= 0.4
    assert 0.3 < m["avg_velocity"] <= 1.0 + 1e-9  # never above v_max (eq. 2)
    assert np.all(np.linalg.norm(np.diff(res.positions, axis=0), axis=2) <= 1.0 * dt + 1e-12)
    assert np.all(res.labels == 0) and m["N_event"] == 0.0  # one visible swarm throughout
    assert m["sph_plans"] == 6 * 90  # every robot replans every T_p = 0.2 s over 18 s
    t = res.timings if hasattr(res, "timings") else {}
    assert set(t) >= {"plan_ms_median", "plan_ms_p95", "coord_ms_median"}


def test_wall_between_robots_splits_and_logs_visibility_events():
    scn = from_dict({**OPEN, "swarm": {"n": 4, "spawn": [-2.0, -3.0, 0.0, 3.0]},
                     "obstacles": [{"type": "box", "min": [-1.05, -0.05], "max": [1.5, 0.05]}]})
    res = swarmnav.run("sph", scn, seed=5, steps=round(4.0 / registry.make("sph").dt))
    assert len(np.unique(res.labels[0])) >= 1
    for k in range(res.labels.shape[0]):  # every agent carries the label of its smallest member
        for lab in np.unique(res.labels[k]):
            assert lab == np.flatnonzero(res.labels[k] == lab).min()
    assert all(e["source"] == "visibility" and e["action"] in ("split", "merge") for e in res.events)


def test_released_kernel_option_runs_and_differs():
    a = swarmnav.run("sph", from_dict(OPEN), seed=1, steps=60)
    b = swarmnav.run("sph", from_dict(OPEN), seed=1, steps=60, kernel="released")
    assert np.all(np.isfinite(b.positions)) and not np.array_equal(a.positions, b.positions)



def test_knot_seeding_runs_the_reference_at_v_max():
    # The interior control points on the knots after C_2: the reference cruises at the knot
    # speed ctrl_spacing / dt_knot = v_max (within the smoothing of a 5 m local plan); the
    # released seeding repeats the points C_2 and C_{K-2} stand for and crawls at ~0.72 v_max.
    assert cruise_reference_speed()[0] == pytest.approx(1.0, abs=0.06)
    assert cruise_reference_speed(ctrl_seed="released")[0] < 0.85


def test_reference_lag_is_bounded_at_each_replan():
    # A robot held at its start (a_max tiny) falls behind; with ref_clamp every replan starts
    # ref_reset from it, so its lag right after a replan never exceeds ref_reset (0.5 m).
    m = registry.make("sph", a_max=1e-6, preset="paper")
    lags = []
    orig = m._replan

    def spy(step, x, v, *rest):
        orig(step, x, v, *rest)
        lags.append(float(np.linalg.norm(m.references.q[0, 0] - x[0])))

    m._replan = spy
    swarmnav.run(m, from_dict(LONE), seed=1, steps=round(6.0 / m.dt))
    assert max(lags) <= 0.5 + 1e-9 and max(lags) > 0.45  # clamped, and the clamp was reached


def test_plan_once_reference_waits_for_a_held_robot():
    # Fig. 3B protocol: no replan re-anchors the reference, so the reference clock of a robot
    # slows as it lags and stops at once_hold (the reference waits on the planned path), and the
    # position error is capped there. Without it the lag of a held robot grows with time
    # (k_p x lag beats the 1/r repulsion and the ESDF force: obstacle contacts in sph-narrow).
    def max_lag(**params):
        m = registry.make("sph", a_max=1e-6, plan_once=True, **params)
        res = swarmnav.run(m, from_dict(LONE), seed=1, steps=round(4.0 / m.dt))
        q_ref, _, _ = m._reference(res.positions.shape[0] - 2)
        return float(np.linalg.norm(q_ref[0] - res.positions[-2, 0]))

    assert max_lag() <= 0.5 + 0.011  # once_hold + one step at v_max
    assert max_lag(once_hold=0.0) > 2.0


def test_lag_reset_with_velocity_restarts_at_the_robot_at_rest():
    # Released reset (ref_reset = 1 m onto the robot) with reset_velocity: once a held robot is
    # 1 m behind, the replan starts at the robot with the robot's velocity, so eq. (13) no
    # longer pushes it with k_v v*; the released planner keeps v* (~v_max) after the reset.
    def starts(**params):
        m = registry.make("sph", a_max=1e-6, ref_reset=1.0, ref_clamp=False, **params)
        out = []
        orig = m._replan

        def spy(step, x, v, *rest):
            lag_before = None if m.references.q is None else float(np.linalg.norm(m._reference(step)[0][0] - x[0]))
            orig(step, x, v, *rest)
            out.append((lag_before, float(np.linalg.norm(m.references.q[0, 0] - x[0])), float(np.linalg.norm(m.references.v[0, 0]))))

        m._replan = spy
        swarmnav.run(m, from_dict(LONE), seed=1, steps=round(4.0 / m.dt))
        return [(after, speed) for before, after, speed in out if before is not None and before > 1.0]

    resets = starts(reset_velocity=True)
    assert resets and all(after < 1e-9 and speed < 1e-3 for after, speed in resets)
    released = starts(reset_velocity=False)
    assert released and all(after < 1e-9 and speed > 0.5 for after, speed in released)


def test_plan_once_narrow_passage_keeps_the_body_clearance():
    # sph-narrow, Fig. 3B protocol (plan once), seed 1, first 25 s: the swarm queues at and
    # passes the 2.2 m gap. With the waiting reference clock (once_hold) no robot comes within
    # the 0.2 m body radius of a block and no two robots touch; with the reference running on by
    # time alone, k_p x lag (metres) beats the ESDF force 2 k_env (d_thr - d) <= 10 m/s^2 and
    # robots are dragged into the blocks.
    dt = registry.make("sph").dt
    res = swarmnav.run("sph", "sph_narrow", seed=1, steps=round(25.0 / dt), plan_once=True, preset="paper")
    assert res.metrics["min_robot_obstacle_distance"] > 0.2
    assert res.metrics["min_inter_robot_distance"] > 0.4
    old = swarmnav.run("sph", "sph_narrow", seed=1, steps=round(25.0 / dt), plan_once=True, once_hold=0.0, preset="paper")
    assert old.metrics["min_robot_obstacle_distance"] < 0.2


def test_goal_reset_gathers_twenty_robots_that_the_capped_pull_cannot():
    # The 1/r repulsion of the robots gathered at one goal pushes a late robot out with about
    # (robots gathered) / (crowd radius) m/s^2. With the final approach's lag bounded at
    # ref_reset = 0.3 m (queue) one of 20 robots stays more than 3 m out; bounded at
    # goal_reset = 0.5 m (Table I's k_p x 0.5 m = 2.5 m/s^2) all 20 gather within 3 m.
    scn = from_dict({"name": "crowd", "world": {"bounds": [-10.0, -12.0, 20.0, 12.0]},
                     "swarm": {"n": 20, "spawn": [-4.0, -3.0, 2.0, 3.0]}, "goal": {"position": [8.0, 0.0]}})

    def radii(**params):
        res = swarmnav.run("sph", scn, seed=1, horizon=50.0, preset="queue", **params)
        return np.linalg.norm(res.positions[-1] - np.array([8.0, 0.0]), axis=1), res.metrics

    capped, _ = radii()
    final, m = radii(goal_reset=0.5)
    assert capped.max() > 3.0
    assert final.max() < 3.0 and m["sph_success"] == 1.0
    assert np.median(final) < np.median(capped) - 0.3
