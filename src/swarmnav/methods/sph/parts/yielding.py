"""Yielding in narrow places (ours, not in the paper): a queue instead of two robots abreast.

Where a corridor is narrower than two robots abreast outside the obstacle band (2 d_thr + 2 body
radii = 1.4 m), the environment forces of the two sides press any two robots that enter it side by
side together (docs/methods/sph.md, *Why the densest forests fall short*). The paper's swarm has no
rule for who goes first. This part gives one: of two visible robots closer than ``yield_range``,
one of them within ``yield_clearance`` of an obstacle, the one with the longer way to the goal
yields: its reference clock slows as the gap to the other shrinks and stops at ``yield_range / 2``,
so the robot ahead passes first.

"The longer way" is the path length to the goal through free space (:func:`goal_distance_field`),
not the straight-line distance: on a detour that runs sideways the straight line ranks a robot
behind another as ahead of it, and the one in front would wait for the one that runs into it.
It is one field for the whole swarm, so the order is strict (ties by index): no two robots wait
for each other and the robot nearest the goal never waits.
"""

from __future__ import annotations

import itertools

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra

from swarmnav.errors import ConfigError
from swarmnav.sensing.esdf import Esdf


def goal_distance_field(esdf: Esdf, goal: np.ndarray, clearance: float, resolution: float) -> Esdf:
    """Shortest path length [m] from every grid node to ``goal`` through nodes more than
    ``clearance`` [m] from any obstacle (8- or 26-connected Dijkstra on the ESDF nodes, taken every
    ``resolution`` metres), as a field with the ESDF's interpolation; +inf where the goal cannot be
    reached."""
    step = max(1, int(round(resolution / esdf.resolution)))
    sl = (slice(None, None, step),) * esdf.dim
    free = esdf.values[sl] > clearance
    if not free.any():
        raise ConfigError(f"sph: no node of the map is farther than inflation = {clearance:g} m from every obstacle, "
                          "so the yielding order has no free space to measure the way to the goal in; lower "
                          "inflation (or set yield_range = 0)")
    h = esdf.resolution * step
    shape = free.shape
    idx = np.arange(free.size).reshape(shape)
    rows, cols, lens = [], [], []
    for off in itertools.product((-1, 0, 1), repeat=esdf.dim):
        if not any(off) or off < (0,) * esdf.dim:  # each undirected edge once
            continue
        src = tuple(slice(max(0, -o), n - max(0, o)) for o, n in zip(off, shape))
        dst = tuple(slice(max(0, o), n - max(0, -o)) for o, n in zip(off, shape))
        ok = free[src] & free[dst]
        rows.append(idx[src][ok])
        cols.append(idx[dst][ok])
        lens.append(np.full(int(ok.sum()), h * float(np.sqrt(np.count_nonzero(off)))))
    r, c, w = np.concatenate(rows), np.concatenate(cols), np.concatenate(lens)
    graph = coo_matrix((w, (r, c)), shape=(free.size, free.size)).tocsr()
    # source: the free node nearest the goal (the goal itself may sit in the band of an obstacle)
    nodes = np.stack(np.nonzero(free), axis=1)[:, ::-1] * h + esdf.origin  # (M, d) as (x, y[, z])
    g = np.asarray(goal, dtype=float)[: esdf.dim]
    k = np.argmin(np.linalg.norm(nodes - g, axis=1))
    source = idx[tuple(np.nonzero(free)[a][k] for a in range(esdf.dim))]
    dist = dijkstra(graph, directed=False, indices=int(source)).reshape(shape)
    dist = dist + float(np.linalg.norm(nodes[k] - g))
    dist.setflags(write=False)
    return Esdf(origin=esdf.origin, resolution=h, values=dist)


def yield_rates(to_goal: np.ndarray, x: np.ndarray, clearance: np.ndarray, vi: np.ndarray, vj: np.ndarray,
                yield_range: float, yield_clearance: float) -> np.ndarray:
    """Reference clock rate ``phi_i`` in [0, 1] of every robot (1: not yielding).

    Args:
        to_goal: (N,) each robot's way to the goal [m] (the order: the longer way waits).
        x: (N, d) positions [m].
        clearance: (N,) distance of each robot to the nearest obstacle (ESDF) [m].
        vi, vj: the visible pairs, as index arrays.
        yield_range: a robot yields to a robot ahead closer than this [m]; its clock runs at
            ``clip(2 r / yield_range - 1, 0, 1)`` at distance r (stops at yield_range / 2).
        yield_clearance: only pairs with a robot closer than this to an obstacle yield [m].

    Returns:
        (N,) clock rates.
    """
    phi = np.ones(x.shape[0])
    if yield_range <= 0 or len(vi) == 0:
        return phi
    r = np.linalg.norm(x[vi] - x[vj], axis=1)
    narrow = (r < yield_range) & (np.minimum(clearance[vi], clearance[vj]) < yield_clearance)
    if not narrow.any():
        return phi
    a, b, r = vi[narrow], vj[narrow], r[narrow]
    # the robot with the longer way waits (ties: the larger index): a strict order
    a_waits = (to_goal[a] > to_goal[b]) | ((to_goal[a] == to_goal[b]) & (a > b))
    waiter = np.where(a_waits, a, b)
    np.minimum.at(phi, waiter, np.clip(2.0 * r / yield_range - 1.0, 0.0, 1.0))
    return phi
