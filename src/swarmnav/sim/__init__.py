"""Simulation core: the rollout loop and its result, and a run between steps (``Flight``)."""

from swarmnav.sim.flight import Flight
from swarmnav.sim.result import Plans, RunResult
from swarmnav.sim.rollout import run

__all__ = ["Flight", "Plans", "RunResult", "run"]
