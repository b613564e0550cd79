"""HES hierarchy: the partition invariant of eq. (1) at every step of a real run, the Pack,
split / merge execution, and the follower reassignment of eq. (41)."""

import numpy as np
import pytest

from swarmnav.methods import registry
from swarmnav.methods.base import Observation
from swarmnav.methods.hes.hierarchy import check_partition, make_pack, merge_pair, reassign, split_members
from swarmnav.world import load_scenario


def drive(scene="default_corridor", seed=1, steps=400, **params):
    """Step the method by hand (as the rollout does) and yield (k, method, x, info)."""
    scn = load_scenario(scene)
    m = registry.make("hes", **params)
    rng = np.random.default_rng(seed)
    x = scn.spawn_positions(rng)
    v = np.zeros_like(x)
    m.reset(scn, x.copy(), v.copy(), rng)
    for k in range(steps):
        a, info = m.act(Observation(k, k * m.dt, x, v), rng)
        yield k, m, x, info
        x, v = m.dynamics.step(x, v, a, m.dt)


def test_partition_invariant_every_step_of_a_run():
    seen_split = seen_merge = False
    max_s = 1
    for k, m, x, info in drive(steps=400):
        lab = info["labels"]
        subleaders = {s: sub.subleader for s, sub in m.subs.items()}
        check_partition(lab, subleaders, len(x))  # every agent in exactly one sub-swarm, subleaders inside
        assert 0 <= m.leader < len(x)  # one leader (the planner), a member of some sub-swarm
        assert len(set(subleaders.values())) == len(subleaders)  # one subleader per sub-swarm
        # the planner's z(k) reads the reports, which cover every agent exactly once
        members = np.concatenate([r.pack.members for r in m.last_reports.values()])
        assert sorted(members.tolist()) == list(range(len(x)))
        max_s = max(max_s, len(subleaders))
        for ev in info["events"]:
            assert ev["source"] == "rule" and ev["reason"]
            seen_split |= ev["action"] == "split"
            seen_merge |= ev["action"] == "merge"
    assert seen_split and seen_merge and max_s >= 2


def test_pack_is_the_report_of_eq3():
    x = np.arange(12, dtype=float).reshape(6, 2)
    v = -x
    pk = make_pack(3, 4, np.array([1, 4, 5]), x, v)
    np.testing.assert_array_equal(pk.positions, x[[1, 4, 5]])
    np.testing.assert_array_equal(pk.velocities, v[[1, 4, 5]])
    np.testing.assert_allclose(pk.centroid, x[[1, 4, 5]].mean(axis=0))
    np.testing.assert_array_equal(pk.subleader_position, x[4])


def test_check_partition_rejects_broken_partitions():
    check_partition(np.array([0, 0, 2, 2]), {0: 1, 2: 3}, 4)
    with pytest.raises(AssertionError):
        check_partition(np.array([0, 0, 2, 2]), {0: 1, 2: 0}, 4)  # subleader outside its sub-swarm
    with pytest.raises(AssertionError):
        check_partition(np.array([0, 0, 2, 2]), {0: 1}, 4)  # a sub-swarm without subleader


def test_split_members_lateral_order_and_sizes():
    rng = np.random.default_rng(0)
    x = rng.uniform(-3, 3, (20, 2))
    heading = np.array([1.0, 0.0])
    groups = split_members(x, np.arange(20), [np.array([5.0, 4.0]), np.array([5.0, -4.0])], [8.0, 4.0], heading, 4)
    assert sorted(np.concatenate(groups).tolist()) == list(range(20))  # a partition of the members
    assert [len(g) for g in groups] == [13, 7]  # proportional to the widths 8 : 4
    assert x[groups[0], 1].min() >= x[groups[1], 1].max()  # the left group takes the left corridor
    groups = split_members(x, np.arange(20), [np.zeros(2), np.ones(2)], [100.0, 0.1], heading, 4)
    assert min(len(g) for g in groups) == 4  # at least min_size


def test_merge_pair_prefers_close_then_near_goal():
    cents = np.array([[0.0, 0.0], [5.0, 0.0], [40.0, 0.0], [45.0, 9.0]])
    near = np.array([False, False, True, True])
    assert merge_pair(cents, [0, 1, 2, 3], near, 8.0) == (0, 1)
    assert merge_pair(cents, [0, 1, 2, 3], near, 4.0) == (2, 3)


def _two_groups():
    x = np.array([[0.0, 0.0], [0.5, 0.0], [19.0, 0.0], [20.0, 0.0], [19.5, 0.5], [18.5, 0.0]])
    labels = np.array([0, 0, 0, 1, 1, 1])  # agent 2 sits at group 1, agent 0 leads group 0
    sl_pos = x[[0, 3]]
    wps = x[[0, 3]]
    protected = np.array([True, False, False, True, False, False])
    return x, labels, sl_pos, wps, protected


def test_reassignment_moves_the_misplaced_follower():
    x, labels, sl_pos, wps, protected = _two_groups()
    new, moved = reassign(x, labels, [0, 1], sl_pos, wps, protected, np.full(6, -999), 100, 20, 1.0, 0.5, 2.0, 3)
    assert moved.tolist() == [2] and new[2] == 1
    assert np.array_equal(np.delete(new, 2), np.delete(labels, 2))


def test_reassignment_respects_cooldown_protection_and_cap():
    x, labels, sl_pos, wps, protected = _two_groups()
    last = np.full(6, -999)
    last[2] = 90  # moved 10 steps ago, tau_ra = 20 steps
    _, moved = reassign(x, labels, [0, 1], sl_pos, wps, protected, last, 100, 20, 1.0, 0.5, 2.0, 3)
    assert len(moved) == 0
    # put the subleader of group 0 next to group 1: protected, it stays
    x2 = x.copy()
    x2[0] = [19.8, 0.2]
    new, moved = reassign(x2, labels, [0, 1], x2[[0, 3]], x2[[0, 3]], protected, np.full(6, -999), 100, 20, 1.0, 0.5,
                          2.0, 3)
    assert 0 not in moved.tolist() and new[0] == 0
    # many candidates, N_move_max = 1: only the largest improvement moves
    labels3 = np.array([0, 1, 1, 1, 0, 0])  # 4 and 5 sit at group 1 but belong to group 0
    x3 = x.copy()
    x3[4] = [30.0, 0.0]
    _, moved = reassign(x3, labels3, [0, 1], x3[[0, 3]], x3[[0, 3]], protected, np.full(6, -999), 100, 20, 1.0, 0.5,
                        2.0, 1)
    assert len(moved) == 1
