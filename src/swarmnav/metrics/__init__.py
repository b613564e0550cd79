"""Run metrics: pure functions of recorded trajectories."""

from swarmnav.metrics.navigation import MetricParams, goal_reached, navigation_metrics

__all__ = ["MetricParams", "goal_reached", "navigation_metrics"]
