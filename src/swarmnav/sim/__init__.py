"""Simulation core: the rollout loop and its result."""

from swarmnav.sim.result import Plans, RunResult
from swarmnav.sim.rollout import run

__all__ = ["Plans", "RunResult", "run"]
