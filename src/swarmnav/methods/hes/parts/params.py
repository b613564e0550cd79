"""Parameters of our extensions of HES, one record per part (each switched by its ``on``), the
safety stack's values and the ablations of Simulation 2. All ``ours``: the reason for each value
is in its line and in ``docs/methods/hes.md``; :class:`swarmnav.methods.hes.params.HesParams`
nests them.
"""

from __future__ import annotations

from dataclasses import dataclass

from swarmnav.params import param


@dataclass(frozen=True, slots=True)
class SafetyParams:
    """Adaptive motion regulation (Section 5.3 "safety stack", our values): cruise slow-down, speed cap,
    waypoint clearance. Switched off as a whole by ``ablation.safety_stack_off``."""

    v_min_frac: float = param(0.5, "", "(0, 1]", "ours",
        "adaptive cruise: v_s is scaled down to this fraction in tight places")
    clr_slow: float = param(3.0, "m", "[0, inf)", "ours",
        "adaptive cruise acts when the sub-swarm's closest LiDAR return is nearer than this")
    v_cap_frac: float = param(1.3, "", "(0, inf)", "ours",
        "speed cap of the safety filter: 1.3 v_s (room to catch up with the formation)")
    wp_clear: float = param(2.0, "m", "[0, inf)", "ours",
        "the waypoint c_s is pushed this far from LiDAR returns (half the corridor width if "
        "narrower)")


@dataclass(frozen=True, slots=True)
class BarrierParams:
    """Wall braking barrier (``WallBarrier``, safety.py; ours): every agent keeps its stopping distance
    from the LiDAR returns ahead of it."""

    on: bool = param(True, "", None, "ours",
        "the barrier acts (with the safety stack); False = the eq. (39) clip alone bounds the command")
    margin: float = param(0.5, "m", "[0, inf)", "ours",
        "braking barrier: stopping distance kept from every LiDAR return")
    a_brake: float = param(1.5, "m/s^2", "[0, inf)", "ours",
        "braking barrier: deceleration budget (< a_max, leaves room for the other terms)")
    passes: int = param(3, "", "[1, 1000]", "ours",
        "braking barrier: sweeps over the rays before what is left is scaled away (one is not "
        "enough between two obstacles)")


@dataclass(frozen=True, slots=True)
class GuardParams:
    """Contact guard (``ContactGuard``, safety.py; ours): each agent of a closing pair brakes in time."""

    on: bool = param(True, "", None, "ours",
        "contact guard (forces.agent_guard), every agent brakes for its neighbours with priority "
        "over the clip of eq. (39); False = eq. (39) alone (the paper build)")
    brake: float = param(2.2, "m/s^2", "[0, inf)", "ours",
        "contact guard: braking each agent of a closing pair is assumed to use (< a_max: head-on "
        "pairs need exactly this each; 2.0: one box_field_2 seed of ten stalls in a pocket, 1.8: "
        "dense_cross_blocks R_unsafe 0.228)")
    margin: float = param(0.5, "m", "[0, inf)", "ours",
        "contact guard: a closing pair stops this far apart (contact 0.4 m + 0.1 m)")


@dataclass(frozen=True, slots=True)
class WidthParams:
    """Width penalty of the route cost (routes.py; ours)."""

    on: bool = param(True, "", None, "ours",
        "route cost of a narrow corridor grows by m (penalty_width - w) / penalty_width for a "
        "sub-swarm of m agents (the queue of funnelling them through); False = route length only")
    penalty_width: float = param(6.0, "m", "(0, inf)", "ours",
        "corridors at least this wide carry no width penalty (three abreast at 2 m)")


@dataclass(frozen=True, slots=True)
class CommitParams:
    """Split commitment (``SplitCommit``, routes.py; ours)."""

    on: bool = param(True, "", None, "ours",
        "a split's corridor is followed until the centroid has passed its throat or commit_time "
        "has lapsed; False = the route is re-chosen every step from the split on")
    time: float = param(20.0, "s", "[0, inf)", "ours",
        "a split's corridor assignment lapses after this long if the throat is not passed")


@dataclass(frozen=True, slots=True)
class HoldParams:
    """Route hold (``RouteHold``, routes.py; ours)."""

    on: bool = param(True, "", None, "ours",
        "a throat stays the route while members in line with it are still in front of it (at most "
        "hold_time after the first passed); False = the next corridor is chosen at once")
    time: float = param(15.0, "s", "[0, inf)", "ours",
        "longest a sub-swarm waits at a throat for its last members")


@dataclass(frozen=True, slots=True)
class TrailParams:
    """Trail following (``TrailFollow``, trail.py; ours)."""

    on: bool = param(True, "", None, "ours",
        "a member cut off from its sub-swarm (slot, subleader and centroid behind obstacles, > "
        "d_c from the centroid) retraces its teammates' trail instead of pulling at its slot "
        "through the wall (trail.py); False = eqs. (24)/(32) toward the slot and c_s "
        "always")
    every: int = param(10, "steps", "[1, inf)", "ours",
        "trail following: steps between two samples of the members' positions (10: 1 s)")
    length: int = param(200, "", "[1, 100000]", "ours",
        "trail following: samples kept (200 at 1 s: longer than a run)")
    reach: float = param(10.0, "m", "[0, inf)", "ours",
        "trail following: a cut-off member looks for trail points this close (half R_L)")
    cut_time: float = param(2.0, "s", "[0, inf)", "ours",
        "trail following: a member cut off this long follows the trail (not one briefly behind a "
        "corner)")


@dataclass(frozen=True, slots=True)
class PassageParams:
    """Passage mode (``PassageMode``, passage.py; ours, beyond the paper)."""

    gap_depth: float = param(0.6, "m", "[0, inf)", "ours",
        "(passage mode) the peak return must lie this far from the throat: a concave corner seen "
        "at a grazing angle (<= one ray spacing, 0.35 m at R_L) is no passage")
    agent_brake: float = param(2.0, "m/s^2", "[0, inf)", "ours",
        "(passage mode) agent braking barrier: a member's own braking budget when closing on a "
        "neighbour (1.5: gates R_goal 0.8 on seed 4; 2.6: more contacts); 0 switches the barrier "
        "off")
    agent_margin: float = param(0.7, "m", "[0, inf)", "ours",
        "(passage mode) agent braking barrier: a member stops this far from the neighbour in "
        "front (contact 0.4 m + 0.3 m; 0.6: twice the contacts on the gates, 0.8: R_goal 0.6-0.8 "
        "on some gates seeds before the tube change, 1.0: Y = 0)")
    on: bool = param(True, "", None, "ours",
        "members inside the tube of their route's throat use d_safe_eff = min(d_safe - "
        "passage_relief, w/2 - passage_margin) in eq. (36); False = the paper's law everywhere")
    margin: float = param(0.3, "m", "[0, inf)", "ours",
        "clearance kept between the throat's centre line and d_safe_eff: the near-obstacle term "
        "engages beyond 0.3 m off centre")
    band: float = param(1.2, "m", "[0, inf)", "ours",
        "a route throat is a passage when the free band the paper's law leaves in it, w - 2 "
        "d_safe, is narrower than this (3 body diameters: room for one file). The first rule, w < "
        "2 (d_safe + passage_margin), was a 0.6 m band: 4 m gates left 1 m and the swarm queued "
        "there without passage mode (hes_gates_4m_shifted Y 0). 1.6 m was tried and dropped: "
        "centred 4.2 m gates fell from Y 1 to 0.6")
    relief: float = param(0.2, "m", "[0, inf)", "ours",
        "inside a passage's tube d_safe_eff <= d_safe - passage_relief, so a throat wider than 2 "
        "(d_safe + passage_margin) still widens its band (4 m gate: 1.0 -> 1.4 m) and its members "
        "queue as in any passage")
    length: float = param(2.5, "m", "[0, inf)", "ours",
        "tube half-length along the throat normal: d_safe (corner reach) + 1 m (wall thickness "
        "either side of the detected throat)")
    confirm: float = param(5.0, "s", "[0, inf)", "ours",
        "a narrow throat becomes a passage after being the route, with no wider corridor "
        "reported, this long (2 s engaged passages beside blocks that the swarm can fly around: "
        "dense_cross_blocks R_unsafe 0.25)")
    memory: float = param(20.0, "s", "[0, inf)", "ours",
        "a throat keeps its passage this long after the sub-swarm's route moved on (members still "
        "in front of it)")
    queue: float = param(20.0, "m", "[0, inf)", "ours",
        "a member in front of an earlier throat queues for it when within this distance (R_L: it "
        "can see the throat)")
    head: int = param(2, "", "[1, inf)", "ours",
        "once this many members have crossed the route's passage they are the head (waypoint, "
        "subleader) and the rest queue for it: the head moves on while the tail streams through "
        "(1 jams the mouth; 3 leaves the whole sub-swarm in formation at the mouth longer, gates "
        "seed 4 fails)")
    reach: float = param(1.5, "m", "[0, inf)", "ours",
        "tube half-width beyond w/2: an agent approaching within d_safe of the throat's corners "
        "is inside")
    count: int = param(3, "", "[1, 1000]", "ours",
        "throats remembered per sub-swarm (the current one and the two before)")


@dataclass(frozen=True, slots=True)
class StallParams:
    """Stall planner (``StallPlanner``, stall.py; ours, beyond the paper)."""

    on: bool = param(True, "", None, "ours",
        "a sub-swarm whose most advanced member has not come plan_progress closer to the goal for "
        "plan_stall s follows a path planned on the map of its rings' returns (plan.py) instead "
        "of the reactive corridor choice; False = the reactive choice always")
    time: float = param(10.0, "s", "[0, inf)", "ours",
        "no progress this long engages the planner (a queue streaming through a gate, or a "
        "formation squeezing round a block, advances its head well within it)")
    progress: float = param(1.0, "m", "[0, inf)", "ours",
        "progress = the most advanced member comes this much closer to the goal than ever before")
    cell: float = param(0.2, "m", "[0.05, 5]", "ours", "map cell (half the 0.4 m body)")
    clear: float = param(0.6, "m", "(0, inf)", "ours",
        "a path keeps this from every return seen: > brake_margin (0.5 m), where the wall braking "
        "barrier stops an agent dead (0.4: four agents froze in the middle of a 0.98 m gap); gaps "
        "from ~1.2 m up are passable")
    weight: float = param(1.0, "", "[0, inf)", "ours",
        "path cost per metre is 1 + plan_weight (d_safe - clearance) / clearance below d_safe: a "
        "squeeze at 0.5 m clearance costs 3 m per metre, at 0.75 m (a 1.5 m gap) 2 m, so wider "
        "ways round win unless much shorter and a path keeps to the middle of a gap")
    look: float = param(2.0, "m", "[0, inf)", "ours",
        "the corridor target is the path point this far (arc length) past the centroid's nearest "
        "path point")
    every: float = param(1.0, "s", "(0, inf)", "ours",
        "replanning interval while engaged (the map grows as the swarm moves)")
    map_every: int = param(5, "steps", "[1, inf)", "ours",
        "steps between two updates of the map of returns (0.5 s; every step while engaged)")
    margin: float = param(20.0, "m", "[0, 200]", "ours",
        "the map covers the box of the start and the goal plus this margin (R_L)")
    max_map_bytes: int = param(2 * 2**30, "B", "[1, inf)", "ours",
        "largest memory the map and its fields may take (stall.py: 180 B a cell while engaged); a start-goal "
        "box that needs more at stall.cell is refused at reset (2 GiB: ~70 times the 24-31 MB of the HES "
        "Simulation 3 scenes)")


@dataclass(frozen=True, slots=True)
class AblationParams:
    """The ablations of Simulation 2 (Tables 3-4)."""

    safety_stack_off: bool = param(False, "", None, "ours",
        "True: waypoint regulation (rate limit, leash, clearance), adaptive cruise and safety "
        "filter off; a_max -> a_max_relaxed")
    occlusion_attenuation: bool = param(True, "", None, "ours",
        "False: sigma_occ = 1 (Table 4 \"w/o occ. attenuation\")")
    acceleration_bound: bool = param(True, "", None, "ours",
        "False: a_max -> a_max_relaxed (Table 4 \"w/o acc. bound\")")
    a_max_relaxed: float = param(26.0, "m/s^2", "(0, inf)", "ours",
        "the \"very loose\" bound of the ablations: 10 x a_max")
    keep_leash: bool = param(False, "", None, "ours",
        "True: the safety stack off keeps the waypoint c_s advancing at the adaptive cruise speed on "
        "its leash (Section 5.3 \"weakens\" the regulation layers: the waypoint clearance and the "
        "safety filter go, the local waypoint of eq. (32) and its pace stay); False: c_s is the "
        "corridor target itself")
    relax_filter: bool = param(False, "", None, "ours",
        "True: \"w/o acc. bound\" also lifts the safety filter (speed cap and wall braking barrier, "
        "which bound the command like eq. (39)), as the safety stack off does; False: eq. (39) "
        "alone is relaxed")
