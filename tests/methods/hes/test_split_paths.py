"""Split paths (n_c of eq. 13) lead toward the target: a wide gap seen behind the swarm is not one."""

from __future__ import annotations

from pathlib import Path

import numpy as np

import swarmnav
from swarmnav.methods.hes.corridors import Corridor
from swarmnav.methods.hes.hierarchy import Pack, Report
from swarmnav.methods.hes.params import HesParams
from swarmnav.methods.hes.report import split_paths
from swarmnav.methods.hes.step import in_view

P = HesParams()
GOAL = np.array([66.0, 0.0])


def _corridor(mid, width, normal=(1.0, 0.0)):
    mid, normal = np.array(mid, float), np.array(normal, float)
    return Corridor(mid=mid, normal=normal, width=width, target=mid + 3 * normal, cost=0.0, direct=False)


def test_a_gap_behind_the_swarm_is_not_a_split_path():
    """The situation traced on hes_gates_4p5m: the swarm threads a gate at x = 26 m; its subleader
    reports the bay ahead (toward gate 3) and the bay it has just crossed, seen back through the
    gate (mouth at x = 19 m). Only the first leads to the goal at (66, 0)."""
    ring = np.full(360, P.paper.lidar_range)  # nothing in view blocks either exit
    pos = np.array([[26.6, -8.2], [28.8, -7.2]])
    pack = Pack(0, 0, np.array([0, 1]), pos, np.zeros_like(pos), pos.mean(axis=0))
    ahead, behind, narrow = _corridor([36.7, 8.0], 7.5), _corridor([19.0, -5.9], 13.2, (0.0, 1.0)), _corridor([35, 0], 3.0)
    paths = split_paths(Report(pack, (ahead, behind, narrow), 5.0), GOAL, ring, P.core.w_split, P.core.rho_vis, P.paper.lidar_range)
    assert paths == [ahead]  # behind: farther from the goal than the swarm; narrow: under w_split


def test_no_split_into_the_bay_behind_on_the_45m_gates():
    """With such splits the swarm turned back through the gate (Y 0 on this seed); without, it
    reaches the goal."""
    r = swarmnav.run("hes", str(Path(__file__).parent / "scenes" / "hes_gates_4p5m.toml"), seed=1, steps=1000)
    assert r.metrics["Y"] == 1.0


def test_a_path_whose_exit_lies_in_an_obstacles_shadow_is_not_a_split_path():
    """hes_gates_4p5m seed 3: from inside a gate's gap the subleader saw a 'corridor' at the
    bottom of the bay whose exit lies behind the gate's own wall, in its LiDAR shadow. A split
    path's exit point must be in view (the ray toward it reaches it)."""
    from swarmnav.sensing import lidar_ring
    from swarmnav.world.obstacles import Box, Geometry

    sensor = np.array([38.95, 8.24])
    ring = lidar_ring(Geometry.from_obstacles([Box((39.6, -10.4), (40.4, 5.9)), Box((-12.0, -11.4), (65.0, -10.4))]),
                      sensor[None], n_rays=P.paper.n_rays, max_range=P.paper.lidar_range)[0]

    def seen(q):
        return in_view(ring, *sensor, np.array(q), P.core.rho_vis, P.paper.lidar_range)

    assert not seen([42.4, -7.5])  # behind the gate's wall
    assert seen([46.5, 2.9])  # over the gate's top, in view
    assert seen([39.0, -7.0])  # down the near side of the wall
