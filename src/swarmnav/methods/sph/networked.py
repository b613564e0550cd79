"""SPH on a network (docs/network.md): every robot computes its own terms from its own state and
what it received of the others.

Under the ideal network every robot sees every other's true state, the pair terms are symmetric,
and ``method.py`` computes each unordered pair once for both ends. On a network robot i's picture
of robot j (``kx[i, j]``, ``kv[i, j]``) need not match robot j's picture of robot i, so each robot
sums over its own *directed* pairs: robot i interacts with robot j where it has heard j, j is
within R of i's own position and the line from i to where i believes j is is not blocked
(Algorithm 2's raycast). Fed the true states, every function here gives what the ideal path
gives, up to the order of floating-point sums (tests/methods/sph/test_networked.py).
"""

from __future__ import annotations

import numpy as np

from swarmnav.methods.sph.kernel import sph_forces
from swarmnav.sensing import segments_blocked
from swarmnav.world.obstacles import Geometry


def heard_pairs(geom: Geometry, x: np.ndarray, kx: np.ndarray, heard: np.ndarray,
                radius: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Directed pairs ``(i, j)``, i != j, that robot i has heard with j within ``radius`` [m] of
    its own position (by i's picture ``kx[i, j]``), and which of them i sees (no obstacle on the
    segment). Sorted by ``(i, j)``."""
    n = x.shape[0]
    i, j = np.nonzero(heard & ~np.eye(n, dtype=bool))
    d = kx[i, j] - x[i]
    near = np.einsum("pd,pd->p", d, d) < radius * radius
    i, j = i[near], j[near]
    if len(i) == 0 or geom.is_empty:
        return i, j, np.ones(len(i), dtype=bool)
    return i, j, ~segments_blocked(geom, x[i], kx[i, j])


def directed_forces(x: np.ndarray, v: np.ndarray, kx: np.ndarray, kv: np.ndarray, i: np.ndarray, j: np.ndarray,
                    **kw) -> dict[str, np.ndarray]:
    """Algorithm 1's terms of every robot (N, D) [m/s^2] over its directed pairs: robot i's
    density, pressure, repulsion and viscosity from its own state and its pictures of its
    neighbours. Each neighbour enters as a ghost particle at ``kx[i, j]`` that only robot i
    interacts with (``sph_forces`` applies a pair to both ends; the ghosts' ends are dropped)."""
    n, p = x.shape[0], len(i)
    ghosts = n + np.arange(p)
    xs = np.concatenate([x, kx[i, j]])
    vs = np.concatenate([v, kv[i, j]])
    _, _, parts = sph_forces(xs, vs, i, ghosts, **kw)
    return {k: a[:n] for k, a in parts.items()}


def directed_yield_rates(to_goal: np.ndarray, to_goal_of: np.ndarray, x: np.ndarray, kx_pairs: np.ndarray,
                         clearance: np.ndarray, clearance_of: np.ndarray, i: np.ndarray, j: np.ndarray,
                         yield_range: float, yield_clearance: float) -> np.ndarray:
    """``parts.yielding.yield_rates`` decided by each robot for itself: robot i waits for a
    neighbour j it sees where, by its picture of j (position ``kx_pairs``, way to the goal
    ``to_goal_of`` and clearance ``clearance_of`` at that position, per pair), the pair is in a
    narrow place and i has the longer way (ties: the larger index waits)."""
    phi = np.ones(x.shape[0])
    if yield_range <= 0 or len(i) == 0:
        return phi
    r = np.linalg.norm(x[i] - kx_pairs, axis=1)
    narrow = (r < yield_range) & (np.minimum(clearance[i], clearance_of) < yield_clearance)
    waits = narrow & ((to_goal[i] > to_goal_of) | ((to_goal[i] == to_goal_of) & (i > j)))
    np.minimum.at(phi, i[waits], np.clip(2.0 * r[waits] / yield_range - 1.0, 0.0, 1.0))
    return phi
