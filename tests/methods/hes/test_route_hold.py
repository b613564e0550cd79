"""The throat hold (``routes.RouteHold``) (docs/methods/hes.md, "Route hold"): a throat is held
for members still in front of it, in line with the gap, not for a member stuck elsewhere."""

from __future__ import annotations

import numpy as np

import swarmnav
from swarmnav.methods.hes import Hes
from swarmnav.methods.hes.corridors import Corridor
from swarmnav.methods.hes.hierarchy import Report, make_pack
from swarmnav.methods.hes.navigate import choose_route
from swarmnav.methods.hes.report import sense
from swarmnav.methods.hes.step import Step, SubSwarm

# dense_cross_blocks: the 9 m gap between cross 2 (x = 39) and the top wall, exit +x
GAP = Corridor(mid=np.array([38.5, 5.9]), normal=np.array([1.0, 0.0]), width=9.0,
               target=np.array([41.5, 5.9]), cost=40.0)
# the next corridor, down between cross 2 and cross 3
NEXT = Corridor(mid=np.array([45.0, 1.5]), normal=np.array([0.7071, -0.7071]), width=8.6,
                target=np.array([47.1, -0.6]), cost=32.0)
HEAD = [[42.0, 6.0], [43.0, 7.0], [44.0, 6.0], [43.0, 5.0], [42.5, 8.0]]  # through the gap


def _route(last):
    """The route chosen for a sub-swarm of the five head members and ``last``, whose previous
    route is GAP (first member through it at step 100, now step 110)."""
    m = Hes()
    x = np.array(HEAD + [last], dtype=float)
    m.reset(swarmnav.load_scenario("dense_cross_blocks"), x, np.zeros_like(x), np.random.default_rng(0))
    step = Step(110, x, np.zeros_like(x), sense(m, x))
    sub = SubSwarm(0, 1, x.mean(axis=0), route=GAP)
    m.subs = {0: sub}
    m.part("hold").since[0] = 100
    rep = Report(make_pack(0, 1, np.arange(len(x)), x, np.zeros_like(x)), (NEXT,), float(step.ring.min()))
    return choose_route(m, step, sub, rep)


def test_a_member_in_front_of_the_gap_holds_it():
    assert _route([36.5, 6.0]) is GAP  # 2 m before the throat, in line with it


def test_a_member_stuck_beside_the_gap_does_not_hold_it():
    """The member below cross 2's bar (10 m across the gap's centre line, beyond the wall) is
    not queued for this gap: holding the route for it for 15 s led the rest of the sub-swarm
    along the old exit direction into the closed pocket left of cross 3 (seeds 16, 26)."""
    assert _route([37.0, -4.0]) is NEXT


def test_route_hold_off_moves_on_at_once():
    """route_hold=false: the next corridor is chosen even with a member in front of the gap."""
    m = Hes(route_hold=False)
    x = np.array(HEAD + [[36.5, 6.0]], dtype=float)
    m.reset(swarmnav.load_scenario("dense_cross_blocks"), x, np.zeros_like(x), np.random.default_rng(0))
    assert m.part("hold") is None
    step = Step(110, x, np.zeros_like(x), sense(m, x))
    sub = SubSwarm(0, 1, x.mean(axis=0), route=GAP)
    m.subs = {0: sub}
    rep = Report(make_pack(0, 1, np.arange(len(x)), x, np.zeros_like(x)), (NEXT,), float(step.ring.min()))
    assert choose_route(m, step, sub, rep) is NEXT
