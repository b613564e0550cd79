"""Per-robot goals for planners that give each robot its own goal (EGO-Swarm, MADER): the
scene gives the swarm one goal point; each robot gets a slot in a disc around it."""

from __future__ import annotations

import math

import numpy as np
from scipy.optimize import linear_sum_assignment


def goal_slots(goal: np.ndarray, spawn: np.ndarray, radius: float) -> np.ndarray:
    """Per-robot goals: ``n`` points filling a disc of ``radius`` around ``goal`` (a sunflower
    spiral in the horizontal plane), assigned to the robots so that the sum of squared distances
    between spawn offsets and goal offsets is least (EGO-Swarm gives each drone its own goal)."""
    n, dim = spawn.shape
    k = np.arange(n)
    r = radius * np.sqrt((k + 0.5) / n)
    th = k * math.pi * (3.0 - math.sqrt(5.0))
    off = np.zeros((n, dim))
    off[:, 0], off[:, 1] = r * np.cos(th), r * np.sin(th)
    rel = spawn - spawn.mean(axis=0)
    scale = radius / max(float(np.max(np.linalg.norm(rel[:, :2], axis=1))), 1e-9)
    cost = np.sum((rel[:, None, :] * scale - off[None, :, :]) ** 2, axis=2)
    rows, cols = linear_sum_assignment(cost)
    out = np.empty((n, dim))
    out[rows] = goal + off[cols]
    return out
