"""Our safety parts around eq. (38)-(39): the wall braking barrier and the contact guard.

- :class:`WallBarrier` (on with the safety stack, ``safety_stack_off = false``): before the
  saturation of eq. (39), every agent's command is projected onto the speed cap
  ``v_cap_frac v_s`` and the braking barrier of every LiDAR ray (``barriers.safety_filter``).
  With passage mode's agent braking barrier (``agent_brake`` > 0), the members of a sub-swarm in a
  chain of narrow throats queue at the gate mouths and brake for the neighbour in front, before
  and again after the wall barrier, which may turn a member toward its neighbour: the wall
  barrier has the last word.
- :class:`ContactGuard` (``agent_guard``, with the safety stack): after the saturation, every
  agent brakes for its neighbours, with priority over the clip (``barriers.agent_guard``).
"""

from __future__ import annotations

import numpy as np

from swarmnav.methods.hes.parts.barriers import agent_guard, brake_radius, safety_filter
from swarmnav.methods.hes.neighbours import neighbour_rows
from swarmnav.methods.hes.hooks import Part


class WallBarrier(Part):
    """Speed cap and wall braking barrier (see the module docstring); ``queue``: passage mode, whose
    queue barrier is interleaved with it (or None)."""

    name = "wall"

    def __init__(self, p, queue=None):
        self.p = p
        self.queue = queue

    def reset(self, hes, positions):
        p = self.p
        self.rays = (hes.cos, hes.sin)
        # the barrier's scalars, read once per run: dt, the speed cap, a_brake, margin, R_L, passes
        self.consts = (p.paper.dt, p.safety.v_cap_frac * p.core.v_s, p.barrier.a_brake, p.barrier.margin,
                       p.paper.lidar_range, p.barrier.passes)

    def wall(self, step, a: np.ndarray) -> np.ndarray:
        return safety_filter(a, step.v, step.ring, *self.rays, *self.consts, step.ring_min)

    def brake(self, step, a):
        if self.queue is None or not self.queue.any_passages():
            return self.wall(step, a)
        chained = self.queue.chained_agents(step)
        if chained is None or not np.count_nonzero(chained):
            return self.wall(step, a)
        a = self.wall(step, self.queue.queue_barrier(step, a, chained))
        return self.wall(step, self.queue.queue_barrier(step, a, chained))

    def brake_known(self, step, a, net):
        """:meth:`brake` on a network: the queue barrier for the members whose plan routes them
        through throats, each braking for its pictures of the others."""
        if self.queue is None:
            return self.wall(step, a)
        chained = self.queue.chained_known(net)
        if not np.count_nonzero(chained):
            return self.wall(step, a)
        a = self.wall(step, self.queue.queue_barrier_known(step, a, chained, net))
        return self.wall(step, self.queue.queue_barrier_known(step, a, chained, net))


class ContactGuard(Part):
    """The contact guard (see the module docstring)."""

    name = "guard"

    def __init__(self, p):
        self.p = p

    def reset(self, hes, positions):
        p = self.p
        self.consts = (p.paper.dt, p.guard.brake, p.guard.margin)  # read once per run
        self.a_max = p.a_bound

    def guard(self, step, a):
        dt, brake, margin = self.consts
        ptr, idx = neighbour_rows(step.x, lambda: brake_radius(a, step.v, dt, brake, margin))
        return agent_guard(a, step.x, step.v, dt, brake, margin, self.a_max, 4, ptr, idx)
