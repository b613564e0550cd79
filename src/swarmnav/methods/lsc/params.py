"""Parameters of the ``lsc`` method: the paper (Park, Kim et al., RA-L 2022) and the authors'
``simulation.launch`` (qwerty35/lsc_planner), with the shared dynamics bounds of the SPH Table II
comparison."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar, Literal

from swarmnav.errors import ConfigError
from swarmnav.params import param


@dataclass(frozen=True, slots=True)
class LscParams:
    """LSC planner. Values from the paper or ``simulation.launch`` unless marked "ours"."""

    #: ``swarmnav`` is the default build: the paper's planner with its bounds on the Euclidean norm
    #: the shared dynamics enforce (limits=norm, ours); ``paper`` bounds each axis as the paper does.
    PRESETS: ClassVar[dict[str, dict[str, Any]]] = {
        "swarmnav": {},
        "paper": {"limits": "axis"},
    }
    DEFAULT_BUILD: ClassVar[str] = "swarmnav"
    PRESET_DOCS: ClassVar[dict[str, str]] = {
        "swarmnav": "our build: the LSC planner with limits=norm (velocity and acceleration bounded on the norm the "
                    "shared dynamics enforce; docs/methods/lsc.md)",
        "paper": "the paper's per-axis velocity and acceleration bounds, with the readings the paper leaves open",
    }

    # --- dynamics and control ---
    dt: float = param(0.01, "s", "[0.001, 0.1]", "ours (SPH's control step, shared by the Table II peers)",
        "control step")
    v_max: float = param(1.0, "m/s", "(0, inf)", "SPH Table I (shared)", "speed bound")
    a_max: float = param(1.5, "m/s^2", "(0, inf)", "SPH Table I (shared)", "acceleration bound")
    k_p: float = param(5.0, "1/s^2", "[0, inf)", "SPH eq. (13), Table I (the shared tracker)", "position gain")
    k_v: float = param(3.5, "1/s", "[0, inf)", "SPH eq. (13), Table I (the shared tracker)", "velocity gain")
    # --- trajectory (paper Section III; simulation.launch traj/*) ---
    segment_time: float = param(0.2, "s", "[0.02, 2]", "simulation.launch traj/dt (= the replanning period)",
        "duration of one Bernstein segment; every robot replans every segment_time")
    segments: int = param(5, "", "[2, 20]", "simulation.launch traj/M", "segments M of the plan (horizon M x segment_time)")
    degree: int = param(5, "", "[3, 9]", "simulation.launch traj/n", "degree n of each Bernstein segment")
    phi: int = param(3, "", "[1, 4]", "simulation.launch traj/phi (3: minimum jerk)",
        "derivative whose squared integral is the control cost (needs phi <= degree)")
    continuity: int = param(2, "", "[0, 4]", "ours (the paper: continuous up to phi - 1)",
        "derivatives 0..continuity continuous between segments (needs continuity < degree)")
    w_goal: float = param(1.0, "1/m^2", "(0, inf)", "simulation.launch opt/terminal_weight",
        "weight of the squared error of the plan's end to the current goal")
    w_jerk: float = param(0.01, "s^5/m^2", "[0, inf)", "simulation.launch opt/control_input_weight",
        "weight of the integral of the squared jerk")
    limits: Literal["axis", "norm"] = param("norm", "", None, "paper (per axis); norm: ours",
        "velocity and acceleration bounds: axis = every derivative control point within the bound per axis "
        "(the paper), which lets a diagonal plan ask sqrt(D) x what the shared norm-saturated dynamics give; "
        "norm = within a polygon (2-D: 8 sides) / polyhedron (3-D: 14 faces) inscribed in the ball of the bound")
    # --- collision constraints ---
    agent_margin: float = param(0.05, "m", "[0, inf)", "ours (tracking error of the shared tracker)",
        "an agent's radius in the LSC is its body radius plus this")
    obstacle_margin: float = param(0.1, "m", "[0, inf)", "ours (simulation.launch grid/margin 0.1)",
        "obstacles grow by the body radius plus this in the robot's map, the SFC boxes and the grid search")
    sfc_growth: float = param(1.0, "m", "(0, inf)", "ours (the plan reaches v_max x horizon = 1 m)",
        "each face of a segment's SFC box grows at most this far beyond the previous plan's segment")
    sfc: Literal["grown", "shifted"] = param("shifted", "", None, "the authors' code (shifted; the paper leaves it "
        "implicit); grown: ours, chosen against on training forests 1-2 (docs)",
        "safe flight corridor: grown = each segment's box grown from the initial trajectory's segment, faces in turn; "
        "shifted = the committed plan's boxes shifted by one segment, and a new last box grown from the initial "
        "trajectory's end towards the current goal first")
    qp_tol: float = param(2e-3, "", "(0, 1]", "ours",
        "a QP solution violating a constraint by more than this (m, m/s or m/s^2) is a failed solve")
    max_iter: int = param(4000, "", "[10, 1000000]", "ours", "OSQP iterations per solve")
    # --- maps and goal planning (paper Section V; simulation.launch plan/*, grid/*) ---
    sensing_range: float = param(8.0, "m", "(0, inf)", "ours (as MADER's and EGO-Swarm's here)",
        "an obstacle joins a robot's map once its bounding box is this close")
    grid_resolution: float = param(0.1, "m", "(0, inf)", "ours (simulation.launch world/resolution 0.1)",
        "cell of the per-robot map, the SFC box expansion and the grid search")
    max_expand: int = param(200000, "", "[1, 100000000]", "ours", "A* expansion budget")
    priority: bool = param(True, "", None, "paper (priority-based goal planning)",
        "deadlock handling: agents nearer their goals have priority; a robot's grid search avoids the "
        "higher-priority agents, and it backs away from one closer than priority_dist")
    priority_cost: float = param(20.0, "", "[0, inf)", "ours",
        "extra cost per metre of the grid search through a disc around a higher-priority agent")
    priority_dist: float = param(0.6, "m", "[0, inf)", "simulation.launch plan/priority_dist_threshold 0.4 (for its "
        "0.15 m robots), scaled to the 0.2 m bodies here",
        "a robot closer than this to a higher-priority agent backs away from it")
    goal_threshold: float = param(0.1, "m", "[0, inf)", "simulation.launch plan/goal_threshold",
        "an agent this close to its goal has arrived (it no longer takes priority; it stops replanning once its "
        "plan rests there)")
    goal_disc: float = param(2.4, "m", "[0, inf)", "ours (EGO-Swarm's and MADER's, planning/goals.py)",
        "per-robot goals fill a disc of this radius around the scene's goal")

    def __post_init__(self) -> None:
        if self.phi > self.degree:
            raise ConfigError(f"lsc: phi = {self.phi} needs degree >= phi (degree = {self.degree})")
        if self.continuity >= self.degree:
            raise ConfigError(f"lsc: continuity = {self.continuity} needs degree > continuity (degree = {self.degree})")
