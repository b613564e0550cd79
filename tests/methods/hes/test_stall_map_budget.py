"""The HES stall planner maps what the LiDAR rings saw over the box round start and goal: a box
too large for that map at ``stall.cell`` is refused at reset (ConfigError, one line giving the
size and the limit ``stall.max_map_bytes``) instead of a MemoryError once the planner engages."""


import numpy as np
import pytest
from _helpers.cli import run_cli

from swarmnav.errors import ConfigError
from swarmnav.methods import registry
from swarmnav.methods.hes.parts.stall import BYTES_PER_CELL
from swarmnav.world import from_dict

FAR = {"name": "far", "world": {"bounds": [-1e6, -1e6, 1e6, 1e6]}, "swarm": {"n": 4, "spawn": [0.0, 0.0, 4.0, 4.0]},
       "goal": {"position": [900_000.0, 2.0]}}
X = np.array([[0.0, 0.0], [4.0, 0.0], [0.0, 4.0], [4.0, 4.0]])  # the swarm, its box [0, 4]^2 m


def _reset(scn, **params):
    m = registry.make("hes", **params)
    m.reset(scn, X, np.zeros_like(X), np.random.default_rng(0))
    return m


def test_a_goal_900_km_away_is_refused_unless_the_planner_is_off():
    with pytest.raises(ConfigError) as e:
        _reset(from_dict(FAR))
    assert str(e.value) == ("hes: the stall planner's map of the 900040 m x 44 m box round start and goal at 0.2 m "
                            "cells needs 166 GiB of maps (limit 2 GiB: stall.max_map_bytes); use a coarser "
                            "stall.cell, a nearer goal or stall.on=false")
    assert _reset(from_dict(FAR), **{"stall.on": False}).part("stall") is None


def test_the_count_is_the_map_and_the_limit_is_exact():
    scn = from_dict({**FAR, "goal": {"position": [100.0, 2.0]}})
    m = _reset(scn)
    occ = m.part("stall").occ
    assert occ.shape == (round(44 / 0.2), round(140 / 0.2))  # [-20, 24] x [-20, 120] m: start, goal, margin
    need = occ.size * BYTES_PER_CELL
    _reset(scn, **{"stall.max_map_bytes": need})
    with pytest.raises(ConfigError, match=r"needs 26.4 MiB of maps \(limit 26.4 MiB: stall.max_map_bytes\)"):
        _reset(scn, **{"stall.max_map_bytes": need - 1})
    assert _reset(scn, **{"stall.cell": 0.4}).part("stall").occ.size == occ.size // 4  # a coarser map fits 4x


def test_cli_far_goal_is_one_line_exit_2(tmp_path):
    f = tmp_path / "far.toml"
    f.write_text("[world]\nbounds = [-1000000.0, -1000000.0, 1000000.0, 1000000.0]\n[swarm]\nn = 4\n"
                 "spawn = [0.0, 0.0, 4.0, 4.0]\n[goal]\nposition = [900000.0, 2.0]\n")
    p = run_cli("run", "--method", "hes", "--scenario-file", f, "--steps", "2", "--out", tmp_path / "o")
    assert p.returncode == 2 and "Traceback" not in p.stderr, p.stderr
    lines = p.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("swarmnav: error: hes: the stall planner's map of the ")
    assert "of maps (limit 2 GiB: stall.max_map_bytes)" in lines[0]
