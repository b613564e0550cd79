"""HES: hierarchical embodied swarm navigation (Wu & Wei, Drones 2026), registered as ``hes``.

The paper's method: ``params`` (Table A1 and our documented choices); the pure equation modules
``forces`` (eq. 23-39), ``corridors`` (Section 3.2 gap detection), ``decision`` (eq. 11-22,
decision sources), ``hierarchy`` (eq. 1-3, split / merge, eq. 41), ``formation`` (templates,
encircle slots); the step's stages ``report`` (1-2), ``structure`` (3), ``navigate`` and
``targets`` (4), ``control`` (5), passing one ``step.Step``; ``method`` (the wiring, ``Hes.act``).

Our additions live apart, in the subpackage ``parts`` (each a part with its own switch, plugged
in at the hooks of ``hooks``): ``parts.routes`` (split commitment, route hold), ``parts.trail``
(trail following), ``parts.passage`` (passage mode), ``parts.stall`` with ``parts.plan`` (stall
planner), ``parts.safety`` with ``parts.barriers`` (wall barrier, contact guard),
``parts.encircle`` (the ring that gives way), ``parts.projection`` (the post-update projection),
``parts.params`` (their parameters). See ``docs/methods/builds.md``.
"""

from swarmnav.methods.hes.decision import DecisionSource, DecisionState, Proposal, RulePolicy, project
from swarmnav.methods.hes.method import Hes
from swarmnav.methods.hes.params import HesParams
from swarmnav.methods.registry import register

register("hes", Hes, "HES: hierarchical embodied swarm, corridor-driven split/merge, eight-term force control.",
         params=HesParams)

__all__ = ["DecisionSource", "DecisionState", "Hes", "HesParams", "Proposal", "RulePolicy", "project"]
