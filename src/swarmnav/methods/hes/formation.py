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


def assign_slots(x: np.ndarray, slots: np.ndarray, exact: int = 64) -> np.ndarray:
    """Formation indices r_i: the slot index of each agent ``x`` (m, 2) among ``slots`` (m, 2).

    Up to ``exact`` agents: the assignment that minimises the summed squared distance
    (Hungarian, O(m^3)). Above (ours: a 500-agent Hungarian took 0.1-0.3 s, more than the
    rest of a step for all agents), a banded sort in O(m log m): agents and slots are cut into
    the same ceil(sqrt(m)) bands of equal count along the slots' longer extent, and paired in
    order across it within each band; groups keep their relative order, so paths do not cross
    on the large scale, but the sum is not minimal."""
    m = len(x)
    if m > exact:
        ext = np.ptp(slots, axis=0)
        a, b = (0, 1) if ext[0] >= ext[1] else (1, 0)
        bands = np.array_split(np.arange(m), int(math.ceil(math.sqrt(m))))
        xo = np.argsort(x[:, a], kind="stable")
        so = np.argsort(slots[:, a], kind="stable")
        out = np.empty(m, dtype=np.int64)
        for band in bands:
            xa, sa = xo[band], so[band]
            out[xa[np.argsort(x[xa, b], kind="stable")]] = sa[np.argsort(slots[sa, b], kind="stable")]
        return out
    cost = np.sum((x[:, None, :] - slots[None, :, :]) ** 2, axis=2)
    rows, cols = linear_sum_assignment(cost)
    out = np.empty(len(x), dtype=np.int64)
    out[rows] = cols
    return out
