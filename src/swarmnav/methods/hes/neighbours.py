"""Neighbour rows for the HES pair kernels: for each agent, the agents that may lie within a
kernel's reach, as CSR rows (``ptr``, ``idx``), from a cell list above ``ROWS_ALL_BELOW`` agents
and every agent below. Kernels visit partners in ascending index either way, so the result is
the all-pairs one, bit for bit."""

from __future__ import annotations

import functools
import math

import numpy as np
from numba import njit

from swarmnav.sensing.cells import neighbour_csr


@njit(cache=True)
def all_rows(n):
    """Neighbour rows (see :func:`neighbour_rows`) that list every agent for every agent."""
    ptr = np.arange(n + 1) * n
    idx = np.empty(n * n, dtype=np.int64)
    for i in range(n):
        for j in range(n):
            idx[i * n + j] = j
    return ptr, idx


@njit(cache=True)
def _sorted_rows(start, end, indices):
    """The rows ``indices[start[i]:end[i]]`` of a symmetric neighbour relation (j in i's row iff
    i in j's: one distance test decides both), each in ascending order, in O(entries): the
    transpose, filled by visiting i in ascending order, lists row j's members ascending."""
    n = start.shape[0]
    ptr = np.zeros(n + 1, dtype=np.int64)
    for i in range(n):
        for t in range(start[i], end[i]):
            ptr[indices[t] + 1] += 1
    for j in range(n):
        ptr[j + 1] += ptr[j]
    fill = ptr[:n].copy()
    idx = np.empty(ptr[n], dtype=np.int64)
    for i in range(n):
        for t in range(start[i], end[i]):
            j = indices[t]
            idx[fill[j]] = i
            fill[j] += 1
    return ptr, idx


@functools.lru_cache(maxsize=16)
def _every_row(n: int) -> tuple[np.ndarray, np.ndarray]:
    """:func:`all_rows` of ``n`` agents, built once (the kernels only read the rows)."""
    return all_rows(n)


ROWS_ALL_BELOW = 64  # agents: below this, every neighbour row lists every agent (a cell list does not pay)


def neighbour_rows(x: np.ndarray, radius, all_below: int = ROWS_ALL_BELOW) -> tuple[np.ndarray, np.ndarray]:
    """Every agent's candidate neighbours for the pair kernels: agent i's are
    ``idx[ptr[i]:ptr[i + 1]]``, ascending, itself included, and hold every agent within
    ``radius`` [m] of it (a cell list, ``sensing.neighbour_csr``). Below ``all_below`` agents
    every row lists every agent (a cell list does not pay there). The kernels visit partners in
    ascending index either way, so a kernel whose partners beyond ``radius`` add nothing gives
    the same result, bit for bit, as over all pairs. ``radius`` may be a function returning it,
    called only when a cell list is built."""
    n = len(x)
    if n < all_below:
        return _every_row(n)
    radius = radius() if callable(radius) else radius
    if not math.isfinite(radius):
        return all_rows(n)
    cap = 32 * n
    while True:
        indices, dist2 = np.empty(cap, dtype=np.int64), np.empty(cap)
        _, start, end, total = neighbour_csr(x, float(radius), 0.0, False, indices, dist2, -1.0)
        if total <= cap:
            return _sorted_rows(start, end, indices)
        cap = total
