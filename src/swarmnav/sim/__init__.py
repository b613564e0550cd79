"""Simulation core: the rollout loop and its result."""

from swarmnav.sim.result import RunResult
from swarmnav.sim.rollout import run

__all__ = ["RunResult", "run"]
