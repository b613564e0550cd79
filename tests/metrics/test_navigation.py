"""Metrics of HES Section 5.1 on trajectories whose values are known by hand."""

import numpy as np
import pytest

from swarmnav.metrics import MetricParams, navigation_metrics


def _line_run(K=10):
    # two agents moving along x at 1 m per step from x = 0 towards a goal at (20, 0)
    t = np.arange(K + 1, dtype=float)
    P = np.zeros((K + 1, 2, 2))
    P[:, 0, 0] = t
    P[:, 1, 0] = t
    P[:, 1, 1] = 3.0
    return P


def test_terminal_errors_goal_ratio_and_success():
    P = _line_run()
    goal = np.array([14.0, 0.0])  # final x = 10: errors 4 and 5
    C = np.full((11, 2), 10.0)
    m = navigation_metrics(P, C, goal)
    assert m["E_mean"] == pytest.approx(4.5)
    assert m["sigma_E"] == pytest.approx(0.5)  # population std of {4, 5}
    assert m["E_90"] == pytest.approx(4.9)  # numpy linear percentile of {4, 5}
    assert m["R_goal"] == 1.0 and m["Y"] == 1.0
    m = navigation_metrics(P, C, np.array([14.0, -4.5]))  # errors ~5.66 and ~8.06 -> one in r_succ = 8
    assert m["R_goal"] == 0.5 and m["Y"] == 0.0


def test_clearance_ratios_use_inner_steps_only():
    P = _line_run(K=10)
    C = np.full((11, 2), 5.0)
    C[0] = 0.0  # k = 0 and k = K are excluded by the paper's definition
    C[10] = 0.0
    C[3, 1] = 1.0  # < d_safe
    C[4, 0] = 0.5  # < 0.75
    C[5, 1] = 0.2  # < 0.30
    m = navigation_metrics(P, C, np.array([10.0, 0.0]))
    assert m["R_unsafe"] == pytest.approx(3 / 9)
    assert m["R_below_0_75"] == pytest.approx(2 / 9)
    assert m["R_below_0_30"] == pytest.approx(1 / 9)
    assert m["d_clr_min"] == pytest.approx(0.2)
    # per agent: agent 0 unsafe at k = 4 only, agent 1 at k = 3 and 5 -> (1/9 + 2/9) / 2
    assert m["R_unsafe_agent"] == pytest.approx(1.5 / 9)
    # S_scene = 0.4 Y + 0.3 R_goal + 0.15 (1 - R_unsafe) + 0.15 clip(d_clr_min / 1.5)
    assert m["S_scene"] == pytest.approx(0.4 + 0.3 + 0.15 * (6 / 9) + 0.15 * (0.2 / 1.5))


def test_path_length_and_stretch():
    P = _line_run(K=10)
    m = navigation_metrics(P, np.full((11, 2), 9.0), np.array([10.0, 0.0]))
    assert m["L_mean"] == pytest.approx(9.0)  # sum over k = 1 .. K-1
    # stretch = mean_i L_i / ||p_i(0) - goal|| = mean(9/10, 9/sqrt(109))
    assert m["path_stretch"] == pytest.approx(0.5 * (0.9 + 9 / np.sqrt(109)))


def test_paper_s_scene_matches_with_r_s_equal_d_safe():
    # HES Table 2/3 default corridor means reproduce the published S_scene = 0.885 at r_s = 1.5 m
    s = 0.4 * 1 + 0.3 * 1 + 0.15 * (1 - 0.117) + 0.15 * min(0.523 / MetricParams().r_s, 1)
    assert s == pytest.approx(0.885, abs=0.001)


def test_inter_agent_distance_and_collisions_small_and_large_paths():
    K, N = 6, 3
    P = np.zeros((K + 1, N, 2))
    P[:, 1, 0] = [5, 3, 0.3, 0.3, 3, 0.2, 5]  # agent 1 touches agent 0 twice (0.3 then 0.2)
    P[:, 2, 0] = 50
    C = np.full((K + 1, N), 9.0)
    C[2:4, 2] = 0.1  # agent 2 inside body radius of an obstacle for one episode
    m = navigation_metrics(P, C, np.zeros(2))
    assert m["min_inter_agent_distance"] == pytest.approx(0.2)
    assert m["collisions"] == 3.0
    # the KD-tree path (N > 64) agrees with the dense path
    big = np.concatenate([P, 1000 + 10 * np.arange(70)[None, :, None] * np.ones((K + 1, 70, 2))], axis=1)
    Cb = np.concatenate([C, np.full((K + 1, 70), 9.0)], axis=1)
    mb = navigation_metrics(big, Cb, np.zeros(2))
    assert mb["min_inter_agent_distance"] == pytest.approx(0.2)
    assert mb["collisions"] == 3.0


def test_periodic_path_length_uses_minimum_image():
    P = np.zeros((4, 1, 2))
    P[:, 0, 0] = [9.5, 0.5, 1.5, 2.5]  # wraps across the period 10
    m = navigation_metrics(P, np.full((4, 1), np.inf), np.zeros(2), periodic_box=10.0)
    assert m["L_mean"] == pytest.approx(2.0)
    assert m["R_unsafe"] == 0.0


def _pairs_reference(positions, contact, box):
    """Plain per-step KD-tree: the smallest nearest-neighbour distance and the contact episodes."""
    from scipy.spatial import cKDTree

    best, hits, prev = np.inf, 0, set()
    for P in positions:
        tree = cKDTree(np.mod(P, box) if box else P, boxsize=box)
        best = min(best, float(tree.query(P, k=2)[0][:, 1].min()))
        cur = {tuple(p) for p in tree.query_pairs(contact, output_type="ndarray")}
        hits += len(cur - prev)
        prev = cur
    return best, hits


@pytest.mark.parametrize("n, box, spread", [
    (80, None, 6.0),     # open world, dense
    (120, 5.0, None),    # periodic, many cells
    (70, 0.9, None),     # periodic cell under 3 search cells wide
    (90, None, 400.0),   # two dense clusters 400 m apart: widened cells
    (65, None, 60.0),    # sparse: no contact in the run, wide fallback search
    (60, 300.0, None),   # periodic and sparse: the fallback search across the seam
])
def test_cell_list_pairs_match_kdtree_reference(n, box, spread):
    from swarmnav.metrics._pairs import inter_agent

    rng = np.random.default_rng(n)
    start = rng.uniform(0.0, box or min(spread, 6.0), (n, 2))
    if spread == 400.0:
        start[n // 2:] += spread
    walk = np.cumsum(rng.normal(0.0, 0.05, (40, n, 2)), axis=0)
    positions = start + walk
    if spread == 60.0:
        positions = np.arange(n)[None, :, None] * 3.0 + 0.01 * walk  # agents 3 m apart on a line
    contact = 0.1 if box else 0.4
    best, hits = inter_agent(positions, contact, box)
    ref_best, ref_hits = _pairs_reference(positions, contact, box)
    assert best == pytest.approx(ref_best, rel=1e-12)
    assert hits == ref_hits
    if spread != 60.0 and box != 300.0:
        assert hits > 0  # the case exercises contacts
    else:
        assert hits == 0  # the case exercises the fallback search


def test_coincident_agents_are_a_contact_at_distance_zero():
    from swarmnav.metrics._pairs import inter_agent

    P = np.zeros((3, 70, 2))
    P[:, :, 0] = np.arange(70) * 2.0  # 70 agents 2 m apart on a line ...
    P[1, 1] = P[1, 0]  # ... agent 1 sits on agent 0 at step 1 only
    assert inter_agent(P, 0.4, None) == (0.0, 1)
    assert inter_agent(P, 0.4, 500.0) == (0.0, 1)


def test_per_agent_unsafe_ratio_is_the_plain_mean_and_never_above_the_swarm_ratio():
    rng = np.random.default_rng(7)
    for _ in range(20):
        K, N = int(rng.integers(2, 30)), int(rng.integers(1, 8))
        C = rng.uniform(0.0, 3.0, (K + 1, N))
        m = navigation_metrics(np.zeros((K + 1, N, 2)), C, np.ones(2))
        own = [sum(C[k, i] < 1.5 for k in range(1, K)) / (K - 1) for i in range(N)]  # per-agent loop
        assert m["R_unsafe_agent"] == pytest.approx(sum(own) / N)
        assert m["R_unsafe_agent"] <= m["R_unsafe"] + 1e-12
        if N == 1:
            assert m["R_unsafe_agent"] == pytest.approx(m["R_unsafe"])


@pytest.mark.parametrize("n, dim", [(2, 2), (5, 2), (20, 2), (63, 2), (7, 3), (20, 3)])
def test_all_pairs_pass_matches_the_cell_list_passes_bit_for_bit(n, dim):
    from swarmnav.metrics._pairs import all_pairs_run, close_pairs_run, min_pair_run

    rng = np.random.default_rng(100 * n + dim)
    for trial in range(12):
        spread = [0.5, 2.0, 6.0, 40.0][trial % 4]
        positions = rng.uniform(0.0, spread, (1, n, dim)) + np.cumsum(rng.normal(0.0, 0.05, (30, n, dim)), axis=0)
        if trial % 3 == 0:
            positions[4:9, 1] = positions[4:9, 0]  # coincident agents: a contact at distance 0
        contact = [0.1, 0.4, 1.0][trial % 3]
        best, hits = all_pairs_run(positions, contact)
        ref_best, ref_hits = close_pairs_run(positions, 0.0, contact)
        if not np.isfinite(ref_best):
            ref_best = min_pair_run(positions, 0.0, contact)
        assert best == ref_best  # the same squared distances: the same bits
        assert hits == ref_hits


def test_norms_equal_numpys_norm_bit_for_bit():
    from swarmnav.metrics.navigation import norms

    rng = np.random.default_rng(3)
    for shape in [(50, 7, 2), (9, 2), (40, 5, 3), (6, 1)]:
        a = rng.normal(0.0, 1.0, shape) * 10.0 ** rng.uniform(-8, 8, shape)
        assert np.array_equal(norms(a), np.linalg.norm(a, axis=-1))
