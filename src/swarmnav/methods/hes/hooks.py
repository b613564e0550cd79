"""The hook points at which our extensions plug into the paper's step (``Hes.act``).

A part is one idea of ours beyond the paper, with its own parameters (fields of
:class:`HesParams`), its own state and a switch; :func:`swarmnav.methods.hes.parts.build_parts`
builds the parts the parameters switch on, in a fixed order. A part that is off is simply not in
the list, so the run is the paper's step at every hook it would have used. The core calls every
part at each hook, in that order; a part overrides only the hooks it needs:

===========================  ====================================================================
stage / hook                 what a part may do there
===========================  ====================================================================
1 perceive  ``observe``      read the step's rings (a map of returns, a trail of positions)
            ``elect``        change a subleader after the core's re-election
2 report    ``gaps``         drop openings of the subleader's ring before the corridor filter
            ``seen_w``,      (attributes, m) an opening narrower than ``seen_w`` is kept only if
            ``seen_depth``   the ring sees ``seen_depth`` on through it (``corridors.seen_passages``)
            ``approach``     (attribute, m) reach narrow throats through their mouth
            ``corridors``    drop reported corridors
            ``cruise_mask``  members whose clearance does not slow the cruise
3 decide    ``split``,       carry per-sub-swarm state across a split / merge
            ``merge``
4 route     ``encircle``     act for a sub-swarm in encircle mode
            ``plan``         replace the reactive corridor choice (route, target)
            ``hold``         keep the previous route (stop the choice there)
            ``candidates``   drop corridor candidates; ``end_route``: head for the goal instead
            ``lost``         the previous route is no longer seen
            ``chosen``       the route is chosen (remember it)
            ``target``       move the corridor target
            ``restart``      move c_s before it advances (it is behind a wall)
  targets   ``targets``      route single agents on their own (``Step.own``)
5 control   ``steer``        re-target single members, lower their safety distance (eq. 36)
            ``push_back``    edit the eight terms of eq. (38) (drop a push-back)
            ``brake``        bound the command before saturation (eq. 39)
            ``guard``        bound the command after saturation
===========================  ====================================================================

On a non-ideal network (``networked.py``, docs/methods/hes-network.md) the planner's hooks run in
the leader's planner on its picture of the agents, and three hooks have a version on what each
agent received (``net``: a :class:`~swarmnav.methods.hes.networked.Picture`): ``observe_known``
(default: ``observe`` of the rings the leader holds), ``steer_known`` and ``brake_known`` (default:
``steer`` / ``brake``, for parts that read only each agent's own state and ring).
"""

from __future__ import annotations

import numpy as np


class Part:
    """An extension of ours (see the module docstring for the hooks; every hook defaults to no-op)."""

    name = "part"
    approach = 0.0  # [m] report: reach throats narrower than the part's width through a mouth this deep
    approach_w = float("inf")  # [m] ... narrower than this
    seen_w = 0.0  # [m] report: openings narrower than this must be seen passages (0: none) ...
    seen_depth = 0.0  # [m] ... the ring seeing this far on through them
    needs_blocked = False  # control: the part reads Step.blocked (segments computed even with sigma = 1)

    def reset(self, hes, positions: np.ndarray) -> None:
        """Start a run (``hes``: the core, for its goal, geometry, ray table and counters)."""

    # 1. perceive
    def observe(self, step) -> None: ...

    def observe_known(self, step, net) -> None:
        """On a network: ``step`` the rings the leader holds (its own, its reports'), at the
        positions where they were sensed; ``net`` each agent's picture."""
        self.observe(step)

    def elect(self, step, col: np.ndarray) -> None: ...

    # 2. report
    def gaps(self, step, sub, gaps: np.ndarray) -> np.ndarray:
        return gaps

    def corridors(self, step, sub, cors: list) -> list:
        return cors

    def cruise_mask(self, members: np.ndarray):
        return None

    # 3. decide: structural changes
    def split(self, old: int, new: list[int], k: int) -> None: ...
    def merge(self, keep: int, drop: int) -> None: ...

    # 4. route, targets
    def encircle(self, step, sub, rep) -> None: ...

    def plan(self, step, sub, rep, cent):
        return None

    def hold(self, step, sub, rep, prev) -> bool:
        return False

    def candidates(self, step, sub, rep, cands: list, cent) -> list:
        return cands

    def end_route(self, step, sub, prev) -> bool:
        return False

    def lost(self, sub) -> None: ...
    def chosen(self, step, sub, rep, route) -> None: ...

    def target(self, step, sub, route, target, cent, along: float):
        return target

    def restart(self, step, sub, cent) -> None: ...

    def targets(self, step, subs: dict, labels: np.ndarray, final: bool) -> None: ...

    # 5. control
    def steer(self, step) -> None: ...

    def steer_known(self, step, net) -> None:
        """``steer`` on a network, reading the others only through ``net``."""
        self.steer(step)

    def push_back(self, step) -> bool:
        """True if the part edits the eight terms this step (then :meth:`edit_terms` is called)."""
        return False

    def edit_terms(self, step, terms: np.ndarray) -> None: ...

    def brake(self, step, a: np.ndarray) -> np.ndarray:
        return a

    def brake_known(self, step, a: np.ndarray, net) -> np.ndarray:
        """``brake`` on a network, reading the others only through ``net``."""
        return self.brake(step, a)

    def guard(self, step, a: np.ndarray) -> np.ndarray:
        return a

    def summary(self) -> dict:
        return {}


HOOKS = ("observe", "elect", "gaps", "corridors", "cruise_mask", "split", "merge", "encircle", "plan", "hold",
         "candidates", "end_route", "lost", "chosen", "target", "restart", "targets", "steer", "push_back",
         "brake", "guard")


def hook_table(parts: list[Part]) -> dict[str, list[Part]]:
    """For each hook, the parts that override it, in order: the step calls only these (a part's
    default hook is a no-op or returns its input, so skipping it changes nothing)."""
    return {hook: [q for q in parts if getattr(type(q), hook) is not getattr(Part, hook)] for hook in HOOKS}
