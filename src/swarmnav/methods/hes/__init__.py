"""HES: hierarchical embodied swarm navigation (Wu & Wei, Drones 2026), registered as ``hes``.

Modules: ``params`` (Table A1 and our documented choices), ``forces`` (eq. 23-39),
``corridors`` (Section 3.2 gap detection), ``decision`` (eq. 11-22, decision sources),
``hierarchy`` (eq. 1-3, split / merge, eq. 41), ``formation`` (templates, encircle slots),
``method`` (the wiring). See ``docs/methods/hes.md``.
"""

from swarmnav.methods.hes.decision import DecisionSource, DecisionState, Proposal, RulePolicy, project
from swarmnav.methods.hes.method import Hes
from swarmnav.methods.hes.params import HesParams
from swarmnav.methods.registry import register

register("hes", Hes, "HES: hierarchical embodied swarm, corridor-driven split/merge, eight-term force control.",
         params=HesParams)

__all__ = ["DecisionSource", "DecisionState", "Hes", "HesParams", "Proposal", "RulePolicy", "project"]
