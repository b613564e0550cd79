"""Run metrics: pure functions of recorded trajectories."""

from swarmnav.metrics.navigation import MetricParams, navigation_metrics

__all__ = ["MetricParams", "navigation_metrics"]
