"""Parameters of the HES method: Table A1 of the paper, and the values it leaves open.

Every field carries its unit and its source. ``Table A1`` / ``eq. (n)`` values are the
paper's and must not be tuned. Fields marked ``ours`` are not given by the paper; the reason
for each value is in the comment and in ``docs/methods/hes.md``. One parameter set serves all
scenes (nothing here is scene-specific).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

from swarmnav.errors import ConfigError
from swarmnav.params import param
from swarmnav.llm.config import DECISIONS, validate as validate_llm  # noqa: F401  DECISIONS: rule + LLM back ends


@dataclass(frozen=True, slots=True)
class HesParams:
    #: Named parameter sets (``--set preset=NAME``): ``swarmnav`` is the default build;
    #: ``faithful`` is the paper as written: every extension of ours switched off, the encircle ring
    #: circulating and merges by eq. (16) under the split-merge cooldown (docs/methods/hes.md).
    PRESETS: ClassVar[dict[str, dict[str, Any]]] = {
        "swarmnav": {},
        "faithful": {"passage_mode": False, "agent_guard": False, "stall_plan": False, "trail_follow": False,
                     "split_commit": False, "route_hold": False, "width_penalty": False,
                     "enc_orbit": True, "merge_rule": "paper_cooldown"},
    }

    # ---------------------------------------------------------------- dynamics and sensing
    dt: float = param(0.1, "s", "[0.0001, 1]", "Section 5.1", "integration / decision step")
    n_rays: int = param(360, "", "[8, 36000]", "Table A1", "LiDAR rays n_theta (1 deg resolution)")
    lidar_range: float = param(20.0, "m", "(0, inf)", "Table A1", "LiDAR range R_L")
    r_trigger: float = param(14.0, "m", "(0, inf)", "eq. (35)-(36), Table A1", "R_t avoidance trigger radius")
    a_max: float = param(2.6, "m/s^2", "(0, inf)", "eq. (39), Table A1", "a_xy^max acceleration saturation")

    # ---------------------------------------------------------------- force gains, Table A1
    k_p: float = param(0.7, "1/s^2", "[0, inf)", "eq. (24), Table A1", "slot position gain")
    k_v: float = param(0.8, "1/s", "[0, inf)", "eq. (24), Table A1", "slot velocity gain")
    k_rep: float = param(9.0, "m^3/s^2", "[0, inf)", "eq. (36), Table A1", "LiDAR repulsion base gain")
    k_e: float = param(48.0, "m/s^2 per m^2", "[0, inf)", "eq. (36), Table A1", "near-obstacle (emergency) gain")
    k_b: float = param(0.9, "", "[0, inf)", "eq. (36), Table A1", "short-range boost factor")
    gamma: float = param(1.2, "", "[0, inf)", "eq. (36), Table A1", "short-range boost exponent")
    k_sep: float = param(1.1, "m^2/s^2", "[0, inf)", "eq. (25), Table A1", "global separation gain")
    k_intra: float = param(1.8, "1/s^2", "[0, inf)", "eq. (26), Table A1", "nearest-neighbour cohesion gain")
    k_ir: float = param(1.6, "m^2/s^2", "[0, inf)", "eq. (31), Table A1", "intra-sub-swarm repulsion gain")
    k_path: float = param(0.75, "1/s^2", "[0, inf)", "eq. (32), Table A1", "corridor-centering gain")
    k_l: float = param(1.6, "1/s^2", "[0, inf)", "eq. (27), Table A1", "follower-subleader position coupling k_l")
    k_vl: float = param(0.7, "1/s", "[0, inf)", "eq. (27), Table A1", "follower-subleader velocity coupling k_vl")
    k_coh: float = param(0.9, "1/s^2", "[0, inf)", "eq. (29), Table A1", "centroid cohesion gain")
    d_safe: float = param(1.5, "m", "(0, inf)", "eq. (36), Table A1",
        "safety distance of eq. (36) (also the metric threshold)")
    sigma_occ: float = param(0.2, "", "(0, 1]", "eq. (30), Table A1", "occlusion attenuation factor")

    # ---------------------------------------------------------------- structural decisions, Table A1
    t_cd: float = param(10.0, "s", "[0, inf)", "eq. (13), Table A1", "T_cd split-merge cooldown")
    r_in: float = param(8.0, "m", "(0, inf)", "eq. (12), Table A1", "encircle entry threshold")
    r_out: float = param(11.0, "m", "(0, inf)", "eq. (12), Table A1", "encircle exit threshold")
    r_merge: float = param(12.0, "m", "(0, inf)", "eqs. (13), (15), Table A1", "near-goal radius")
    d_merge: float = param(8.0, "m", "(0, inf)", "eq. (16), Table A1", "inter-sub-swarm merge distance")

    # ---------------------------------------------------------------- follower reassignment, Table A1
    w_sl: float = param(1.0, "", "[0, inf)", "eq. (41), Table A1", "w subleader-distance weight")
    w_c: float = param(0.5, "", "[0, inf)", "eq. (41), Table A1", "w_c waypoint-distance weight")
    delta_min: float = param(2.0, "m", "[0, inf)", "eq. (41), Table A1", "Delta_min minimum cost improvement")
    tau_ra: float = param(2.0, "s", "[0, inf)", "Section 4.4, Table A1", "tau_ra per-follower cooldown")
    n_move_max: int = param(3, "", "[0, inf)", "Section 4.4, Table A1", "N_move^max transfers per planner update")

    # ---------------------------------------------------------------- reference trajectory (ours)
    v_s: float = param(3.0, "m/s", "(0, inf)", "ours",
        "cruise speed v_s: crosses the 70 m scenes in ~40 s, leaving time to form the encircle "
        "ring")
    eps_v: float = param(0.5, "m", "(0, inf)", "ours",
        "eps_v of eq. (23): the slot velocity ramps down within ~0.5 m of the slot")
    spacing: float = param(1.4, "m", "(0, inf)", "ours",
        "spacing of the equilibrium formation (alpha_s = spacing (k_p + k_path) / k_p, see docs)")
    aspect_max: float = param(3.0, "", "[1, inf)", "ours",
        "the template is squeezed across a narrow corridor (area kept) up to this aspect ratio")
    lane_margin: float = param(2.0, "m", "[0, inf)", "ours",
        "the squeezed formation keeps this from each side of the corridor (d_safe + 0.5)")
    lead: float = param(3.0, "m", "(0, inf)", "ours",
        "leash: waypoint c_s stays within this distance ahead of the sub-swarm centroid")
    through: float = param(3.0, "m", "[0, inf)", "ours", "the corridor target lies this far beyond the gap's throat")
    r_enc: float = param(6.0, "m", "(0, inf)", "ours",
        "encircle radius: paper's E_mean = 6.1 m with R_goal = 1 (r_succ = 8 m)")
    enc_orbit: bool = param(False, "", None, "ours",
        "True: the encircle slots circulate around the goal at the cruise speed v_s (the ring "
        "keeps moving, as the paper's path lengths imply); False: fixed slots")
    enc_clear: float = param(2.0, "m", "[0, inf)", "ours",
        "encircle slots keep this clearance from LiDAR returns (> d_safe)")
    enc_samples: int = param(72, "", "[1, 36000]", "ours",
        "candidate angles of the encircle slots on the circle of r_enc (72: every 5 deg)")
    slot_refresh: int = param(10, "steps", "[1, inf)", "ours",
        "steps between two solutions of the slot assignment (10: 1 s at dt = 0.1 s)")
    assign_exact: int = param(64, "agents", "[1, inf)", "ours",
        "slot assignment minimising the summed squared distance (Hungarian, O(m^3)) up to this many "
        "agents per sub-swarm; above, a banded sort in O(m log m) (formation.assign_slots)")
    stray: float = param(4.0, "m", "(0, inf)", "ours",
        "a subleader farther than this from its sub-swarm's centroid (or cut off from it) hands "
        "its role to the member nearest the centroid (the paper fixes no rule for who leads)")

    # ---------------------------------------------------------------- interaction radii (ours)
    r_sep: float = param(1.6, "m", "(0, inf)", "ours",
        "r_sep of eq. (25): global separation acts inside ~one UAV spacing")
    d_ir: float = param(1.2, "m", "(0, inf)", "ours", "d_ir of eq. (31): shorter than r_sep, as Section 4.2 requires")
    d_thr: float = param(2.0, "m", "(0, inf)", "ours",
        "d_thr of eq. (26): a nearest neighbour farther than 2 m is drifting away")
    d_0: float = param(12.5, "m", "(0, inf)", "ours",
        "d_0 of eq. (27): > 2 r_enc, so the encircle ring (followers up to 2 r_enc from the "
        "subleader) is not pulled in")
    d_c: float = param(6.5, "m", "(0, inf)", "ours",
        "d_c of eq. (29): > r_enc, so the ring is not pulled in; acts on stragglers only")
    d_floor: float = param(0.05, "m", "(0, inf)", "ours",
        "distances are floored here before 1/d and 1/d^2 (bounded forces)")

    # ---------------------------------------------------------------- corridor detection (ours)
    w_pass: float = param(2.0, "m", "(0, inf)", "ours",
        "narrowest gap a UAV may be routed through (0.4 m body + margins)")
    w_split: float = param(6.0, "m", "[0, inf)", "ours",
        "a gap counts as a split path (n_c) if a >=5-agent sub-swarm (~3 m across) passes it with "
        "d_safe = 1.5 m each side")
    h_open: float = param(0.5, "m", "[0, inf)", "ours",
        "the ring must rise this much between two minima to form an opening")
    toward_deg: float = param(80.0, "deg", "(0, 180]", "ours",
        "a corridor leads toward the goal if its exit direction is within this of the goal "
        "bearing (< 90: never back)")
    gap_depth: float = param(0.6, "m", "[0, inf)", "ours",
        "(passage mode) the peak return must lie this far from the throat: a concave corner seen "
        "at a grazing angle (<= one ray spacing, 0.35 m at R_L) is no passage")
    switch_margin: float = param(3.0, "m", "[0, inf)", "ours",
        "route-cost margin before a sub-swarm switches corridor (hysteresis)")
    rho_vis: float = param(0.4, "m", "[0, inf)", "ours",
        "half-width of the straight line from the centroid to a throat (or from a member to a trail "
        "point) that must be free of LiDAR returns for it to count as reachable / in view")
    width_penalty: bool = param(True, "", None, "ours",
        "route cost of a narrow corridor grows by m (penalty_width - w) / penalty_width for a "
        "sub-swarm of m agents (the queue of funnelling them through); False = route length only")
    penalty_width: float = param(6.0, "m", "(0, inf)", "ours",
        "corridors at least this wide carry no width penalty (three abreast at 2 m)")
    split_commit: bool = param(True, "", None, "ours",
        "a split's corridor is followed until the centroid has passed its throat or commit_time "
        "has lapsed; False = the route is re-chosen every step from the split on")
    commit_time: float = param(20.0, "s", "[0, inf)", "ours",
        "a split's corridor assignment lapses after this long if the throat is not passed")
    route_hold: bool = param(True, "", None, "ours",
        "a throat stays the route while members in line with it are still in front of it (at most "
        "hold_time after the first passed); False = the next corridor is chosen at once")
    hold_time: float = param(15.0, "s", "[0, inf)", "ours",
        "longest a sub-swarm waits at a throat for its last members")
    max_subswarms: int = param(3, "", "[1, 1000]", "ours", "a split creates at most this many sub-swarms")
    min_size: int = param(4, "", "[1, inf)", "ours", "smallest sub-swarm a split may create")

    # ---------------------------------------------------------------- safety stack (ours; Section 5.3)
    v_min_frac: float = param(0.5, "", "(0, 1]", "ours",
        "adaptive cruise: v_s is scaled down to this fraction in tight places")
    clr_slow: float = param(3.0, "m", "[0, inf)", "ours",
        "adaptive cruise acts when the sub-swarm's closest LiDAR return is nearer than this")
    v_cap_frac: float = param(1.3, "", "(0, inf)", "ours",
        "speed cap of the safety filter: 1.3 v_s (room to catch up with the formation)")
    brake_margin: float = param(0.5, "m", "[0, inf)", "ours",
        "braking barrier: stopping distance kept from every LiDAR return")
    a_brake: float = param(1.5, "m/s^2", "[0, inf)", "ours",
        "braking barrier: deceleration budget (< a_max, leaves room for the other terms)")
    agent_brake: float = param(2.0, "m/s^2", "[0, inf)", "ours",
        "(passage mode) agent braking barrier: a member's own braking budget when closing on a "
        "neighbour (1.5: gates R_goal 0.8 on seed 4; 2.6: more contacts); 0 switches the barrier "
        "off")
    agent_margin: float = param(0.7, "m", "[0, inf)", "ours",
        "(passage mode) agent braking barrier: a member stops this far from the neighbour in "
        "front (contact 0.4 m + 0.3 m; 0.6: twice the contacts on the gates, 0.8: R_goal 0.6-0.8 "
        "on some gates seeds before the tube change, 1.0: Y = 0)")
    agent_guard: bool = param(True, "", None, "ours",
        "contact guard (forces.agent_guard), every agent brakes for its neighbours with priority "
        "over the clip of eq. (39); False = eq. (39) alone (the faithful build)")
    guard_brake: float = param(2.2, "m/s^2", "[0, inf)", "ours",
        "contact guard: braking each agent of a closing pair is assumed to use (< a_max: head-on "
        "pairs need exactly this each; 2.0: one box_field_2 seed of ten stalls in a pocket, 1.8: "
        "dense_cross_blocks R_unsafe 0.228)")
    guard_margin: float = param(0.5, "m", "[0, inf)", "ours",
        "contact guard: a closing pair stops this far apart (contact 0.4 m + 0.1 m)")
    wall_passes: int = param(3, "", "[1, 1000]", "ours",
        "braking barrier: sweeps over the rays before what is left is scaled away (one is not "
        "enough between two obstacles)")
    trail_follow: bool = param(True, "", None, "ours",
        "a member cut off from its sub-swarm (slot, subleader and centroid behind obstacles, > "
        "d_c from the centroid) retraces its teammates' trail instead of pulling at its slot "
        "through the wall (trail.py); False = eqs. (24)/(32) toward the slot and c_s "
        "always")
    trail_every: int = param(10, "steps", "[1, inf)", "ours",
        "trail following: steps between two samples of the members' positions (10: 1 s)")
    trail_len: int = param(200, "", "[1, 100000]", "ours",
        "trail following: samples kept (200 at 1 s: longer than a run)")
    trail_reach: float = param(10.0, "m", "[0, inf)", "ours",
        "trail following: a cut-off member looks for trail points this close (half R_L)")
    cut_time: float = param(2.0, "s", "[0, inf)", "ours",
        "trail following: a member cut off this long follows the trail (not one briefly behind a "
        "corner)")
    wp_clear: float = param(2.0, "m", "[0, inf)", "ours",
        "the waypoint c_s is pushed this far from LiDAR returns (half the corridor width if "
        "narrower)")

    # ---------------------------------------------------------------- passage mode (ours, beyond the paper; docs "Passage mode")
    passage_mode: bool = param(True, "", None, "ours",
        "members inside the tube of their route's throat use d_safe_eff = min(d_safe - "
        "passage_relief, w/2 - passage_margin) in eq. (36); False = the paper's law everywhere")
    passage_margin: float = param(0.3, "m", "[0, inf)", "ours",
        "clearance kept between the throat's centre line and d_safe_eff: the near-obstacle term "
        "engages beyond 0.3 m off centre")
    passage_band: float = param(1.2, "m", "[0, inf)", "ours",
        "a route throat is a passage when the free band the paper's law leaves in it, w - 2 "
        "d_safe, is narrower than this (3 body diameters: room for one file). The first rule, w < "
        "2 (d_safe + passage_margin), was a 0.6 m band: 4 m gates left 1 m and the swarm queued "
        "there without passage mode (hes_gates_4m_shifted Y 0). 1.6 m was tried and dropped: "
        "centred 4.2 m gates fell from Y 1 to 0.6")
    passage_relief: float = param(0.2, "m", "[0, inf)", "ours",
        "inside a passage's tube d_safe_eff <= d_safe - passage_relief, so a throat wider than 2 "
        "(d_safe + passage_margin) still widens its band (4 m gate: 1.0 -> 1.4 m) and its members "
        "queue as in any passage")
    passage_len: float = param(2.5, "m", "[0, inf)", "ours",
        "tube half-length along the throat normal: d_safe (corner reach) + 1 m (wall thickness "
        "either side of the detected throat)")
    passage_confirm: float = param(5.0, "s", "[0, inf)", "ours",
        "a narrow throat becomes a passage after being the route, with no wider corridor "
        "reported, this long (2 s engaged passages beside blocks that the swarm can fly around: "
        "dense_cross_blocks R_unsafe 0.25)")
    passage_memory: float = param(20.0, "s", "[0, inf)", "ours",
        "a throat keeps its passage this long after the sub-swarm's route moved on (members still "
        "in front of it)")
    passage_queue: float = param(20.0, "m", "[0, inf)", "ours",
        "a member in front of an earlier throat queues for it when within this distance (R_L: it "
        "can see the throat)")
    passage_head: int = param(2, "", "[1, inf)", "ours",
        "once this many members have crossed the route's passage they are the head (waypoint, "
        "subleader) and the rest queue for it: the head moves on while the tail streams through "
        "(1 jams the mouth; 3 leaves the whole sub-swarm in formation at the mouth longer, gates "
        "seed 4 fails)")
    passage_reach: float = param(1.5, "m", "[0, inf)", "ours",
        "tube half-width beyond w/2: an agent approaching within d_safe of the throat's corners "
        "is inside")
    passage_count: int = param(3, "", "[1, 1000]", "ours",
        "throats remembered per sub-swarm (the current one and the two before)")

    # ---------------------------------------------------------------- stall planner (ours, beyond the paper; docs "Stall planner")
    stall_plan: bool = param(True, "", None, "ours",
        "a sub-swarm whose most advanced member has not come plan_progress closer to the goal for "
        "plan_stall s follows a path planned on the map of its rings' returns (plan.py) instead "
        "of the reactive corridor choice; False = the reactive choice always")
    plan_stall: float = param(10.0, "s", "[0, inf)", "ours",
        "no progress this long engages the planner (a queue streaming through a gate, or a "
        "formation squeezing round a block, advances its head well within it)")
    plan_progress: float = param(1.0, "m", "[0, inf)", "ours",
        "progress = the most advanced member comes this much closer to the goal than ever before")
    plan_cell: float = param(0.2, "m", "[0.05, 5]", "ours", "map cell (half the 0.4 m body)")
    plan_clear: float = param(0.6, "m", "(0, inf)", "ours",
        "a path keeps this from every return seen: > brake_margin (0.5 m), where the wall braking "
        "barrier stops an agent dead (0.4: four agents froze in the middle of a 0.98 m gap); gaps "
        "from ~1.2 m up are passable")
    plan_weight: float = param(1.0, "", "[0, inf)", "ours",
        "path cost per metre is 1 + plan_weight (d_safe - clearance) / clearance below d_safe: a "
        "squeeze at 0.5 m clearance costs 3 m per metre, at 0.75 m (a 1.5 m gap) 2 m, so wider "
        "ways round win unless much shorter and a path keeps to the middle of a gap")
    plan_look: float = param(2.0, "m", "[0, inf)", "ours",
        "the corridor target is the path point this far (arc length) past the centroid's nearest "
        "path point")
    plan_every: float = param(1.0, "s", "(0, inf)", "ours",
        "replanning interval while engaged (the map grows as the swarm moves)")
    plan_map_every: int = param(5, "steps", "[1, inf)", "ours",
        "steps between two updates of the map of returns (0.5 s; every step while engaged)")
    plan_margin: float = param(20.0, "m", "[0, 200]", "ours",
        "the map covers the box of the start and the goal plus this margin (R_L)")

    # ---------------------------------------------------------------- ablations (Simulation 2)
    safety_stack_off: bool = param(False, "", None, "ours",
        "True: waypoint regulation (rate limit, leash, clearance), adaptive cruise and safety "
        "filter off; a_max -> a_max_relaxed")
    occlusion_attenuation: bool = param(True, "", None, "ours",
        "False: sigma_occ = 1 (Table 4 \"w/o occ. attenuation\")")
    acceleration_bound: bool = param(True, "", None, "ours",
        "False: a_max -> a_max_relaxed (Table 4 \"w/o acc. bound\")")
    a_max_relaxed: float = param(26.0, "m/s^2", "(0, inf)", "ours",
        "the \"very loose\" bound of the ablations: 10 x a_max")

    # ---------------------------------------------------------------- structural rules
    merge_rule: str = param("swarmnav", "", None, "ours",
        "swarmnav: merge two sub-swarms closer than d_merge only once their corridors have "
        "rejoined and T_cd has passed (RulePolicy rule 3); paper: merge whenever eq. (16) holds; "
        "paper_cooldown: eq. (16) once T_cd has passed since the last change (Table A1's "
        "split-merge cooldown read as holding merges too)")

    # ---------------------------------------------------------------- decision source
    decision: str = param("rule", "", None, "Section 3.3",
        "rule | ollama | openai | llamacpp | replay, Section 3.3 (docs/llm.md)")
    llm_url: str = param("", "", None, "ours",
        "model server URL; \"\" = the back end's default (Ollama :11434, OpenAI-compatible "
        ":8000/v1)")
    llm_model: str = param("qwen2.5:3b", "", None, "Section 3.3",
        "model name, Section 3.3 (the paper also runs qwen3.5:4b)")
    llm_timeout: float = param(120.0, "s", "(0, inf)", "Section 3.3", "per-call timeout")
    llm_interval: int = param(50, "steps", "[1, inf)", "eq. (20), Section 3.3",
        "T_llm between LLM calls, eq. (20) (5 s at dt = 0.1 s)")
    llm_gguf: str = param("", "", None, "ours", "GGUF model file for decision=llamacpp")
    llm_latency: str = param("blocking", "", None, "ours",
        "blocking (paper) | real | fixed:SECONDS (ours: the swarm flies on while the model "
        "thinks)")
    llm_replay: str = param("", "", None, "ours", "transcript or run directory for decision=replay")
    llm_response_format: str = param("json_object", "", None, "ours",
        "openai back end: json_object | json_schema | none")
    llm_threads: int = param(0, "", "[0, 1024]", "ours", "llama.cpp CPU threads (0: llama-cpp-python's default)")

    def __post_init__(self) -> None:
        # single values are checked against their declared ranges by params.build; here the
        # relations between them
        validate_llm(self)  # decision and llm_* (raises ConfigError)
        if self.merge_rule not in ("swarmnav", "paper", "paper_cooldown"):
            raise ConfigError(f"hes: merge_rule must be swarmnav, paper or paper_cooldown, got {self.merge_rule!r}")
        if not self.r_out > self.r_in:
            raise ConfigError(f"hes: need r_out > r_in (eq. 12), got r_in={self.r_in}, r_out={self.r_out}")
        if not self.passage_relief < self.d_safe:
            raise ConfigError(f"hes: passage_relief must be < d_safe ({self.d_safe} m), got {self.passage_relief}")

    # -- derived
    @property
    def sigma(self) -> float:
        """Occlusion factor actually applied (1 when the ablation switches it off)."""
        return self.sigma_occ if self.occlusion_attenuation else 1.0

    @property
    def a_bound(self) -> float:
        """Acceleration bound actually applied [m/s^2]."""
        if self.safety_stack_off or not self.acceleration_bound:
            return self.a_max_relaxed
        return self.a_max

    @property
    def adaptive(self) -> bool:
        """The adaptive motion-regulation layers (waypoint regulation, adaptive cruise, safety filter) are on."""
        return not self.safety_stack_off
