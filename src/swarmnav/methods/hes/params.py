"""Parameters of the HES method: Table A1 of the paper, and the values it leaves open.

Every field carries its unit and its source. ``Table A1`` / ``eq. (n)`` values are the
paper's and must not be tuned. Fields marked ``ours`` are not given by the paper; the reason
for each value is in the comment and in ``docs/methods/hes.md``. One parameter set serves all
scenes (nothing here is scene-specific).
"""

from __future__ import annotations

from dataclasses import dataclass

from swarmnav.errors import ConfigError
from swarmnav.llm.config import DECISIONS, validate as validate_llm  # noqa: F401  DECISIONS: rule + LLM back ends


@dataclass(frozen=True, slots=True)
class HesParams:
    # ---------------------------------------------------------------- dynamics and sensing
    dt: float = 0.1  # [s] integration / decision step, Section 5.1
    n_rays: int = 360  # LiDAR rays n_theta (1 deg resolution), Table A1
    lidar_range: float = 20.0  # R_L [m], Table A1
    r_trigger: float = 14.0  # R_t [m] avoidance trigger radius of eq. (35)-(36), Table A1
    a_max: float = 2.6  # a_xy^max [m/s^2] acceleration saturation, eq. (39), Table A1

    # ---------------------------------------------------------------- force gains, Table A1
    k_p: float = 0.7  # [1/s^2] slot position gain, eq. (24)
    k_v: float = 0.8  # [1/s] slot velocity gain, eq. (24)
    k_rep: float = 9.0  # [m^3/s^2] LiDAR repulsion base gain, eq. (36)
    k_e: float = 48.0  # [m/s^2 per m^2] near-obstacle (emergency) gain, eq. (36)
    k_b: float = 0.9  # [-] short-range boost factor, eq. (36)
    gamma: float = 1.2  # [-] short-range boost exponent, eq. (36)
    k_sep: float = 1.1  # [m^2/s^2] global separation gain, eq. (25)
    k_intra: float = 1.8  # [1/s^2] nearest-neighbour cohesion gain, eq. (26)
    k_ir: float = 1.6  # [m^2/s^2] intra-sub-swarm repulsion gain, eq. (31)
    k_path: float = 0.75  # [1/s^2] corridor-centering gain, eq. (32)
    k_l: float = 1.6  # [1/s^2] follower-subleader position coupling k_l, eq. (27)
    k_vl: float = 0.7  # [1/s] follower-subleader velocity coupling k_vl, eq. (27)
    k_coh: float = 0.9  # [1/s^2] centroid cohesion gain, eq. (29)
    d_safe: float = 1.5  # [m] safety distance of eq. (36) (also the metric threshold), Table A1
    sigma_occ: float = 0.2  # [-] occlusion attenuation factor, eq. (30), Table A1

    # ---------------------------------------------------------------- structural decisions, Table A1
    t_cd: float = 10.0  # T_cd [s] split-merge cooldown, eq. (13)
    r_in: float = 8.0  # [m] encircle entry threshold, eq. (12)
    r_out: float = 11.0  # [m] encircle exit threshold, eq. (12)
    r_merge: float = 12.0  # [m] near-goal radius, eqs. (13), (15)
    d_merge: float = 8.0  # [m] inter-sub-swarm merge distance, eq. (16)

    # ---------------------------------------------------------------- follower reassignment, Table A1
    w_sl: float = 1.0  # w [-] subleader-distance weight, eq. (41)
    w_c: float = 0.5  # w_c [-] waypoint-distance weight, eq. (41)
    delta_min: float = 2.0  # Delta_min [m] minimum cost improvement, eq. (41)
    tau_ra: float = 2.0  # tau_ra [s] per-follower cooldown, Section 4.4
    n_move_max: int = 3  # N_move^max transfers per planner update, Section 4.4

    # ---------------------------------------------------------------- reference trajectory (ours)
    v_s: float = 3.0  # ours [m/s] cruise speed v_s: crosses the 70 m scenes in ~40 s, leaving time to form the encircle ring
    eps_v: float = 0.5  # ours [m] eps_v of eq. (23): the slot velocity ramps down within ~0.5 m of the slot
    spacing: float = 1.4  # ours [m] spacing of the equilibrium formation (alpha_s = spacing (k_p + k_path) / k_p, see docs)
    aspect_max: float = 3.0  # ours [-] the template is squeezed across a narrow corridor (area kept) up to this aspect ratio
    lane_margin: float = 2.0  # ours [m] the squeezed formation keeps this from each side of the corridor (d_safe + 0.5)
    lead: float = 3.0  # ours [m] leash: waypoint c_s stays within this distance ahead of the sub-swarm centroid
    through: float = 3.0  # ours [m] the corridor target lies this far beyond the gap's throat
    r_enc: float = 6.0  # ours [m] encircle radius: paper's E_mean = 6.1 m with R_goal = 1 (r_succ = 8 m)
    enc_clear: float = 2.0  # ours [m] encircle slots keep this clearance from LiDAR returns (> d_safe)

    # ---------------------------------------------------------------- interaction radii (ours)
    r_sep: float = 1.6  # ours [m] r_sep of eq. (25): global separation acts inside ~one UAV spacing
    d_ir: float = 1.2  # ours [m] d_ir of eq. (31): shorter than r_sep, as Section 4.2 requires
    d_thr: float = 2.0  # ours [m] d_thr of eq. (26): a nearest neighbour farther than 2 m is drifting away
    d_0: float = 12.5  # ours [m] d_0 of eq. (27): > 2 r_enc, so the encircle ring (followers up to 2 r_enc from the subleader) is not pulled in
    d_c: float = 6.5  # ours [m] d_c of eq. (29): > r_enc, so the ring is not pulled in; acts on stragglers only
    d_floor: float = 0.05  # ours [m] distances are floored here before 1/d and 1/d^2 (bounded forces)

    # ---------------------------------------------------------------- corridor detection (ours)
    w_pass: float = 2.0  # ours [m] narrowest gap a UAV may be routed through (0.4 m body + margins)
    w_split: float = 6.0  # ours [m] a gap counts as a split path (n_c) if a >=5-agent sub-swarm (~3 m across) passes it with d_safe = 1.5 m each side
    h_open: float = 0.5  # ours [m] the ring must rise this much between two minima to form an opening
    toward_deg: float = 80.0  # ours [deg] a corridor leads toward the goal if its exit direction is within this of the goal bearing (< 90: never back)
    gap_depth: float = 0.6  # ours [m] (passage mode) the peak return must lie this far from the throat: a concave corner seen at a grazing angle (<= one ray spacing, 0.35 m at R_L) is no passage
    switch_margin: float = 3.0  # ours [m] route-cost margin before a sub-swarm switches corridor (hysteresis)
    max_subswarms: int = 3  # ours [-] a split creates at most this many sub-swarms
    min_size: int = 4  # ours [-] smallest sub-swarm a split may create

    # ---------------------------------------------------------------- safety stack (ours; Section 5.3)
    v_min_frac: float = 0.5  # ours [-] adaptive cruise: v_s is scaled down to this fraction in tight places
    clr_slow: float = 3.0  # ours [m] adaptive cruise acts when the sub-swarm's closest LiDAR return is nearer than this
    v_cap_frac: float = 1.3  # ours [-] speed cap of the safety filter: 1.3 v_s (room to catch up with the formation)
    brake_margin: float = 0.5  # ours [m] braking barrier: stopping distance kept from every LiDAR return
    a_brake: float = 1.5  # ours [m/s^2] braking barrier: deceleration budget (< a_max, leaves room for the other terms)
    agent_brake: float = 2.0  # ours [m/s^2] (passage mode) agent braking barrier: a member's own braking budget when closing on a neighbour (1.5: gates R_goal 0.8 on seed 4; 2.6: more contacts); 0 switches the barrier off
    agent_margin: float = 0.7  # ours [m] (passage mode) agent braking barrier: a member stops this far from the neighbour in front (contact 0.4 m + 0.3 m; 0.6: twice the contacts on the gates, 0.8: R_goal 0.6-0.8 on some gates seeds before the tube change, 1.0: Y = 0)
    agent_guard: bool = True  # ours: contact guard (forces.agent_guard), every agent brakes for its neighbours with priority over the clip of eq. (39); False = eq. (39) alone (the faithful build)
    guard_brake: float = 2.2  # ours [m/s^2] contact guard: braking each agent of a closing pair is assumed to use (< a_max: head-on pairs need exactly this each; 2.0: one box_field_2 seed of ten stalls in a pocket, 1.8: dense_cross_blocks R_unsafe 0.228)
    guard_margin: float = 0.5  # ours [m] contact guard: a closing pair stops this far apart (contact 0.4 m + 0.1 m)
    trail_follow: bool = True  # ours: a member cut off from its sub-swarm (slot, subleader and centroid behind obstacles, > d_c from the centroid) retraces its teammates' trail instead of pulling at its slot through the wall (Hes._follow_trail); False = eqs. (24)/(32) toward the slot and c_s always
    wp_clear: float = 2.0  # ours [m] the waypoint c_s is pushed this far from LiDAR returns (half the corridor width if narrower)

    # ---------------------------------------------------------------- passage mode (ours, beyond the paper; docs "Passage mode")
    passage_mode: bool = True  # ours: members inside the tube of their route's throat use d_safe_eff = min(d_safe - passage_relief, w/2 - passage_margin) in eq. (36); False = the paper's law everywhere
    passage_margin: float = 0.3  # ours [m] clearance kept between the throat's centre line and d_safe_eff: the near-obstacle term engages beyond 0.3 m off centre
    passage_band: float = 1.2  # ours [m] a route throat is a passage when the free band the paper's law leaves in it, w - 2 d_safe, is narrower than this (3 body diameters: room for one file). The first rule, w < 2 (d_safe + passage_margin), was a 0.6 m band: 4 m gates left 1 m and the swarm queued there without passage mode (hes_gates_4m_shifted Y 0). 1.6 m was tried and dropped: centred 4.2 m gates fell from Y 1 to 0.6
    passage_relief: float = 0.2  # ours [m] inside a passage's tube d_safe_eff <= d_safe - passage_relief, so a throat wider than 2 (d_safe + passage_margin) still widens its band (4 m gate: 1.0 -> 1.4 m) and its members queue as in any passage
    passage_len: float = 2.5  # ours [m] tube half-length along the throat normal: d_safe (corner reach) + 1 m (wall thickness either side of the detected throat)
    passage_confirm: float = 5.0  # ours [s] a narrow throat becomes a passage after being the route, with no wider corridor reported, this long (2 s engaged passages beside blocks that the swarm can fly around: dense_cross_blocks R_unsafe 0.25)
    passage_memory: float = 20.0  # ours [s] a throat keeps its passage this long after the sub-swarm's route moved on (members still in front of it)
    passage_queue: float = 20.0  # ours [m] a member in front of an earlier throat queues for it when within this distance (R_L: it can see the throat)
    passage_head: int = 2  # ours [-] once this many members have crossed the route's passage they are the head (waypoint, subleader) and the rest queue for it: the head moves on while the tail streams through (1 jams the mouth; 3 leaves the whole sub-swarm in formation at the mouth longer, gates seed 4 fails)
    passage_reach: float = 1.5  # ours [m] tube half-width beyond w/2: an agent approaching within d_safe of the throat's corners is inside

    # ---------------------------------------------------------------- stall planner (ours, beyond the paper; docs "Stall planner")
    stall_plan: bool = True  # ours: a sub-swarm whose most advanced member has not come plan_progress closer to the goal for plan_stall s follows a path planned on the map of its rings' returns (plan.py) instead of the reactive corridor choice; False = the reactive choice always
    plan_stall: float = 10.0  # ours [s] no progress this long engages the planner (a queue streaming through a gate, or a formation squeezing round a block, advances its head well within it)
    plan_progress: float = 1.0  # ours [m] progress = the most advanced member comes this much closer to the goal than ever before
    plan_cell: float = 0.2  # ours [m] map cell (half the 0.4 m body)
    plan_clear: float = 0.6  # ours [m] a path keeps this from every return seen: > brake_margin (0.5 m), where the wall braking barrier stops an agent dead (0.4: four agents froze in the middle of a 0.98 m gap); gaps from ~1.2 m up are passable
    plan_weight: float = 1.0  # ours [-] path cost per metre is 1 + plan_weight (d_safe - clearance) / clearance below d_safe: a squeeze at 0.5 m clearance costs 3 m per metre, at 0.75 m (a 1.5 m gap) 2 m, so wider ways round win unless much shorter and a path keeps to the middle of a gap
    plan_look: float = 2.0  # ours [m] the corridor target is the path point this far (arc length) past the centroid's nearest path point
    plan_every: float = 1.0  # ours [s] replanning interval while engaged (the map grows as the swarm moves)

    # ---------------------------------------------------------------- ablations (Simulation 2)
    safety_stack_off: bool = False  # True: waypoint regulation (rate limit, leash, clearance), adaptive cruise and safety filter off; a_max -> a_max_relaxed
    occlusion_attenuation: bool = True  # False: sigma_occ = 1 (Table 4 "w/o occ. attenuation")
    acceleration_bound: bool = True  # False: a_max -> a_max_relaxed (Table 4 "w/o acc. bound")
    a_max_relaxed: float = 26.0  # ours [m/s^2] the "very loose" bound of the ablations: 10 x a_max

    # ---------------------------------------------------------------- decision source
    decision: str = "rule"  # rule | ollama | openai | llamacpp | replay, Section 3.3 (docs/llm.md)
    llm_url: str = ""  # model server URL; "" = the back end's default (Ollama :11434, OpenAI-compatible :8000/v1)
    llm_model: str = "qwen2.5:3b"  # model name, Section 3.3 (the paper also runs qwen3.5:4b)
    llm_timeout: float = 120.0  # [s] per-call timeout, Section 3.3
    llm_interval: int = 50  # T_llm [steps] between LLM calls, eq. (20) (5 s at dt = 0.1 s, Section 3.3)
    llm_gguf: str = ""  # GGUF model file for decision=llamacpp
    llm_latency: str = "blocking"  # blocking (paper) | real | fixed:SECONDS (ours: the swarm flies on while the model thinks)
    llm_replay: str = ""  # transcript or run directory for decision=replay
    llm_response_format: str = "json_object"  # openai back end: json_object | json_schema | none
    llm_threads: int = 0  # llama.cpp CPU threads (0: llama-cpp-python's default)

    def __post_init__(self) -> None:
        validate_llm(self)  # decision and llm_* (raises ConfigError)
        if not self.r_out > self.r_in:
            raise ConfigError(f"hes: need r_out > r_in (eq. 12), got r_in={self.r_in}, r_out={self.r_out}")
        for name in ("dt", "lidar_range", "r_trigger", "a_max", "v_s", "eps_v", "spacing", "d_safe", "r_enc"):
            if not getattr(self, name) > 0:
                raise ConfigError(f"hes: {name} must be > 0, got {getattr(self, name)}")
        if not 0.0 < self.sigma_occ <= 1.0:
            raise ConfigError(f"hes: sigma_occ must be in (0, 1], got {self.sigma_occ}")
        if self.n_rays < 8:
            raise ConfigError(f"hes: n_rays must be >= 8, got {self.n_rays}")
        if self.max_subswarms < 1 or self.min_size < 1 or self.n_move_max < 0:
            raise ConfigError("hes: max_subswarms and min_size must be >= 1, n_move_max >= 0")
        for name in ("passage_margin", "passage_len", "passage_reach", "passage_band", "passage_relief", "agent_brake",
                     "agent_margin", "guard_brake", "guard_margin", "a_brake", "brake_margin", "w_split",
                     "plan_stall", "plan_progress", "plan_weight", "plan_look"):
            if not getattr(self, name) >= 0:  # our safety-stack and passage-mode lengths [m] and decelerations [m/s^2]
                raise ConfigError(f"hes: {name} must be >= 0, got {getattr(self, name)}")
        for name in ("plan_cell", "plan_every", "plan_clear"):  # plan_clear divides the path cost
            if not getattr(self, name) > 0:
                raise ConfigError(f"hes: {name} must be > 0, got {getattr(self, name)}")
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
