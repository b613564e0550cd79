"""swarmnav: simulate, compare and reproduce multi-UAV swarm navigation in cluttered worlds.

Public API::

    import swarmnav
    scn = swarmnav.load_scenario("default_corridor")
    ring = swarmnav.lidar_scan(scn, positions, n_rays=360, max_range=20.0)
    res = swarmnav.run("apf", scn, seed=1, steps=1000)
    res.metrics["Y"], res.positions.shape
"""

from __future__ import annotations

from swarmnav import portable

portable.apply()  # before NumPy, OpenBLAS and numba load: docs/determinism.md

import numpy as np  # noqa: E402

from swarmnav._version import __version__
from swarmnav.errors import ConfigError, ScenarioError, SwarmnavError
from swarmnav.sim import RunResult, run
from swarmnav.world import Scenario, load_scenario


def lidar_scan(scenario: Scenario | str, positions, n_rays: int = 360, max_range: float = 20.0) -> np.ndarray:
    """Fused LiDAR ring of every agent, HES Section 2.4.

    Args:
        scenario: a Scenario or anything :func:`load_scenario` accepts.
        positions: (N, 2) sensor positions [m].
        n_rays: rays per ring; ray r points at angle 2*pi*r/n_rays from +x, counter-clockwise.
        max_range: LiDAR range R_L [m].

    Returns:
        (N, n_rays) distance [m] to the first obstacle boundary along each ray, ``max_range``
        where nothing is within range, 0 for a sensor inside an obstacle.
    """
    from swarmnav.sensing import lidar_ring

    scn = scenario if isinstance(scenario, Scenario) else load_scenario(scenario)
    pts = np.ascontiguousarray(np.asarray(positions, dtype=np.float64).reshape(-1, 2))
    return lidar_ring(scn.geometry, pts, int(n_rays), float(max_range))


__all__ = [
    "ConfigError", "RunResult", "Scenario", "ScenarioError", "SwarmnavError",
    "__version__", "lidar_scan", "load_scenario", "run",
]
