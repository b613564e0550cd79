"""Parameters of the HES method: the paper's Table A1 (:class:`PaperParams`), the values it leaves
open (:class:`CoreParams`), and one nested record per extension of ours (``parts/params.py``).

Every field carries its unit and its source. ``Table A1`` / ``eq. (n)`` values are the
paper's and must not be tuned. Fields marked ``ours`` are not given by the paper; the reason
for each value is in its line and in ``docs/methods/hes.md``. One parameter set serves all
scenes (nothing here is scene-specific). Names are dotted (``paper.k_p``, ``passage.on``); the
flat names of earlier versions are aliases (``HesParams.ALIASES``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields
from typing import Any, ClassVar

from swarmnav.errors import ConfigError
from swarmnav.llm.config import DECISIONS, validate as validate_llm  # noqa: F401  DECISIONS: rule + LLM back ends
from swarmnav.methods.hes.parts.params import (
    AblationParams, BarrierParams, CommitParams, GuardParams, HoldParams, PassageParams, SafetyParams, StallParams,
    TrailParams, WidthParams,
)
from swarmnav.params import param


@dataclass(frozen=True, slots=True)
class PaperParams:
    """The paper's parameters: Table A1 and the step of Section 5.1 (never tuned)."""

    dt: float = param(0.1, "s", "[0.0001, 1]", "Section 5.1", "integration / decision step")
    n_rays: int = param(360, "", "[8, 36000]", "Table A1", "LiDAR rays n_theta (1 deg resolution)")
    lidar_range: float = param(20.0, "m", "(0, inf)", "Table A1", "LiDAR range R_L")
    r_trigger: float = param(14.0, "m", "(0, inf)", "eq. (35)-(36), Table A1", "R_t avoidance trigger radius")
    a_max: float = param(2.6, "m/s^2", "(0, inf)", "eq. (39), Table A1", "a_xy^max acceleration saturation")
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
    t_cd: float = param(10.0, "s", "[0, inf)", "eq. (13), Table A1", "T_cd split-merge cooldown")
    r_in: float = param(8.0, "m", "(0, inf)", "eq. (12), Table A1", "encircle entry threshold")
    r_out: float = param(11.0, "m", "(0, inf)", "eq. (12), Table A1", "encircle exit threshold")
    r_merge: float = param(12.0, "m", "(0, inf)", "eqs. (13), (15), Table A1", "near-goal radius")
    d_merge: float = param(8.0, "m", "(0, inf)", "eq. (16), Table A1", "inter-sub-swarm merge distance")
    w_sl: float = param(1.0, "", "[0, inf)", "eq. (41), Table A1", "w subleader-distance weight")
    w_c: float = param(0.5, "", "[0, inf)", "eq. (41), Table A1", "w_c waypoint-distance weight")
    delta_min: float = param(2.0, "m", "[0, inf)", "eq. (41), Table A1", "Delta_min minimum cost improvement")
    tau_ra: float = param(2.0, "s", "[0, inf)", "Section 4.4, Table A1", "tau_ra per-follower cooldown")
    n_move_max: int = param(3, "", "[0, inf)", "Section 4.4, Table A1", "N_move^max transfers per planner update")


@dataclass(frozen=True, slots=True)
class CoreParams:
    """Values the paper leaves open in its own method (ours: each value's reason in its line)."""

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
    enc_yield: float = param(0.0, "m", "[0, inf)", "ours",
        "0: off; > 0: an encircling member's slot moves in toward the goal until it lies this far "
        "from every return of the member's own LiDAR ring, so the turning ring bends around an "
        "obstacle near the goal (parts/encircle.py). The paper build's 3.5 m: d_safe plus ~2 m, what a "
        "member trails outside its slot on the turning ring (v_s^2 / (k_p r_enc) = 2.1 m: the "
        "centripetal 1.5 m/s^2 from the slot attraction); 3.0 m left default_corridor R_unsafe "
        "0.197, 4.0 m took sigma_E to 1.22 m")
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
    ke_ratio: bool = param(False, "", None, "ours",
        "the near-obstacle term of eq. (36), garbled in the paper's text: False = k_e (d_safe - d + "
        "1)^2 (48 m/s^2 at d_safe, 300 at contact); True = k_e (d_safe / d + 1)^2 (192 m/s^2 at "
        "d_safe, growing as 1/d^2), the reading under which relaxing the bound of eq. (39) "
        "degrades the flight as Table 4 reports (docs/reproduction.md)")
    projection: float = param(0.0, "m", "[0, inf)", "ours",
        "the geometric post-update safety projection of Section 5.3 (no formula given): 0 = off; > "
        "0: each agent's next step is shortened until it ends this far short of every LiDAR return "
        "ahead of it, so no agent crosses a wall in one step (parts/projection.py)")
    d_floor: float = param(0.05, "m", "(0, inf)", "ours",
        "distances are floored here before 1/d and 1/d^2 (bounded forces)")
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
    switch_margin: float = param(3.0, "m", "[0, inf)", "ours",
        "route-cost margin before a sub-swarm switches corridor (hysteresis)")
    rho_vis: float = param(0.4, "m", "[0, inf)", "ours",
        "half-width of the straight line from the centroid to a throat (or from a member to a trail "
        "point) that must be free of LiDAR returns for it to count as reachable / in view")
    max_subswarms: int = param(3, "", "[1, 1000]", "ours", "a split creates at most this many sub-swarms")
    min_size: int = param(4, "", "[1, inf)", "ours", "smallest sub-swarm a split may create")
    merge_rule: str = param("swarmnav", "", None, "ours",
        "swarmnav: merge two sub-swarms closer than d_merge only once their corridors have "
        "rejoined and T_cd has passed (RulePolicy rule 3); paper: merge whenever eq. (16) holds; "
        "paper_cooldown: eq. (16) once T_cd has passed since the last change (Table A1's "
        "split-merge cooldown read as holding merges too)")


@dataclass(frozen=True, slots=True)
class HesParams:
    """Every parameter of HES: the paper's Table A1 (``paper``), the values it leaves open (``core``),
    one record per extension of ours (switched by its ``on``), the ablations, and the decision source.

    ``--set`` names are dotted (``paper.k_p=0.7``, ``passage.on=false``); the flat names of earlier
    versions (``k_p``, ``passage_mode``) are accepted as aliases (``ALIASES``)."""

    #: Named parameter sets (``--set preset=NAME``): ``swarmnav`` is the default build;
    #: ``paper`` is the paper as written: every extension of ours that changes its decisions or
    #: its control law switched off, plus the readings its silence forces (the encircle ring
    #: circulating and giving way to obstacles near the goal, merges by eq. (16) under the
    #: split-merge cooldown, ...; docs/methods/hes.md, *The paper build*).
    PRESETS: ClassVar[dict[str, dict[str, Any]]] = {
        "swarmnav": {},
        "paper": {"passage.on": False, "guard.on": False, "stall.on": False, "trail.on": False,
                     "commit.on": False, "hold.on": False, "width.on": False,
                     "core.enc_orbit": True, "core.enc_yield": 3.5, "core.merge_rule": "paper_cooldown",
                     "core.ke_ratio": True, "core.projection": 0.1, "core.w_pass": 3.0, "ablation.keep_leash": True,
                     "ablation.relax_filter": True,
                     "ablation.a_max_relaxed": 260.0},
    }
    #: The preset the defaults are (``swarmnav methods hes`` lists what ``paper`` changes).
    DEFAULT_BUILD: ClassVar[str] = "swarmnav"
    #: ``paper`` was called ``faithful`` before issue 34; the old name resolves to the same values, so
    #: old specs and stored runs keep their meaning (a run's key hashes the resolved values, not the name).
    PRESET_ALIASES: ClassVar[dict[str, str]] = {"faithful": "paper"}
    PRESET_DOCS: ClassVar[dict[str, str]] = {
        "swarmnav": "our recommended build: the paper's method with every part of ours on (methods/hes/parts/; "
                    "docs/methods/hes.md, Our extensions)",
        "paper": "the paper as written (Sections 2-4, Table A1) plus the readings its silence forces, each named in "
                 "docs/methods/hes.md, The paper build (several chosen on seeds 1-10, re-measured on held-out "
                 "seeds 11-30: docs/reproduction/hes.md)",
    }
    #: Flat names of earlier versions -> their dotted name (accepted by ``--set``, specs and the API):
    #: the fields of ``paper``, ``core``, ``safety`` and ``ablation`` kept their names; then the others.
    ALIASES: ClassVar[dict[str, str]] = {
        **{f.name: f"{group}.{f.name}" for group, record in (("paper", PaperParams), ("core", CoreParams),
           ("safety", SafetyParams), ("ablation", AblationParams)) for f in fields(record)},
        "a_brake": "barrier.a_brake",
        "penalty_width": "width.penalty_width",
        "cut_time": "trail.cut_time",
        "gap_depth": "passage.gap_depth",
        "agent_brake": "passage.agent_brake",
        "agent_margin": "passage.agent_margin",
        "brake_margin": "barrier.margin",
        "wall_passes": "barrier.passes",
        "width_penalty": "width.on",
        "split_commit": "commit.on",
        "commit_time": "commit.time",
        "route_hold": "hold.on",
        "hold_time": "hold.time",
        "agent_guard": "guard.on",
        "guard_brake": "guard.brake",
        "guard_margin": "guard.margin",
        "trail_follow": "trail.on",
        "trail_every": "trail.every",
        "trail_len": "trail.length",
        "trail_reach": "trail.reach",
        "passage_mode": "passage.on",
        "passage_margin": "passage.margin",
        "passage_band": "passage.band",
        "passage_relief": "passage.relief",
        "passage_len": "passage.length",
        "passage_confirm": "passage.confirm",
        "passage_memory": "passage.memory",
        "passage_queue": "passage.queue",
        "passage_head": "passage.head",
        "passage_reach": "passage.reach",
        "passage_count": "passage.count",
        "stall_plan": "stall.on",
        "plan_stall": "stall.time",
        "plan_progress": "stall.progress",
        "plan_cell": "stall.cell",
        "plan_clear": "stall.clear",
        "plan_weight": "stall.weight",
        "plan_look": "stall.look",
        "plan_every": "stall.every",
        "plan_map_every": "stall.map_every",
        "plan_margin": "stall.margin",
    }

    paper: PaperParams = field(default_factory=PaperParams, metadata={"doc": "Table A1 and Section 5.1"})
    core: CoreParams = field(default_factory=CoreParams, metadata={"doc": "values the paper leaves open"})
    safety: SafetyParams = field(default_factory=SafetyParams, metadata={"doc": "adaptive motion regulation (safety stack)"})
    barrier: BarrierParams = field(default_factory=BarrierParams, metadata={"doc": "wall braking barrier"})
    guard: GuardParams = field(default_factory=GuardParams, metadata={"doc": "contact guard"})
    width: WidthParams = field(default_factory=WidthParams, metadata={"doc": "route-cost width penalty"})
    commit: CommitParams = field(default_factory=CommitParams, metadata={"doc": "split commitment"})
    hold: HoldParams = field(default_factory=HoldParams, metadata={"doc": "route hold"})
    trail: TrailParams = field(default_factory=TrailParams, metadata={"doc": "trail following"})
    passage: PassageParams = field(default_factory=PassageParams, metadata={"doc": "passage mode"})
    stall: StallParams = field(default_factory=StallParams, metadata={"doc": "stall planner"})
    ablation: AblationParams = field(default_factory=AblationParams, metadata={"doc": "Simulation 2 ablations"})

    # ---------------------------------------------------------------- decision source (Section 3.3)
    # the fields of swarmnav.llm.LlmParams, under the same names (shared with ``swarmnav llm``)
    decision: str = param("rule", "", None, "Section 3.3",
        "rule | ollama | openai | llamacpp | replay, Section 3.3 (docs/llm.md); oracle: the lookahead "
        "bound of ours (docs/oracle.md)")
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
    # ---------------------------------------------------------------- decision=oracle (ours, docs/oracle.md)
    oracle_horizon: float = param(20.0, "s", "(0, 1000]", "ours",
        "lookahead flown after each feasible action, the rule deciding (20 s: half the ~40 s crossing "
        "of the 70 m scenes at cruise speed)")
    oracle_w_reach: float = param(50.0, "m", "[0, inf)", "ours",
        "objective weight of R (fraction of agents at the goal at the horizon's end), metres of progress")
    oracle_w_success: float = param(100.0, "m", "[0, inf)", "ours",
        "objective weight of Y (R >= 0.8 at the horizon's end), metres of progress")
    oracle_w_crash: float = param(200.0, "m", "[0, inf)", "ours",
        "objective weight of the fraction of agents crashed within the horizon, metres of progress")
    oracle_w_unsafe: float = param(10.0, "m", "[0, inf)", "ours",
        "objective weight of the fraction of agent-steps within d_safe of an obstacle, metres of progress")
    oracle_margin: float = param(0.01, "m", "[0, inf)", "ours",
        "objective gain over the rule's action below which the oracle keeps the rule's action")

    def __post_init__(self) -> None:
        # single values are checked against their declared ranges by params.build; here the
        # relations between them
        validate_llm(self)  # decision and llm_* (raises ConfigError)
        c, a = self.core, self.paper
        if c.merge_rule not in ("swarmnav", "paper", "paper_cooldown"):
            raise ConfigError(f"hes: core.merge_rule must be swarmnav, paper or paper_cooldown, got {c.merge_rule!r}")
        if not a.r_out > a.r_in:
            raise ConfigError(f"hes: need paper.r_out > paper.r_in (eq. 12), got r_in={a.r_in}, r_out={a.r_out}")
        # the formation scale of targets.template; beyond the LiDAR range a subleader could not see
        # its own formation (and k_p -> 0 sends it to infinity)
        alpha = c.spacing * (a.k_p + a.k_path) / a.k_p if a.k_p > 0 else math.inf
        if not alpha < a.lidar_range:
            raise ConfigError(f"hes: the formation scale core.spacing (paper.k_p + paper.k_path) / paper.k_p = {alpha:g} m "
                              f"must be below paper.lidar_range ({a.lidar_range:g} m); raise paper.k_p or lower core.spacing")
        if not self.passage.relief < a.d_safe:
            raise ConfigError(f"hes: passage.relief must be < paper.d_safe ({a.d_safe} m), got {self.passage.relief}")

    # -- derived
    @property
    def dt(self) -> float:
        """The step [s] (``paper.dt``)."""
        return self.paper.dt

    @property
    def sigma(self) -> float:
        """Occlusion factor actually applied (1 when the ablation switches it off)."""
        return self.paper.sigma_occ if self.ablation.occlusion_attenuation else 1.0

    @property
    def a_bound(self) -> float:
        """Acceleration bound actually applied [m/s^2]."""
        if self.ablation.safety_stack_off or not self.ablation.acceleration_bound:
            return self.ablation.a_max_relaxed
        return self.paper.a_max

    @property
    def filtered(self) -> bool:
        """The safety filter (speed cap and wall braking barrier, ``WallBarrier``) acts: with the safety
        stack and ``barrier.on``, unless ``ablation.relax_filter`` lifts it with the bound of eq. (39)."""
        relaxed = self.ablation.relax_filter and not self.ablation.acceleration_bound
        return self.adaptive and self.barrier.on and not relaxed

    @property
    def leashed(self) -> bool:
        """c_s advances toward its target at the adaptive cruise speed on the ``core.lead`` leash (with
        the safety stack, or without it when ``ablation.keep_leash``); otherwise c_s is the target itself."""
        return self.adaptive or self.ablation.keep_leash

    @property
    def adaptive(self) -> bool:
        """The adaptive motion-regulation layers (waypoint regulation, adaptive cruise, safety filter) are on."""
        return not self.ablation.safety_stack_off
