"""The shared world: obstacles, scenes, scene files and generators."""

from swarmnav.world.catalog import load_scenario
from swarmnav.world.obstacles import Box, Circle, Geometry, Polygon
from swarmnav.world.scenario import Scenario, Swarm, builtin_names, from_dict, load_file, loads

__all__ = [
    "Box", "Circle", "Geometry", "Polygon", "Scenario", "Swarm",
    "builtin_names", "from_dict", "load_file", "load_scenario", "loads",
]
