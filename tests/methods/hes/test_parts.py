"""Our extensions as named parts (methods/hes/hooks.py, methods/hes/parts/): which switch builds which part, the step
context they read, split commitment and the width penalty on their own. Passage mode, the stall
planner, trail following, the route hold and the barriers have their own test files."""

from __future__ import annotations

import numpy as np
import pytest

import swarmnav
from swarmnav.methods.base import Observation
from swarmnav.methods.hes import Hes
from swarmnav.methods.hes.corridors import Corridor
from swarmnav.methods.hes.hierarchy import Report, make_pack
from swarmnav.methods.hes.navigate import choose_route
from swarmnav.methods.hes.parts.regulation import width_penalty
from swarmnav.methods.hes.report import sense
from swarmnav.methods.hes.step import Step, SubSwarm
from swarmnav.world import from_dict

ALL = ["commit", "hold", "trail", "passage", "stall", "wall", "guard"]
OPEN = from_dict({"name": "open", "swarm": {"n": 6, "spawn": [-3.0, -3.0, 3.0, 3.0]}, "goal": {"position": [60.0, 0.0]}})


def _parts(**kw) -> list[str]:
    m = Hes(**kw)
    x = np.array([[0.0, 0.0], [1.0, 0.0]])
    m.reset(OPEN, x, np.zeros_like(x), np.random.default_rng(0))
    return [q.name for q in m.parts]


@pytest.mark.parametrize("switch, name", [
    ("commit.on", "commit"), ("hold.on", "hold"), ("trail.on", "trail"), ("passage.on", "passage"),
    ("stall.on", "stall"), ("barrier.on", "wall"), ("guard.on", "guard")])
def test_each_switch_removes_exactly_its_part(switch, name):
    assert _parts() == ALL  # the default build, in hook order
    assert _parts(**{switch: False}) == [q for q in ALL if q != name]
    assert _parts(**{switch: "off"}) == _parts(**{switch: False})  # as --set passes it


@pytest.mark.parametrize("old, new", [
    ("split_commit", "commit.on"), ("route_hold", "hold.on"), ("trail_follow", "trail.on"),
    ("passage_mode", "passage.on"), ("stall_plan", "stall.on"), ("agent_guard", "guard.on")])
def test_the_old_flat_switch_names_still_work(old, new):
    assert _parts(**{old: False}) == _parts(**{new: False})


def test_the_paper_preset_and_the_safety_stack_ablation():
    assert _parts(preset="paper") == ["ring_yield", "wall", "projection"]  # of ours: the safety stack; readings: the ring, the projection
    assert _parts(safety_stack_off=True) == ["commit", "hold", "trail", "passage", "stall"]


def test_the_step_context_holds_every_stage_output():
    m = Hes()
    x = np.array([[0.0, 0.0], [1.5, 0.5], [0.5, 1.5], [-1.0, 1.0], [1.0, -1.5], [-1.5, -0.5]])
    m.reset(OPEN, x, np.zeros_like(x), np.random.default_rng(0))
    a, _ = m.act(Observation(0, 0.0, x, np.zeros_like(x)), np.random.default_rng(0))
    s = m.last_step
    assert s.k == 0 and set(s.reports) == set(m.subs) and s.z is m.last_z
    for name in ("slot", "wp", "cent", "exit_dir"):
        assert getattr(s, name).shape == (6, 2), name
    for name in ("own", "routed", "speed", "dsafe", "nn", "follower", "nav", "exit_free"):
        assert getattr(s, name).shape == (6,), name
    assert s.sig.shape == s.blocked.shape == (6, 4)
    assert np.all(s.dsafe == m.params.paper.d_safe) and np.all(s.own == -1)  # open field: no passage
    assert np.all(np.hypot(*a.T) <= m.params.paper.a_max + 1e-12)


# ---------------------------------------------------------------- split commitment
GATE = Corridor(mid=np.array([10.0, 5.0]), normal=np.array([1.0, 0.0]), width=7.0, target=np.array([13.0, 5.0]),
                cost=55.0)
OTHER = Corridor(mid=np.array([10.0, -5.0]), normal=np.array([1.0, 0.0]), width=7.0, target=np.array([13.0, -5.0]),
                 cost=45.0)


def _choose(k, centroid_x, **kw):
    """The route of a sub-swarm assigned GATE by a split at step 0, its report showing only OTHER
    (cheaper, and GATE out of its view) at step ``k``."""
    m = Hes(**kw)
    x = np.array([[centroid_x + dx, 5.0 + dy] for dx, dy in ((0, 0), (1, 0), (0, 1), (-1, 0))], dtype=float)
    m.reset(OPEN, x, np.zeros_like(x), np.random.default_rng(0))
    sub = SubSwarm(0, 0, x.mean(axis=0), route=GATE)
    m.subs = {0: sub}
    commit = m.part("commit")
    if commit is not None:
        commit.split(0, [0], 0)
    step = Step(k, x, np.zeros_like(x), sense(m, x))
    rep = Report(make_pack(0, 0, np.arange(4), x, np.zeros_like(x)), (OTHER,), 20.0)
    return choose_route(m, step, sub, rep), commit


def test_a_split_corridor_is_kept_until_its_throat_is_passed_or_the_commitment_lapses():
    assert _choose(50, 5.0)[0] is GATE  # 5 s after the split, in front of the throat
    route, commit = _choose(50, 12.0)  # all past the throat: the commitment ends, the choice is free
    assert route is OTHER and not commit.committed(0)
    assert _choose(int(20.0 / 0.1) + 1, 5.0)[0] is OTHER  # commit_time lapsed
    assert _choose(50, 5.0, split_commit=False)[0] is OTHER  # switched off


# ---------------------------------------------------------------- width penalty
def test_width_penalty_is_one_metre_per_agent_at_zero_width_and_none_from_six_metres():
    assert width_penalty(0.0, 10) == 10.0 and width_penalty(3.0, 10) == 5.0
    assert width_penalty(6.0, 10) == width_penalty(20.0, 10) == width_penalty(np.inf, 10) == 0.0


def test_the_width_penalty_switch_routes_by_length_alone():
    narrow = Corridor(mid=np.array([10.0, 0.0]), normal=np.array([1.0, 0.0]), width=2.0, target=np.array([13.0, 0.0]),
                      cost=50.0)
    wide = Corridor(mid=np.array([10.0, 8.0]), normal=np.array([1.0, 0.0]), width=8.0, target=np.array([13.0, 8.0]),
                    cost=52.0)
    wall = from_dict({"name": "wall", "swarm": {"n": 6, "spawn": [-3.0, -3.0, 3.0, 3.0]},
                      "goal": {"position": [60.0, 0.0]},
                      "obstacles": [{"type": "box", "min": [5.0, -3.0], "max": [6.0, 3.0]}]})  # no direct route
    for on, expect in ((True, wide), (False, narrow)):
        m = Hes(width_penalty=on)
        x = np.array([[0.0, 0.0], [1.0, 0.5], [0.0, 1.0], [-1.0, 0.0], [0.5, -1.0], [-0.5, -1.0]])
        m.reset(wall, x, np.zeros_like(x), np.random.default_rng(0))
        sub = m.subs[0]
        step = Step(0, x, np.zeros_like(x), sense(m, x))
        rep = Report(make_pack(0, sub.subleader, np.arange(6), x, np.zeros_like(x)), (narrow, wide), 5.0)
        assert choose_route(m, step, sub, rep) is expect  # 6 agents: +4 m on the 2 m gap


def test_new_switches_on_is_the_default_build():
    a = swarmnav.run("hes", "default_corridor", seed=2, steps=200)
    b = swarmnav.run("hes", "default_corridor", seed=2, steps=200, split_commit=True, route_hold=True,
                     width_penalty=True)
    np.testing.assert_array_equal(a.positions, b.positions)
