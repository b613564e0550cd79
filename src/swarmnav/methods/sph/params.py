"""Parameters of the ``sph`` method: Table I of the SPH paper, plus the choices it leaves open."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal


@dataclass(frozen=True, slots=True)
class SphParams:
    """SPH swarm navigation (Li et al., RA-L 2025). Table I values unless marked "our choice"."""

    # --- swarm (Table I) ---
    c: float = 54.97  # kernel normalisation constant [-], eq. (4)
    R: float = 20.0  # connection range [m], eq. (1); also the perception range (Section IV)
    h: float = 10.0  # kernel radius [m], eq. (4)
    m: float = 1.0  # particle mass [kg]
    k_den: float = 1.0  # aggregation (density) gain, Alg. 1 line 8
    k_rep: float = 1.0  # dispersion (repulsion) gain [m^2/s^2], Alg. 1 line 9
    k_vis: float = 1.5  # velocity damping [1/s], Alg. 1 line 10
    k_env: float = 10.0  # obstacle gain [1/s^2], Alg. 1 line 11
    v_max: float = 1.0  # [m/s], eq. (2)
    a_max: float = 1.5  # [m/s^2], eq. (2)
    rho0: float = 1e6  # reference density, Alg. 1 line 8
    gamma: float = 7.0  # density sensitivity, Section III-A ("gamma = 7")
    # --- planning (Table I) ---
    T_p: float = 0.2  # replanning interval [s]
    lambda_s: float = 5.0  # smoothness weight, eq. (8)
    lambda_c: float = 1000.0  # collision weight, eq. (8)
    lambda_f: float = 1.0  # feasibility weight, eq. (8)
    k_p: float = 5.0  # position tracking gain [1/s^2], eq. (13)
    k_v: float = 3.5  # velocity tracking gain [1/s], eq. (13)
    d_thr: float = 0.5  # obstacle safety threshold [m], eqs. (5), (10)
    # --- our choices (the paper does not give them; see docs/methods/sph.md) ---
    dt: float = 0.01  # control step [s]: the text's ">= 100 Hz" swarm control (Sec. III); released code 0.02
    kernel: Literal["paper", "released"] = "paper"  # eq. (4) as printed, or the released C++
    r_floor: float = 0.05  # distance floor in the 1/r repulsion [m] (finite force)
    esdf_resolution: float = 0.1  # ESDF grid [m], as the released sdf_map
    grid_resolution: float = 0.1  # grid-search cell [m], as the released A*
    inflation: float = 0.3  # grid-search body clearance [m]: body radius 0.2 m + one cell (last tier)
    plan_clearance: float = 0.9  # first-tier grid-search clearance [m]: d_thr + a body diameter, so a
    #   neighbour abreast of the path at contact distance is still outside the ESDF force band (0 = off)
    plan_clearance_cost: float = 2.0  # extra A* cost per metre inside plan_clearance [-]: detours up to
    #   ~2 m per metre of hugging are preferred (ours)
    plan_neighbours: float = 0.0  # [m] cells this close to a visible neighbour cost like the wide band in
    #   the grid search (ours; 0 = off, as the paper's planner: on, it made contacts more frequent)
    plan_neighbours_range: float = 3.0  # [m] only visible neighbours this close enter the search
    ctrl_spacing: float = 0.5  # control-point spacing along the initial path [m] (released dist_p)
    ctrl_seed: Literal["knots", "released"] = "knots"  # initial interior control points: the path points
    #   at the knot times after C_2 (ours, reference at v_max), or path[1..-2] as the released code
    #   (repeats the points C_2 and C_{K-2} stand for: the reference crawls at ~0.7 v_max)
    plan_speed: float = 1.0  # knot speed of the reference as a fraction of v_max [-] (1: the released
    #   beta = v_max / dist_p)
    horizon_points: int = 10  # path points per local plan (released: first 10); 0 = whole path
    max_iter: int = 200  # L-BFGS-B iteration cap (released opt_maxeval)
    max_expand: int = 2_000_000  # A* expansion cap per search
    search_weight_3d: float = 2.0  # [-] heuristic weight of the 3-D A* (ours; released lambda_heu = 10): paths at
    #   most 2x the optimal cost (~7 % longer measured), 50x fewer expansions than 1.001 in a 3-D forest (the planar
    #   search keeps 1.001, a tie-break only)
    replan_from: Literal["state", "reference"] = "reference"  # start state of a replan (released)
    ref_reset: float = 0.5  # "reference" mode: bound on the reference lag at a replan [m] (ours; released 1.0):
    #   k_p ref_reset = k_rep / (2 body radius) = 2.5 m/s^2, the tracking pull never beats the contact repulsion
    ref_clamp: bool = True  # beyond ref_reset move the start to ref_reset from the robot (ours; False: onto
    #   the robot, released): the pull stays continuous, no jump of the reference to the robot
    reset_velocity: bool = False  # on a ref_reset also restart from the measured velocity (ours); the
    #   released planner moves only the start position and keeps the reference's velocity/acceleration
    goal_spread: float = 0.0  # per-robot goal = goal + goal_spread * (spawn_i - spawn centroid)
    plan_once: bool = False  # plan the whole path once at t = 0 (Fig. 3B protocol)
    once_hold: float = 0.5  # plan_once only [m]: a robot's reference clock slows once its lag passes
    #   once_hold / 2 and stops at once_hold (v* = phi v, a* = phi^2 a), and the position error is capped at
    #   once_hold (ours: k_p once_hold = k_rep / (2 body radius)); 0 = off, the reference runs on by time alone
