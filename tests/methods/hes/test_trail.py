"""Trail following (ours, ``trail_follow``; docs/methods/hes.md "Held-out stalls on
dense_cross_blocks"): a member cut off from its sub-swarm retraces its teammates' trail instead
of pulling at its slot through the wall."""

from __future__ import annotations

import numpy as np

import swarmnav
from swarmnav.methods.base import Observation
from swarmnav.methods.hes import Hes
from swarmnav.methods.hes.corridors import newest_visible
from swarmnav.sensing import lidar_ring, ray_table
from swarmnav.world import from_dict

GOAL = np.array([30.0, 8.0])
# a cup open toward -x (away from the goal): inner space x 2..6, y -3..3
CUP = from_dict({"name": "cup", "swarm": {"n": 8, "spawn": [-3.0, -3.0, 3.0, 3.0]}, "goal": {"position": GOAL.tolist()},
                 "obstacles": [{"type": "box", "min": [6.0, -3.0], "max": [7.0, 3.0]},
                               {"type": "box", "min": [2.0, 3.0], "max": [7.0, 4.0]},
                               {"type": "box", "min": [2.0, -4.0], "max": [7.0, -3.0]}]})
IN_CUP = np.array([4.5, 0.0])
# the way the others flew: along y = 0 toward the cup's mouth, up past its top arm, on to the goal
PATH = np.vstack([np.column_stack([np.linspace(-8.0, -3.0, 6), np.zeros(6)]),
                  np.column_stack([np.full(8, -3.0), np.linspace(1.0, 8.0, 8)]),
                  np.column_stack([np.linspace(-2.0, 20.0, 23), np.full(23, 8.0)])])


def test_newest_visible_is_the_latest_trail_point_in_straight_reach():
    cos, sin = ray_table(360)
    ring = lidar_ring(CUP.geometry, IN_CUP[None, :], 360, 20.0)[0]
    trail = np.zeros((len(PATH), 2, 2))
    trail[:, 0] = PATH
    trail[:, 1] = IN_CUP  # agent 1 is not a teammate here
    t, j = newest_visible(ring, IN_CUP[0], IN_CUP[1], cos, sin, trail, len(PATH), np.array([0]), 0.4, 10.0, 20.0)
    assert j == 0 and PATH[t, 0] == -3.0 and 4.0 <= PATH[t, 1] <= 6.0  # up the mouth side, short of the arm's shadow
    # nothing in reach
    assert newest_visible(ring, IN_CUP[0], IN_CUP[1], cos, sin, trail, len(PATH), np.array([0]), 0.4, 3.0, 20.0) == (-1, -1)


def _fly(steps, **kw):
    """Seven members on the encircle ring at the goal, one left in the cup (26 m away, the cup's
    back wall between it and all of them); the trail of the others is the PATH."""
    m = Hes(**kw)
    ang = np.linspace(0, 2 * np.pi, 7, endpoint=False)
    x = np.vstack([GOAL + 6.0 * np.column_stack([np.cos(ang), np.sin(ang)]), IN_CUP])
    v = np.zeros_like(x)
    rng = np.random.default_rng(0)
    m.reset(CUP, x.copy(), v.copy(), rng)
    trail = m.part("trail")  # None when switched off
    for p in PATH:
        if trail is not None:
            trail.record(np.vstack([np.tile(p, (7, 1)), IN_CUP]))
    for k in range(steps):
        a, _ = m.act(Observation(k, k * m.dt, x, v), rng)
        x, v = m.dynamics.step(x, v, a, m.dt)
    return x


def test_a_member_left_in_a_cup_retraces_the_trail_to_the_swarm():
    """Eqs. (24)/(27)/(29) pull it at the back wall (attenuated by eq. (30), still enough to pin it
    against the LiDAR repulsion): without the trail it stays in the cup."""
    stuck = _fly(400, trail_follow=False)
    assert np.all(np.abs(stuck[7] - [4.0, 0.0]) <= [2.0, 3.0])  # still inside
    out = _fly(400)
    assert np.hypot(*(out[7] - GOAL)) <= 8.0  # r_succ: it reached the goal with the others
    assert np.all(np.hypot(*(out[:7] - GOAL).T) <= 8.0)


def test_no_member_cut_off_no_change():
    a = swarmnav.run("hes", "default_corridor", seed=1, steps=300)
    b = swarmnav.run("hes", "default_corridor", seed=1, steps=300, trail_follow=False)
    np.testing.assert_array_equal(a.positions, b.positions)
