"""Raycasting-based splitting and merging, Algorithm 2 of the SPH paper.

An agent interacts only with the neighbours within R (eq. 1) whose line of sight is not
blocked by an obstacle. Sub-swarms are the connected components of this visibility graph.
Algorithm 2 names the per-pair transitions (a neighbour becoming visible: "merge with j";
a visible neighbour becoming occluded: "split from j"); the structural events logged for the
rollout are the component-level ones, as HES logs them: a sub-swarm breaking into several
(``split``) or several joining into one (``merge``).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from swarmnav.sensing import neighbor_pairs, segments_blocked
from swarmnav.world.obstacles import Geometry


def visible_pairs(geom: Geometry, x: np.ndarray, radius: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Unordered pairs ``i < j`` closer than ``radius`` [m] (eq. 1) and which of them have an
    unblocked line of sight (the raycast of Algorithm 2, line 6, on the obstacle geometry).

    Returns ``(i, j, visible)``: int64 pair arrays sorted by ``(i, j)`` and a bool mask.
    """
    i, j = neighbor_pairs(x, radius)
    if len(i) == 0 or geom.is_empty:
        return i, j, np.ones(len(i), dtype=bool)
    return i, j, ~segments_blocked(geom, x[i], x[j])


def components(n: int, i: np.ndarray, j: np.ndarray) -> np.ndarray:
    """(n,) sub-swarm label of every agent: the smallest agent index of its connected
    component in the graph with edges ``(i, j)`` (stable while a component keeps its
    lowest-indexed member)."""
    out = np.empty(n, dtype=np.int32)
    _smallest_member(n, np.asarray(i, dtype=np.int64), np.asarray(j, dtype=np.int64), out)
    return out


@njit(cache=True)
def _smallest_member(n, i, j, out):
    """Union-find over the edges, each set rooted at its smallest member (so the root is the
    label, whatever the order of the unions); writes every agent's root into ``out``."""
    root = np.arange(n)
    for e in range(i.shape[0]):
        a, b = i[e], j[e]
        while root[a] != a:  # path halving
            root[a] = root[root[a]]
            a = root[a]
        while root[b] != b:
            root[b] = root[root[b]]
            b = root[b]
        if a < b:
            root[b] = a
        elif b < a:
            root[a] = b
    for k in range(n):
        r = k
        while root[r] != r:
            r = root[r]
        out[k] = r


def structural_events(prev: np.ndarray, new: np.ndarray) -> list[dict]:
    """Component-level split and merge events between two labelings of the same agents.

    A previous sub-swarm whose members now carry several labels split; a new sub-swarm
    whose members carried several labels is a merge. Both can happen in one step.
    """
    events = []
    for lab in np.unique(prev):
        parts = np.unique(new[prev == lab])
        if len(parts) > 1:
            events.append({"action": "split", "source": "visibility",
                           "reason": f"line of sight lost: sub-swarm {int(lab)} split into "
                                     f"{', '.join(str(int(p)) for p in parts)}"})
    for lab in np.unique(new):
        parts = np.unique(prev[new == lab])
        if len(parts) > 1:
            events.append({"action": "merge", "source": "visibility",
                           "reason": f"line of sight restored: sub-swarms "
                                     f"{', '.join(str(int(p)) for p in parts)} merged into {int(lab)}"})
    return events


def link_changes(prev_visible: np.ndarray, in_range: np.ndarray, visible: np.ndarray) -> tuple[int, int]:
    """Algorithm 2's per-pair transitions, counted once per unordered pair: ``(merges, splits)``.

    Args:
        prev_visible: sorted keys ``i * N + j`` of the pairs visible at the previous step.
        in_range: keys of the pairs within R now; visible: bool mask over ``in_range``.

    A pair within R that is visible now and was not is a merge (line 8); one within R that is
    occluded now and was visible is a split (line 10). A pair that left R is neither.
    """
    prev = np.asarray(prev_visible, dtype=np.int64)
    keys = np.asarray(in_range, dtype=np.int64)
    visible = np.asarray(visible, dtype=bool)
    if len(prev) == 0:
        return int(np.count_nonzero(visible)), 0
    pos = np.minimum(np.searchsorted(prev, keys), len(prev) - 1)
    was = prev[pos] == keys  # a binary search in the sorted previous keys
    return int(np.count_nonzero(visible & ~was)), int(np.count_nonzero(~visible & was))
