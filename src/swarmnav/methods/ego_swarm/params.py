"""Parameters of the ``ego-swarm`` method: EGO-Swarm / EGO-Planner and the authors' launch files.

Sources: "paper" = EGO-Planner (Zhou et al., RA-L 2020) or EGO-Swarm (Zhou et al., ICRA 2021);
"launch" = the authors' ``ego-planner-swarm`` ``advanced_param.xml`` / ``swarm.launch`` (values
read, nothing copied); "shared" = the Table II comparison's common dynamics (SPH Table I);
"ours" = a choice the papers leave open, with the reason in the doc string.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar, Literal

from swarmnav.params import param
from swarmnav.planning.schedule import check_plan_steps



@dataclass(frozen=True, slots=True)
class EgoSwarmParams:
    """EGO-Swarm (Zhou, Wang, Gao et al., ICRA 2021) on EGO-Planner's ESDF-free optimiser."""

    #: ``swarmnav`` is the default build: the papers' planner with our two named parts on (the A* guide
    #: after a failed replan, the brake for another robot's plan); ``paper`` switches both off.
    PRESETS: ClassVar[dict[str, dict[str, Any]]] = {
        "swarmnav": {},
        "paper": {"retry_guide": "previous", "brake_on_swarm": False},
    }
    DEFAULT_BUILD: ClassVar[str] = "swarmnav"
    PRESET_DOCS: ClassVar[dict[str, str]] = {
        "swarmnav": "our build: EGO-Swarm / EGO-Planner with the launch values and our two named parts "
                    "(retry_guide, brake_on_swarm; chosen on seeds 1-10, docs/methods/ego-swarm.md)",
        "paper": "EGO-Swarm / EGO-Planner with the launch values and the readings the papers leave open, "
                 "without our two parts",
    }

    # --- shared dynamics of the Table II comparison (replace the launch files' max_vel / max_acc) ---
    v_max: float = param(1.0, "m/s", "(0, inf)", "shared (SPH Table I; launch max_vel)",
                         "speed bound of the vehicle and of the planner (eq. feasibility)")
    a_max: float = param(1.5, "m/s^2", "(0, inf)", "shared (SPH Table I; launch max_acc)",
                         "acceleration bound of the vehicle and of the planner")
    dt: float = param(0.02, "s", "[0.001, 0.1]", "ours",
                      "control step: 50 Hz, as SPH's released code; plans change at most every check_period")
    k_p: float = param(5.0, "1/s^2", "[0, inf)", "shared (SPH eq. 13, Table I)",
                       "position gain of the PD tracking law (the authors fly an SO(3) controller)")
    k_v: float = param(3.5, "1/s", "[0, inf)", "shared (SPH eq. 13, Table I)", "velocity gain of the tracking law")
    # --- optimisation (launch advanced_param.xml) ---
    lambda_smooth: float = param(1.0, "", "[0, inf)", "launch optimization/lambda_smooth", "smoothness (jerk) weight")
    lambda_collision: float = param(0.5, "", "[0, inf)", "launch optimization/lambda_collision",
                                    "ESDF-free {p, v} collision weight")
    lambda_feasibility: float = param(0.1, "", "[0, inf)", "launch optimization/lambda_feasibility",
                                      "velocity / acceleration feasibility weight")
    lambda_fitness: float = param(1.0, "", "[0, inf)", "launch optimization/lambda_fitness",
                                  "refinement: weight of the distance to the rebounded curve")
    lambda_swarm: float = param(0.5, "", "[0, inf)", "released combineCostRebound (= lambda_collision)",
                                "swarm (reciprocal) collision weight; the released code weighs it as the obstacle term")
    dist0: float = param(0.5, "m", "(0, inf)", "launch optimization/dist0", "obstacle clearance s_f of the {p, v} cost")
    swarm_clearance: float = param(0.5, "m", "(0, inf)", "launch optimization/swarm_clearance",
                                   "per-robot clearance: two trajectories are pushed 2 x swarm_clearance apart")
    swarm_min_gap: float = param(0.5, "m", "[0, inf)", "released (swarm_clearance)",
                                 "restart the optimisation (weights doubled) while a control point passes another "
                                 "robot's plan closer than this (0.6 m, tried on seeds 1-10: more failed replans, more contacts)")
    ctrl_spacing: float = param(0.4, "m", "[0.05, 5]", "launch manager/control_points_distance",
                                "control-point spacing; knot span = ctrl_spacing / v_max")
    feasibility_tolerance: float = param(0.05, "", "[0, 10]", "launch manager/feasibility_tolerance",
                                         "time re-allocation when a limit is exceeded by more than this fraction")
    max_rebound: int = param(20, "", "[0, 100]", "released rebound_optimize (rebound_times <= 20)",
                             "rebounds (re-find {p, v} pairs for newly colliding stretches, optimise again)")
    max_restart: int = param(3, "", "[0, 100]", "released rebound_optimize (MAX_RESART_NUMS_SET)",
                             "restarts with doubled collision and swarm weights while the plan still collides")
    max_iter: int = param(200, "", "[1, 10000]", "released lbfgs max_iterations", "L-BFGS-B iteration cap per optimisation")
    # --- replanning (launch fsm/*) ---
    planning_horizon: float = param(7.5, "m", "(0, inf)", "launch swarm.launch planning_horizon",
                                    "local goal: this far along the global path")
    replan_period: float = param(2.0, "s", "(0, inf)", "launch fsm/thresh_replan_time",
                                 "replan after flying this long on one plan")
    no_replan_dist: float = param(1.0, "m", "[0, inf)", "launch fsm/thresh_no_replan_meter",
                                  "no periodic replan this close to the goal")
    emergency_time: float = param(1.0, "s", "[0, inf)", "launch fsm/emergency_time_",
                                  "a collision predicted sooner than this after a failed replan: brake")
    check_period: float = param(0.05, "s", "(0, inf)", "released collision-check timer (20 Hz)",
                                "how often each robot checks its plan against its map and the others' plans")
    swarm_check_horizon: float = param(3.0, "s", "(0, inf)", "launch fsm/planning_horizen_time",
                                       "how far ahead the plan is checked against the others' plans")
    swarm_check_clearance: float = param(0.8, "m", "(0, inf)", "ours",
                                         "a newer plan of another robot passing closer than this triggers a replan "
                                         "(between contact, 0.4 m, and the optimiser's 2 x swarm_clearance)")
    reset_lag: float = param(0.5, "m", "[0, inf)", "ours",
                             "a replan starts from the reference unless the robot is farther than this from it")
    # --- map (launch grid_map/*) ---
    sensing_range: float = param(5.0, "m", "(0, inf)", "launch grid_map/depth_filter_maxdist",
                                 "obstacles enter a robot's map within this range")
    grid_resolution: float = param(0.1, "m", "[0.02, 1]", "launch grid_map/resolution", "occupancy cell")
    inflation: float = param(0.3, "m", "[0, inf)", "ours (launch obstacles_inflation 0.099 + body radius 0.2)",
                             "cells this close to an obstacle are occupied")
    max_expand: int = param(50_000, "", "[1, inf)", "ours", "A* expansion cap per guide-path search")
    max_map_bytes: int = param(2 * 2**30, "B", "[1, inf)", "ours",
                               "largest memory the robots' maps may take; a larger world is refused")
    # --- goals (EGO-Swarm gives each drone its own goal) ---
    goal_disc: float = param(2.4, "m", "[0, inf)", "ours",
                               "per-robot goals fill a disc of this radius around the scene's goal (within the "
                               "3 m arrival radius), assigned to the spawn layout")
    brake_on_swarm: bool = param(True, "", None, "ours",
                                 "a failed replan also brakes when the plan it keeps passes a newer plan of another "
                                 "robot closer than swarm_clearance within emergency_time (the released emergency "
                                 "stop looks at obstacles)")
    retry_guide: Literal["astar", "previous"] = param(
        "astar", "", None, "ours",
        "initial path of the replan after a failed one: an A* path to the local goal on the robot's map (ours; "
        "the released planner retries with random initial polynomials), or the usual rest of the plan + line")
    force_fail: bool = param(False, "", None, "ours (tests)", "every optimisation reports failure (fallback test)")

    def __post_init__(self) -> None:
        # single values are checked against their declared ranges by params.build; here the
        # relation that keeps a plan finite
        check_plan_steps("ego-swarm", "planning_horizon", self.planning_horizon, self.v_max, self.a_max, self.dt)
