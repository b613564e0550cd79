"""Two route parts of ours that keep a throat as the route for longer than the paper's choice does.

- :class:`SplitCommit` (``split_commit``): the corridor a split assigned a sub-swarm is kept
  (even when the subleader's view of the throat changes) until the centroid has passed the
  throat or ``commit_time`` has lapsed, and dropped once the corridor is lost from view.
- :class:`RouteHold` (``route_hold``): a throat is held until the whole sub-swarm is through (at
  most ``hold_time`` after the first member passed): the next corridor's target would pull the
  members still in front of this gap away from it, along the wall. Only members in line with the
  gap count as in front of it: a member stuck beside it (beyond its side wall, e.g. in a block's
  concave corner) held the route for 15 s while the target ran on along the old exit direction
  and led the rest into a closed pocket (dense_cross_blocks seeds 16, 26). In a chain of
  passages (passage mode) the queues replace the hold: a wide bay corridor held for the tail would
  keep the head behind the last gate.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from swarmnav.methods.hes.corridors import segment_clear
from swarmnav.methods.hes.hooks import Part


class SplitCommit(Part):
    """Split commitment (see the module docstring)."""

    name = "commit"

    def __init__(self, p):
        self.p = p

    def reset(self, hes, positions):
        self.since: dict[int, int] = {}  # sid -> step of the split that assigned its corridor (committed)

    def split(self, old, new, k):
        self.since.pop(old, None)
        for sid in new:
            self.since[sid] = k

    def merge(self, keep, drop):
        self.since.pop(keep, None)
        self.since.pop(drop, None)

    def lost(self, sub):
        self.since.pop(sub.sid, None)

    def committed(self, sid: int) -> bool:
        return sid in self.since

    def hold(self, step, sub, rep, prev):
        if sub.sid not in self.since or prev is None:
            return False
        passed = float(np.dot(rep.pack.centroid - prev.mid, prev.normal)) > 0.0
        if passed or (step.k - self.since[sub.sid]) * self.p.paper.dt > self.p.commit.time:
            del self.since[sub.sid]
            return False
        return True


class RouteHold(Part):
    """Route hold (see the module docstring); ``passage``: passage mode (or None), whose queues
    replace the hold in a chain of passages."""

    name = "hold"

    def __init__(self, p, passage=None):
        self.p = p
        self.passage = passage

    def reset(self, hes, positions):
        self.h = hes
        self.since: dict[int, int] = {}  # sid -> step since which its route is held

    def split(self, old, new, k):
        for sid in [old, *new]:
            self.since.pop(sid, None)

    def merge(self, keep, drop):
        self.since.pop(drop, None)

    def hold(self, step, sub, rep, prev):
        p, h = self.p, self.h
        if prev is None or prev.direct or (self.passage is not None and self.passage.engaged(sub.sid)):
            return False
        # members in line with the gap (within w/2 + 2 m of its centre line) that have passed it
        # and that are still in front of it
        through, before = gap_sides(rep.pack.positions, prev.mid, prev.normal, 0.5 * prev.width + 2.0)
        a, cent = sub.subleader, rep.pack.centroid
        sl = step.x[a]
        if through > 0 and before > 0 and segment_clear(step.ring[a], sl[0], sl[1], h.cos, h.sin, cent[0], cent[1],
                                                        prev.mid[0], prev.mid[1], p.core.rho_vis, p.paper.lidar_range):
            start = self.since.setdefault(sub.sid, step.k)
            return (step.k - start) * p.paper.dt <= p.hold.time
        self.since.pop(sub.sid, None)
        return False


@njit(cache=True)
def gap_sides(pos, mid, normal, band):
    """How many rows of ``pos`` (m, 2) lie within ``band`` [m] of the centre line of the gap at
    ``mid`` with exit direction ``normal``, past the gap (along > 0) and in front of it."""
    through = before = 0
    for i in range(pos.shape[0]):
        rx = pos[i, 0] - mid[0]
        ry = pos[i, 1] - mid[1]
        if abs(rx * -normal[1] + ry * normal[0]) < band:
            if rx * normal[0] + ry * normal[1] > 0.0:
                through += 1
            else:
                before += 1
    return through, before
