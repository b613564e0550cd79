"""Our parts of HES: what we added to the paper's method, each with its own parameters, state and
switch, plugged in at the hooks of ``swarmnav.methods.hes.hooks`` (the core's step calls them).

Nothing in this package is in the paper. Some parts are the readings the paper's own words leave
to us, and ``preset=paper`` switches them on (``swarmnav methods hes`` lists what differs):
``encircle`` (``core.enc_yield``: the paper gives no encircle slots), ``safety`` with ``barriers``
(the wall barrier) and ``regulation`` (the waypoint leash, adaptive cruise and wall clearance): the
"safety stack" Section 5.3 and Table 3 name without a formula; ``projection`` (the "geometric
post-update safety projection" Section 5.3 names). The others are our default build's additions:
``routes`` (split commitment, route hold), ``trail`` (trail following), ``passage`` (passage mode),
``stall`` with ``plan`` (stall planner), ``safety`` (the contact guard), ``regulation`` (the
width penalty). ``params`` holds their parameter records. docs/methods/builds.md maps every file
of the family to the paper or to us.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from swarmnav.methods.hes.hooks import Part
from swarmnav.methods.hes.parts.encircle import RingYield
from swarmnav.methods.hes.parts.passage import PassageMode
from swarmnav.methods.hes.parts.projection import PostProjection
from swarmnav.methods.hes.parts.routes import RouteHold, SplitCommit
from swarmnav.methods.hes.parts.safety import ContactGuard, WallBarrier
from swarmnav.methods.hes.parts.stall import StallPlanner
from swarmnav.methods.hes.parts.trail import TrailFollow

if TYPE_CHECKING:
    from swarmnav.methods.hes.params import HesParams


def build_parts(p: "HesParams") -> list[Part]:
    """The parts of ours that ``p`` switches on, in hook order:

    ============== ====================== ===============================================
    part           switch                 module
    ============== ====================== ===============================================
    RingYield      ``core.enc_yield`` > 0 parts/encircle.py
    SplitCommit    ``commit.on``          parts/routes.py
    RouteHold      ``hold.on``            parts/routes.py
    TrailFollow    ``trail.on``           parts/trail.py
    PassageMode    ``passage.on``         parts/passage.py (its queue barrier: ``passage.agent_brake`` > 0)
    StallPlanner   ``stall.on``           parts/stall.py
    WallBarrier    ``barrier.on``         parts/safety.py (with the safety stack: ``ablation.safety_stack_off = false``)
    ContactGuard   ``guard.on``           parts/safety.py (with the safety stack)
    PostProjection ``core.projection`` >0 parts/projection.py
    ============== ====================== ===============================================
    """
    stall = StallPlanner(p, narrow_relief=p.passage.on) if p.stall.on else None
    passage = PassageMode(p, stall) if p.passage.on else None
    parts: list[Part | None] = [
        RingYield(p) if p.core.enc_yield > 0.0 else None,
        SplitCommit(p) if p.commit.on else None,
        RouteHold(p, passage) if p.hold.on else None,
        TrailFollow(p) if p.trail.on else None,
        passage,
        stall,
        WallBarrier(p, passage if p.passage.agent_brake > 0.0 else None) if p.filtered else None,
        ContactGuard(p) if p.adaptive and p.guard.on else None,
        PostProjection(p) if p.core.projection > 0.0 else None,
    ]
    return [q for q in parts if q is not None]

