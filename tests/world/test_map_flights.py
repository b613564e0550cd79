"""HES, SPH and APF fly every example map (MovingAI scenario, ROS map, TOML scene with [map],
point cloud) for a few simulated seconds: finite, moving, and toward the goal on the open scenario."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import swarmnav
from swarmnav.world import load_scenario

EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "maps"
SCENES = {
    "scen": f"{EXAMPLES}/warehouse.map.scen#2",
    "ros": f"{EXAMPLES}/office.yaml#start=1:2,goal=24:14",
    "toml": str(EXAMPLES / "warehouse_flight.toml"),
    "cloud": f"{EXAMPLES}/hall.ply#start=1:3:1.2,goal=7:3:1.2",
}


@pytest.mark.parametrize("method", ["hes", "sph", "apf"])
@pytest.mark.parametrize("which", sorted(SCENES))
def test_methods_fly_example_maps(method, which):
    scn = load_scenario(SCENES[which])
    res = swarmnav.run(method, scn, seed=3, horizon=3.0)
    p = res.positions
    assert np.isfinite(p).all() and np.isfinite(res.velocities).all()
    moved = np.linalg.norm(p[-1] - p[0], axis=1)
    assert moved.mean() > 0.3, moved
    # closer to the goal than at the start, on average
    g = np.asarray(scn.goal)
    assert np.linalg.norm(p[-1] - g, axis=1).mean() < np.linalg.norm(p[0] - g, axis=1).mean()
