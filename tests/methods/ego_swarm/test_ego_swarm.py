"""ego-swarm: the optimiser's cost against finite differences, the ESDF-free pairs, the swarm term,
and the method's public behaviour (reaching goals, clearance, bad input, fallbacks, messages)."""

import numpy as np
import pytest

import swarmnav
from _helpers.cli import run_cli
from swarmnav.methods import registry
from swarmnav.methods.ego_swarm.optimizer import MapView, Weights, cost_grad, rebound_optimize
from swarmnav.planning.bspline import evaluate
from swarmnav.planning.esdf_free import find_pairs, occupied
from swarmnav.planning.maps import OccupancyMaps
from swarmnav.planning.messages import trajectory_bytes
from swarmnav.world import loads
from swarmnav.world.obstacles import Circle

PILLAR = """
name = "pillar"
[world]
bounds = [-6.0, -6.0, 16.0, 6.0]
[swarm]
n = {n}
spawn = [-5.0, -2.0, -2.0, 2.0]
min_spacing = 0.9
clearance = 0.5
[goal]
position = [12.0, 0.0]
[[obstacles]]
type = "circle"
center = [5.0, 0.0]
radius = 1.5
"""


def _cost(ctrl, others, anchors, target, lam_t=0.7):
    pi = np.array([4, 5, 9], dtype=np.int64)
    pp = np.array([[0.3, 0.2], [1.1, 0.4], [2.0, -0.3]])
    pv = np.array([[0.0, 1.0], [0.6, 0.8], [-0.8, 0.6]])
    g = np.empty_like(ctrl)
    f = cost_grad(ctrl, 0.4, 1.0, 0.5, 0.1, 0.5, 1.0, 0.5, 1.0, 1.0, 1.5, pi, pp, pv, others, anchors, lam_t,
                  target, g)
    return f, g


def test_cost_gradient_matches_finite_differences():
    """Every term (jerk, feasibility, {p, v} pairs in both branches, swarm, fitness, terminal)
    together: the analytic gradient equals central differences to 1e-5 relative."""
    rng = np.random.default_rng(3)
    n = 12
    ctrl = np.column_stack([np.linspace(0, 4.4, n), 0.3 * np.sin(np.arange(n))]) + rng.normal(0, 0.05, (n, 2))
    ctrl[5] += [0.0, -0.9]  # deep inside its pair: the quadratic branch
    others = np.stack([ctrl + rng.normal(0, 0.4, ctrl.shape), np.full_like(ctrl, np.nan)])
    anchors = ((ctrl[:-2] + 4 * ctrl[1:-1] + ctrl[2:]) / 6.0) + rng.normal(0, 0.1, (n - 2, 2))
    target = np.array([4.0, 0.5])
    f0, g = _cost(ctrl, others, anchors, target)
    assert f0 > 0
    num = np.zeros_like(ctrl)
    h = 1e-6
    for i in range(n):
        for d in range(2):
            e = np.zeros_like(ctrl)
            e[i, d] = h
            num[i, d] = (_cost(ctrl + e, others, anchors, target)[0] - _cost(ctrl - e, others, anchors, target)[0]) / (2 * h)
    np.testing.assert_allclose(g, num, rtol=1e-5, atol=1e-6)


def _disc_map():
    maps = OccupancyMaps((Circle((5.0, 0.0), 1.0),), (0.0, -4.0, 10.0, 4.0), 1, 0.1, 0.3, 100.0)
    maps.observe(0, np.array([5.0, 0.0]))
    view = MapView(maps.grids[0].reshape(-1), np.array(maps.shape[::-1], dtype=np.int64), maps.origin, 0.1, 1)
    return maps, view


def test_pairs_point_out_of_the_obstacle_to_its_surface():
    """A straight polygon through a disc (inflated radius 1.3 m): each point inside gets v
    towards the guide path (which passes above or below) and p on the inflated surface."""
    maps, view = _disc_map()
    ctrl = np.column_stack([np.linspace(2.0, 8.0, 16), np.full(16, 0.1)])
    path = maps.search(0, ctrl[3], ctrl[12], 100000)
    idx, p, v = find_pairs(ctrl, 4, 11, path, view.grid, view.counts, view.origin, view.res, view.blocked)
    assert len(idx) >= 4
    for i, pi, vi in zip(idx, p, v):
        assert abs(np.linalg.norm(vi) - 1.0) < 1e-9
        if occupied(view.grid, view.counts, view.origin, view.res, view.blocked, ctrl[i]):
            r = np.linalg.norm(pi - [5.0, 0.0])
            assert 1.25 <= r <= 1.5  # the inflated surface (1.0 + 0.3), within a cell
            assert np.dot(ctrl[i] - pi, vi) < 0  # the point lies behind the surface


def test_rebound_plan_leaves_the_obstacle_and_keeps_off_a_head_on_robot():
    """Rebound optimisation from a straight line through the disc ends collision-free; with a
    robot broadcast flying the same line head-on, the plan stays clear of it at matching times."""
    maps, view = _disc_map()
    w = Weights(1.0, 0.5, 0.1, 0.5, 1.0, 0.5, 1.0, 1.0, 1.5, 0.05)
    ctrl = np.column_stack([np.linspace(0.5, 9.5, 24), np.full(24, 0.05)])
    ctrl[:3] = ctrl[3] - [[1.2, 0], [0.8, 0], [0.4, 0]]
    search = lambda a, b: maps.search(0, a, b, 100000)  # noqa: E731
    none = lambda dt, n: np.zeros((0, n, 2))  # noqa: E731
    out = rebound_optimize(ctrl.copy(), 0.4, w, view, search, none, 20, 200, ctrl[-1].copy())
    assert out.ok and out.pairs > 0
    tau = np.linspace(0, (len(out.ctrl) - 3) * 0.4, 400)
    q = evaluate(out.ctrl, 0.4, tau)[0]
    assert np.min(np.linalg.norm(q - [5.0, 0.0], axis=1)) > 1.3

    # a second robot from the far end along y = -2.5 (clear of the disc), flying towards us
    def head_on(dt, n):
        t = dt * (np.arange(n) - 1.0)
        return np.stack([np.column_stack([9.5 - 1.0 * t, np.full(n, -2.5)])])

    straight = np.column_stack([np.linspace(0.5, 9.5, 24), np.full(24, -2.5)])
    straight[:3] = straight[3] - [[1.2, 0], [0.8, 0], [0.4, 0]]
    out2 = rebound_optimize(straight.copy(), 0.4, w, view, search, head_on, 20, 200, straight[-1].copy())
    assert out2.ok
    t = 0.4 * (np.arange(len(out2.ctrl)) - 1.0)
    other = np.column_stack([9.5 - t, np.full(len(t), -2.5)])
    gap = np.linalg.norm(out2.ctrl[3:] - other[3:], axis=1)
    assert gap.min() >= 0.45  # without the swarm term the lines meet (gap 0); contact is 0.4 m


@pytest.mark.parametrize("dim", [2, 3])
def test_swarm_reaches_the_goal_around_a_pillar_without_contact(dim):
    """Six robots fly around a pillar they learn on the way: every one arrives within 3 m of the
    goal, none touches another (0.4 m) or the pillar (0.2 m); 2-D and the same scene in 3-D."""
    text = PILLAR.format(n=6)
    if dim == 3:
        text = (text.replace("[-6.0, -6.0, 16.0, 6.0]", "[-6.0, -6.0, 0.0, 16.0, 6.0, 4.0]")
                .replace("[-5.0, -2.0, -2.0, 2.0]", "[-5.0, -2.0, 1.5, -2.0, 2.0, 2.5]")
                .replace("[12.0, 0.0]", "[12.0, 0.0, 2.0]")
                .replace('type = "circle"\ncenter = [5.0, 0.0]\nradius = 1.5',
                         'type = "cylinder"\ncenter = [5.0, 0.0]\nradius = 1.5\nz = [0.0, 4.0]'))
    res = swarmnav.run("ego-swarm", loads(text), seed=2, horizon=30.0)
    m = res.metrics
    assert m["sph_success"] == 1.0, m
    assert m["min_inter_robot_distance"] > 0.4 and m["min_robot_obstacle_distance"] > 0.2
    assert m["ego_plans"] >= 6 and np.all(np.isfinite(res.positions))


def test_periodic_world_refused_with_one_line(tmp_path):
    with pytest.raises(swarmnav.ConfigError, match="ego-swarm cannot fly a periodic world"):
        swarmnav.run("ego-swarm", "periodic_box:n=10,rho=1.0", seed=1, steps=5)
    out = run_cli("run", "--method", "ego-swarm", "--scenario", "periodic_box:n=10,rho=1.0", "--steps", "5",
                  "--out", tmp_path / "run")
    assert out.returncode == 2
    assert "ego-swarm cannot fly a periodic world" in out.stderr and "Traceback" not in out.stderr
    assert len(out.stderr.strip().splitlines()) == 1


@pytest.mark.parametrize("key,value", [("dist0", -0.5), ("v_max", 0.0), ("max_rebound", 1000), ("dt", 2.0)])
def test_out_of_range_parameter_refused(key, value):
    with pytest.raises(swarmnav.ConfigError, match=key):
        registry.make("ego-swarm", **{key: value})


def test_forced_failure_is_a_counted_fallback_and_the_run_stays_finite():
    """Every optimisation reported failed: each robot brakes once and hovers; every replan is a
    fallback, the run stays finite, and each broadcast (the brake plans) is counted with its size."""
    res = swarmnav.run("ego-swarm", loads(PILLAR.format(n=4)), seed=1, horizon=3.0, force_fail=True)
    m = res.metrics
    assert np.all(np.isfinite(res.positions)) and np.all(np.isfinite(res.velocities))
    assert m["ego_fallbacks"] == m["ego_plans"] > 4
    assert m["comm_messages"] == m["ego_brakes"] == 4  # one brake each; retries keep it
    assert m["comm_bytes"] == m["comm_messages"] * trajectory_bytes(2)
    assert np.max(np.linalg.norm(res.positions[-1] - res.positions[0], axis=1)) < 0.05


def test_comm_counts_every_committed_plan():
    res = swarmnav.run("ego-swarm", loads(PILLAR.format(n=4)), seed=3, horizon=8.0)
    m = res.metrics
    assert m["comm_messages"] == m["ego_plans"] - m["ego_fallbacks"] + m["ego_brakes"]
    assert m["comm_bytes"] > m["comm_messages"] * trajectory_bytes(6)  # each plan has > 6 control points
    assert m["comm_mbps"] == pytest.approx(m["comm_bytes"] * 8 / 8.0 / 1e6, rel=1e-3)


def test_compiled_lbfgs_agrees_with_scipy(monkeypatch):
    """The compiled L-BFGS and SciPy's L-BFGS-B on the same cost reach collision-free plans of the
    same cost (within 2 %: different line searches stop at slightly different points)."""
    import swarmnav.methods.ego_swarm.optimizer as opt

    maps, view = _disc_map()
    w = Weights(1.0, 0.5, 0.1, 0.5, 1.0, 0.5, 1.0, 1.0, 1.5, 0.05)
    ctrl = np.column_stack([np.linspace(0.5, 9.5, 24), np.full(24, 0.05)])
    ctrl[:3] = ctrl[3] - [[1.2, 0], [0.8, 0], [0.4, 0]]
    search = lambda a, b: maps.search(0, a, b, 100000)  # noqa: E731
    none = lambda dt, n: np.zeros((0, n, 2))  # noqa: E731
    costs = []
    for solver in ("lbfgs", "scipy"):
        monkeypatch.setattr(opt, "SOLVER", solver)
        out = rebound_optimize(ctrl.copy(), 0.4, w, view, search, none, 20, 200, ctrl[-1].copy())
        assert out.ok
        pairs = opt.Pairs(2)
        opt._assign_pairs(out.ctrl, 0.4, pairs, view, search, 0.05)
        g = np.empty_like(out.ctrl)
        costs.append(cost_grad(out.ctrl, 0.4, 1.0, 0.5, 0.1, 0.5, 0.0, 0.5, 1.0, 1.0, 1.5, pairs.idx, pairs.p, pairs.v,
                               np.zeros((0, 24, 2)), np.zeros((0, 2)), 0.5, ctrl[-1], g))
    assert costs[0] == pytest.approx(costs[1], rel=0.02, abs=1e-3)
