"""Yielding in narrow places (ours, not in the paper): a queue instead of two robots abreast.

Where a corridor is narrower than two robots abreast outside the obstacle band (2 d_thr + 2 body
radii = 1.4 m), the environment forces of the two sides press any two robots that enter it side by
side together (docs/methods/sph.md, *Why the densest forests fall short*). The paper's swarm has no
rule for who goes first. This part gives one: of two visible robots closer than ``yield_range``,
one of them within ``yield_clearance`` of an obstacle, the one farther from its goal yields: its
reference clock slows as the gap to the other shrinks and stops at ``yield_range / 2``, so the
robot nearer its goal passes first. "Nearer the goal" is a strict order (ties by index), so no two
robots wait for each other and the robot nearest its goal never waits.
"""

from __future__ import annotations

import numpy as np


def yield_rates(x: np.ndarray, goals: np.ndarray, clearance: np.ndarray, vi: np.ndarray, vj: np.ndarray,
                yield_range: float, yield_clearance: float) -> np.ndarray:
    """Reference clock rate ``phi_i`` in [0, 1] of every robot (1: not yielding).

    Args:
        x: (N, d) positions [m].
        goals: (N, d) each robot's goal [m].
        clearance: (N,) distance of each robot to the nearest obstacle (ESDF) [m].
        vi, vj: the visible pairs (i < j), as index arrays.
        yield_range: a robot yields to a robot nearer its goal closer than this [m]; the clock
            runs at ``clip(2 r / yield_range - 1, 0, 1)`` at distance r (stops at yield_range / 2).
        yield_clearance: only pairs with a robot closer than this to an obstacle yield [m].

    Returns:
        (N,) clock rates.
    """
    n = x.shape[0]
    phi = np.ones(n)
    if yield_range <= 0 or len(vi) == 0:
        return phi
    r = np.linalg.norm(x[vi] - x[vj], axis=1)
    narrow = (r < yield_range) & (np.minimum(clearance[vi], clearance[vj]) < yield_clearance)
    if not narrow.any():
        return phi
    a, b, r = vi[narrow], vj[narrow], r[narrow]
    to_goal = np.linalg.norm(goals - x, axis=1)
    # the robot farther from its goal waits (ties: the larger index), a strict order
    a_waits = (to_goal[a] > to_goal[b]) | ((to_goal[a] == to_goal[b]) & (a > b))
    waiter = np.where(a_waits, a, b)
    np.minimum.at(phi, waiter, np.clip(2.0 * r / yield_range - 1.0, 0.0, 1.0))
    return phi
