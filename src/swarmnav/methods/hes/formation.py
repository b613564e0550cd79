"""Formation references of HES, eq. (23): templates Delta_f, encircle slots, slot assignment."""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np
from scipy.optimize import linear_sum_assignment


@lru_cache(maxsize=64)
def hex_template(m: int) -> np.ndarray:
    """Formation template Delta_f for ``m`` agents (ours; the paper does not give one): the ``m``
    points of a unit-spacing triangular lattice nearest the origin, re-centred so the slots'
    mean is exactly zero (the slots' centroid is then the waypoint c_s), read-only (m, 2)."""
    if m <= 0:
        return np.zeros((0, 2))
    r = int(math.ceil(math.sqrt(m))) + 2
    pts = [(i + 0.5 * j, j * math.sqrt(3) / 2) for i in range(-2 * r, 2 * r + 1) for j in range(-2 * r, 2 * r + 1)]
    pts = np.array(pts)
    key = np.round(np.hypot(pts[:, 0], pts[:, 1]), 9) * 1e3 + np.arctan2(pts[:, 1], pts[:, 0])
    out = pts[np.argsort(key, kind="stable")[:m]]
    out = out - out.mean(axis=0)
    out.setflags(write=False)
    return out


@lru_cache(maxsize=64)
def hex_width(m: int) -> float:
    """Extent [m] of :func:`hex_template` (m) across the formation axis (its y coordinates)."""
    return float(np.ptp(hex_template(m)[:, 1]))


def ring_slots(goal: np.ndarray, radius: float, m: int, free: np.ndarray, angles: np.ndarray) -> np.ndarray:
    """Encircle slots: ``m`` points on the circle of ``radius`` around ``goal``, spread evenly over
    the free sample angles (``free`` (A,) bool over ``angles`` (A,)); all angles if none is free."""
    ok = angles[free] if free.any() else angles
    idx = np.round(np.linspace(0, len(ok), m, endpoint=False)).astype(int) % len(ok)
    if free.all():  # the whole circle: evenly spaced
        a = angles[0] + 2 * math.pi * np.arange(m) / m
    else:
        a = ok[idx]
    return goal[None, :] + radius * np.column_stack([np.cos(a), np.sin(a)])


def assign_slots(x: np.ndarray, slots: np.ndarray) -> np.ndarray:
    """Formation indices r_i: the assignment of agents ``x`` (m, 2) to ``slots`` (m, 2) that
    minimises the summed squared distance (Hungarian); returns the slot index of each agent."""
    cost = np.sum((x[:, None, :] - slots[None, :, :]) ** 2, axis=2)
    rows, cols = linear_sum_assignment(cost)
    out = np.empty(len(x), dtype=np.int64)
    out[rows] = cols
    return out
