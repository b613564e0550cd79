"""HES Section 3: task-mode hysteresis (eq. 12), feasibility (eq. 13, 16), the projection
Pi_feas (eq. 22) as a truth table and as a property over arbitrary proposals, the rule policy."""

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from swarmnav.methods.hes.decision import (
    A_STR,
    ENCIRCLE,
    NAVIGATE,
    DecisionState,
    RulePolicy,
    merge_feasible,
    project,
    split_feasible,
    target_proximity,
    task_mode,
)


def z(**kw):
    base = dict(k=0, dt=0.1, S=1, n_c=0, w_max=0.0, w_min=0.0, d_goal_avg=50.0, n_near=0,
                d_swarm_min=math.inf, can_split=False, can_merge=False)
    base.update(kw)
    return DecisionState(**base)


def test_task_mode_hysteresis_eq12():
    assert target_proximity(9.0, 7.5) == 7.5
    assert task_mode(NAVIGATE, 7.9, 8.0, 11.0) == ENCIRCLE
    assert task_mode(ENCIRCLE, 9.0, 8.0, 11.0) == ENCIRCLE  # in the band: keep
    assert task_mode(NAVIGATE, 9.0, 8.0, 11.0) == NAVIGATE
    assert task_mode(ENCIRCLE, 11.0, 8.0, 11.0) == NAVIGATE  # >= r_out: navigate


@pytest.mark.parametrize("S, n_c, k, k_last, d, expect", [
    (1, 2, 100, None, 50.0, True),
    (2, 2, 100, None, 50.0, False),  # only a single swarm splits
    (1, 1, 100, None, 50.0, False),  # needs two paths
    (1, 3, 100, 50, 50.0, False),  # cooldown: 50 steps < T_cd = 100 steps
    (1, 3, 150, 50, 50.0, True),  # exactly T_cd later
    (1, 3, 150, 50, 11.9, False),  # within r_merge of the goal
    (1, 3, 150, 50, 12.0, True),
])
def test_split_feasibility_eq13(S, n_c, k, k_last, d, expect):
    assert split_feasible(S, n_c, k, k_last, 100, d, 12.0) is expect


@pytest.mark.parametrize("S, n_near, d_min, expect", [
    (1, 1, math.inf, False),
    (2, 2, 30.0, True),  # two near the goal
    (2, 1, 7.9, True),  # close together
    (2, 1, 8.0, False),
    (3, 0, 20.0, False),
])
def test_merge_feasibility_eq16(S, n_near, d_min, expect):
    assert merge_feasible(S, n_near, d_min, 8.0) is expect


@pytest.mark.parametrize("action, can_split, can_merge, executed", [
    ("split", True, False, "split"), ("split", False, True, "keep"),
    ("merge", False, True, "merge"), ("merge", True, False, "keep"),
    ("keep", True, True, "keep"), ("explode", True, True, "keep"), ("", True, True, "keep"),
])
def test_projection_truth_table_eq22(action, can_split, can_merge, executed):
    assert project(action, z(can_split=can_split, can_merge=can_merge)) == executed


@given(action=st.one_of(st.sampled_from(A_STR), st.text(max_size=12)),
       S=st.integers(1, 4), n_c=st.integers(0, 4), n_near=st.integers(0, 4),
       d_min=st.floats(0.0, 100.0), k=st.integers(0, 2000), k_last=st.one_of(st.none(), st.integers(0, 2000)),
       d_goal=st.floats(0.0, 100.0))
def test_projected_action_is_always_executable(action, S, n_c, n_near, d_min, k, k_last, d_goal):
    n_near = min(n_near, S)
    d_min = d_min if S >= 2 else math.inf
    cs = split_feasible(S, n_c, k, k_last, 100, d_goal, 12.0)
    cm = merge_feasible(S, n_near, d_min, 8.0)
    state = z(k=k, S=S, n_c=n_c, n_near=n_near, d_swarm_min=d_min, can_split=cs, can_merge=cm)
    out = project(action, state)
    assert out in A_STR
    assert out != "split" or cs
    assert out != "merge" or cm
    if action in A_STR and (action == "keep" or (action == "split" and cs) or (action == "merge" and cm)):
        assert out == action  # a feasible proposal is executed unchanged


def test_to_dict_has_the_prompt_fields():
    d = z(n_c=2, n_near=1).to_dict()
    for key in ("can_split", "path_count", "avg_goal_distance", "can_merge", "near_goal_subswarms", "w_max",
                "w_min", "n_near", "d_swarm_min", "S", "k", "dt"):
        assert key in d
    assert d["path_count"] == 2 and d["near_goal_subswarms"] == d["n_near"] == 1


def test_rule_policy():
    r = RulePolicy(d_merge=8.0, cooldown_s=10.0)
    assert r.propose(z(can_split=True, n_c=2), 0).action == "split"
    assert r.propose(z(k=1, S=2, can_merge=True, n_near=2, d_swarm_min=5.0), 1).action == "merge"
    # close, but the split's corridors are still there and the split was 0.1 s ago: keep
    r = RulePolicy(d_merge=8.0, cooldown_s=10.0)
    r.propose(z(k=0, S=1), 0)
    assert r.propose(z(k=1, S=2, can_merge=True, d_swarm_min=5.0, n_c=2), 1).action == "keep"
    assert r.propose(z(k=50, S=2, can_merge=True, d_swarm_min=5.0, n_c=1), 50).action == "keep"  # 4.9 s
    p = r.propose(z(k=101, S=2, can_merge=True, d_swarm_min=5.0, n_c=1), 101)
    assert (p.action, p.source) == ("merge", "rule")
    assert r.propose(z(k=200, S=1), 200).action == "keep"


def test_rule_policy_as_the_paper_writes_it_merges_whenever_feasible():
    # merge_rule = paper: eq. (16) alone, even 0.1 s after the split and with both corridors in view
    r = RulePolicy(d_merge=8.0, cooldown_s=10.0, merge="paper")
    r.propose(z(k=0, S=1), 0)
    p = r.propose(z(k=1, S=2, can_merge=True, d_swarm_min=5.0, n_c=2), 1)
    assert (p.action, p.source) == ("merge", "rule")
    assert r.propose(z(k=2, S=2, can_merge=False, d_swarm_min=9.0, n_c=2), 2).action == "keep"
    assert r.propose(z(k=3, S=1, can_split=True, n_c=2), 3).action == "split"
    # paper_cooldown: the same merge waits T_cd (10 s) after the last change of S
    r = RulePolicy(d_merge=8.0, cooldown_s=10.0, merge="paper_cooldown")
    r.propose(z(k=0, S=1), 0)
    assert r.propose(z(k=1, S=2, can_merge=True, d_swarm_min=5.0, n_c=2), 1).action == "keep"
    assert r.propose(z(k=99, S=2, can_merge=True, n_near=2, d_swarm_min=5.0), 99).action == "keep"
    assert r.propose(z(k=101, S=2, can_merge=True, d_swarm_min=5.0, n_c=2), 101).action == "merge"
