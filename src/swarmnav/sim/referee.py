"""The contact rule of a run, applied step by step (the scene's ``rules.contact``).

Under ``contact = "crash"`` an agent whose clearance falls below the body radius (it touched an
obstacle or a boundary wall) or that comes nearer than twice the body radius to another agent
crashes: from that step on it stays where it hit with zero velocity, the method still sees it
there (a wreck is an obstacle to the others), and the metrics count it as failed. Under
``"count"`` nothing is enforced; the metrics only count the contacts (the behaviour before the
rule existed, for ablations and RL).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from swarmnav.sensing.cells import neighbour_csr

#: agents: below this, every pair is visited each step (a cell list does not pay)
ALL_PAIRS_BELOW = 64


@njit(cache=True)
def _touching_all(P, contact, box, out):
    """``out[i]`` = agent i is nearer than ``contact`` to another agent (every pair visited;
    minimum image in a periodic square of side ``box`` > 0)."""
    n, d = P.shape
    c2 = contact * contact
    for i in range(n):
        out[i] = False
    for i in range(n):
        for j in range(i + 1, n):
            d2 = 0.0
            for c in range(d):
                dc = P[j, c] - P[i, c]
                if box > 0.0:
                    dc -= box * np.round(dc / box)
                d2 += dc * dc
            if d2 < c2:
                out[i] = True
                out[j] = True


@njit(cache=True)
def _any_new_contact(P, clearance, body_radius, box, crashed, near):
    """:func:`_touching_all` into ``near`` (2 body radii), and whether an agent not yet crashed is
    in contact with an obstacle or another agent."""
    if P.shape[0] >= 2 and body_radius > 0.0:
        _touching_all(P, 2.0 * body_radius, box, near)
    else:
        for i in range(P.shape[0]):
            near[i] = False
    for i in range(P.shape[0]):
        if not crashed[i] and (near[i] or clearance[i] < body_radius):
            return True
    return False


@njit(cache=True)
def _touching_cells(P, contact, box, out, idx, d2):
    """:func:`_touching_all` on the shared cell list (many agents); returns the buffers, grown
    if they were too short."""
    n = P.shape[0]
    Q = P - box * np.floor(P / box) if box > 0.0 else P
    order, start, end, total = neighbour_csr(Q, contact, box, box > 0.0, idx, d2, -1.0)
    if total > idx.shape[0]:
        idx = np.empty(2 * total, np.int64)
        d2 = np.empty(2 * total)
        order, start, end, total = neighbour_csr(Q, contact, box, box > 0.0, idx, d2, -1.0)
    c2 = contact * contact
    for i in range(n):
        out[i] = False
    for i in range(n):
        for e in range(start[i], end[i]):
            if idx[e] != i and d2[e] < c2:
                out[i] = True
    return idx, d2


class Referee:
    """Applies the crash rule to a run's states (see the module docstring).

    Args:
        n: number of agents.
        body_radius: [m] obstacle contact below this clearance, agent contact below twice it.
        period: side of the periodic square [m], or None in an open or walled world.
        bounds: the world's bounds in a walled world (a contact near them is reported as a wall).
    """

    def __init__(self, n: int, body_radius: float, period: float | None = None,
                 bounds: tuple[float, ...] | None = None):
        self.body_radius = float(body_radius)
        self.bounds = None if bounds is None else np.asarray(bounds, dtype=np.float64).reshape(2, -1)
        self.box = float(period or 0.0)
        self.crashed = np.zeros(n, dtype=bool)
        self.crash_step = np.full(n, -1, dtype=np.int64)  # the step of each agent's crash (-1: none)
        self.where = np.zeros((n, 0))  # crashed agents' positions, filled at the first crash
        self._near = np.zeros(n, dtype=np.bool_)
        self._idx = np.empty(8 * n, np.int64)
        self._d2 = np.empty(8 * n)

    def hold(self, pos: np.ndarray, vel: np.ndarray) -> None:
        """Keep every crashed agent where it hit, at rest (in place, before the state is recorded)."""
        if self.crashed.any():
            pos[self.crashed] = self.where[self.crashed]
            vel[self.crashed] = 0.0

    def judge(self, k: int, pos: np.ndarray, clearance: np.ndarray, state: np.ndarray | None = None) -> list[dict]:
        """Crash every agent still flying that touches an obstacle, a wall or another agent at
        recorded step ``k`` (recorded positions ``pos`` (N, d), clearance (N,) [m]); returns one
        event per new crash. ``state``: the positions as the method's dynamics hold them, where
        :meth:`hold` keeps a crashed agent (a planar method on a 3-D scene: its (N, 2) slice
        state); default ``pos``."""
        state = pos if state is None else state
        P = np.ascontiguousarray(pos, dtype=np.float64)
        contact = 2.0 * self.body_radius
        if len(P) < ALL_PAIRS_BELOW:  # the usual case: one compiled pass, nothing allocated
            if not _any_new_contact(P, clearance, self.body_radius, self.box, self.crashed, self._near):
                return []
        else:
            self._idx, self._d2 = _touching_cells(P, contact, self.box, self._near, self._idx, self._d2)
        hit_obstacle = clearance < self.body_radius
        hit_agent = self._near if len(P) >= 2 and contact > 0.0 else np.zeros(len(P), dtype=bool)
        new = (hit_obstacle | hit_agent) & ~self.crashed
        if not new.any():
            return []
        if self.where.shape[1] != state.shape[1]:
            self.where = np.zeros(state.shape)
        self.where[new] = state[new]
        self.crashed |= new
        self.crash_step[new] = k
        return [{"step": int(k), "action": "crash", "agent": int(i), "source": "referee",
                 "reason": self._what(P[i]) if hit_obstacle[i] else "agent",
                 "clearance": float(clearance[i])} for i in np.flatnonzero(new)]

    def fail(self, k: int, agents: np.ndarray, state: np.ndarray, reason: str) -> list[dict]:
        """Crash the agents flagged in ``agents`` (N,) bool that are still flying, at recorded step
        ``k``, for a reason other than a contact (a quadrotor that flipped: ``"flipped"``; one that
        came down to a 3-D world's floor: ``"ground"``);
        ``state`` as in :meth:`judge`. Returns one event per new crash."""
        new = np.asarray(agents, dtype=bool) & ~self.crashed
        if not new.any():
            return []
        if self.where.shape[1] != state.shape[1]:
            self.where = np.zeros(state.shape)
        self.where[new] = state[new]
        self.crashed |= new
        self.crash_step[new] = k
        return [{"step": int(k), "action": "crash", "agent": int(i), "source": "referee", "reason": reason}
                for i in np.flatnonzero(new)]

    def _what(self, p: np.ndarray) -> str:
        """What an agent at ``p`` touched: the ground if it is within a body radius of a 3-D
        world's floor (or below it), else the boundary wall if it is within a body radius of the
        bounds (or beyond them), else an obstacle."""
        if self.bounds is not None and p.shape[0] == self.bounds.shape[1]:
            r = self.body_radius
            if p.shape[0] == 3 and p[2] - self.bounds[0, 2] < r:
                return "ground"
            if np.any(p - self.bounds[0] < r) or np.any(self.bounds[1] - p < r):
                return "wall"
        return "obstacle"
