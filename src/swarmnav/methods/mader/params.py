"""Parameters of the ``mader`` method: the authors' ``mader.yaml`` (mit-acl/mader) and the paper
(Tordesillas & How, T-RO 2021), with the shared dynamics bounds of the SPH Table II comparison."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar, Literal

from swarmnav.params import param
from swarmnav.planning.schedule import check_plan_steps



@dataclass(frozen=True, slots=True)
class MaderParams:
    """MADER (Tordesillas & How, T-RO 2021). Values from ``mader.yaml`` unless marked "ours"."""

    #: ``swarmnav`` is the default build: MADER with our three named parts on (a Euclidean clearance,
    #: limits on the norm the shared dynamics bound, feasible crowded starts); ``paper`` is MADER's box
    #: clearance and per-axis limits. Both keep the readings the paper leaves open (docs/methods/mader.md).
    PRESETS: ClassVar[dict[str, dict[str, Any]]] = {
        "swarmnav": {},
        "paper": {"clearance": "box", "limits": "axis", "crowd_shrink": 0.0},
    }
    DEFAULT_BUILD: ClassVar[str] = "swarmnav"
    PRESET_DOCS: ClassVar[dict[str, str]] = {
        "swarmnav": "our build: MADER with clearance=ball, limits=norm, crowd_shrink=0.9 (chosen on training forests "
                    "1-2, docs/methods/mader.md)",
        "paper": "MADER's box clearance and per-axis limits, with the readings the paper leaves open",
    }

    # --- dynamics and control ---
    dt: float = param(0.01, "s", "[0.001, 0.1]", "mader.yaml dc",
        "control step (the authors' 100 Hz reference, and SPH's step)")
    v_max: float = param(1.0, "m/s", "(0, inf)", "SPH Table I (shared; mader.yaml v_max is also 1.0 per axis)",
        "speed bound: per axis in the planner (as MADER), on the norm in the shared dynamics")
    a_max: float = param(1.5, "m/s^2", "(0, inf)", "SPH Table I (shared; mader.yaml a_max is also 1.5 per axis)",
        "acceleration bound: per axis in the planner, on the norm in the dynamics")
    k_p: float = param(5.0, "1/s^2", "[0, inf)", "SPH eq. (13), Table I (the shared tracker)", "position gain")
    k_v: float = param(3.5, "1/s", "[0, inf)", "SPH eq. (13), Table I (the shared tracker)", "velocity gain")
    # --- planning (mader.yaml) ---
    Ra: float = param(4.0, "m", "(0, inf)", "mader.yaml: Ra \"should be < fov_depth\" (4.5 m); its value 8.0 breaks that rule",
        "planning horizon: radius of the planning sphere (chosen on forest 1 of density 0.25: docs)")
    num_pol: int = param(4, "", "[4, 12]", "mader.yaml num_pol", "segments of the cubic B-spline")
    weight: float = param(1000.0, "1/m^2", "[0, inf)", "mader.yaml weight",
        "weight of the squared distance of the final point to the local goal")
    eps_tol: float = param(1e-6, "", "(0, 1]", "mader.yaml epsilon_tol_constraints", "constraint tolerance")
    xtol_rel: float = param(1e-13, "", "[0, 1)", "mader.yaml xtol_rel", "NLopt relative x tolerance")
    ftol_rel: float = param(1e-10, "", "[0, 1)", "mader.yaml ftol_rel", "NLopt relative f tolerance")
    algorithm: Literal["ipopt", "LD_SLSQP", "LD_MMA", "LD_CCSAQ"] = param("ipopt", "", None, "ours (docs: NLopt's SLSQP and MMA measured slower and less often feasible)",
        "solver: ipopt (CasADi), or NLopt's LD_SLSQP, LD_MMA, LD_CCSAQ (mader.yaml's list; its default LD_MMA)")
    max_iter: int = param(200, "", "[1, 100000]", "ours",
        "IPOPT iterations per replan: a deterministic stand-in for upper_bound_runtime_snlopt (0.35 s)")
    knots: Literal["clamped", "uniform"] = param("clamped", "", None, "MADER paper Section IV (clamped uniform B-splines)",
        "knot vector: clamped (the curve starts at C_0, C_1 = q + v dt / 3) or uniform (the shared "
        "planning/bspline.py spline, whose start points lie v dt around the robot)")
    basis: Literal["bspline", "bezier"] = param("bspline", "", None, "mader.yaml basis (MINVO there; not built here: docs)",
        "hull of each segment: bspline (its control points) or bezier (its Bezier points, a tighter hull)")
    precheck: bool = param(True, "", None, "ours (result-neutral: docs, 'Solver cost')",
        "skip IPOPT on a problem whose fixed start control points already lie within the clearance of a set they "
        "must be separated from (a certificate of infeasibility within eps_tol): the same fallback, without the solve")
    plane_bound: float = param(100.0, "1/m", "(0, inf)", "ours",
        "bound on each component of a plane normal (the margin 2/|n| stays above 2/(plane_bound sqrt(D)))")
    max_eval: int = param(300, "", "[1, 100000]", "ours",
        "NLopt evaluations per replan: a deterministic stand-in for upper_bound_runtime_snlopt (0.35 s)")
    factor_alloc: float = param(1.0, "", "[1, 10]", "mader.yaml factor_alloc",
        "duration = factor x the per-axis minimum time of a double integrator")
    factor_alloc_close: float = param(1.5, "", "[1, 10]", "mader.yaml factor_alloc_close", "factor near the goal")
    dist_factor_alloc_close: float = param(2.0, "m", "[0, inf)", "mader.yaml dist_factor_alloc_close",
        "distance to the goal below which factor_alloc_close applies")
    replan_time: float = param(0.2, "s", "[0.01, 5]", "ours (mader.yaml runtime bounds 0.05-0.35 s)",
        "simulated time a replan takes: a plan started at t commits at t + replan_time, from the "
        "committed trajectory's state at that time (point A)")
    # --- obstacles and agents (ours: the paper takes polyhedra from its perception) ---
    sensing_range: float = param(8.0, "m", "(0, inf)", "ours (= Ra)",
        "an obstacle joins a robot's map once its bounding box is this close")
    inflation: float = param(0.3, "m", "[0, inf)", "ours (body 0.2 m + 0.1 m)",
        "obstacles grow by this before their polyhedra are built")
    agent_inflation: float = param(0.5, "m", "[0, inf)", "ours (two bodies 0.4 m + 0.1 m; MADER: drone_bbox)",
        "half-size of the box added to another agent's trajectory hull")
    obstacle_margin: float = param(1.0, "m", "[0, inf)", "ours",
        "obstacles and agents within this of the seed's bounding box enter the problem")
    check_margin: float = param(0.05, "m", "[0, inf)", "ours",
        "check: a new plan fails if it comes within 2 body radii + this of a trajectory committed meanwhile")
    clearance: Literal["box", "ball"] = param("ball", "", None, "MADER paper (drone_bbox); ball: ours",
        "shape of the clearance kept from obstacles (inflation) and other agents (agent_inflation): box = their "
        "polyhedra grown by a cube of that half-size, as MADER (a diagonal pair needs sqrt(D) x the gap); ball = "
        "each plane's normal bounded so the sets stay that far apart in Euclidean distance")
    limits: Literal["axis", "norm"] = param("norm", "", None, "MADER paper (per axis); norm: ours",
        "velocity and acceleration bounds of the plan: axis = |V_i|, |A_i| per axis (MADER), which lets a diagonal "
        "plan ask sqrt(D) x what the shared norm-saturated dynamics give; norm = their Euclidean norm (the dynamics' own)")
    crowd_shrink: float = param(0.9, "", "[0, 1)", "ours",
        "a pair already closer than agent_inflation keeps max(crowd_shrink x gap, 2 body radii + check_margin / 2) "
        "(none between contact and that floor: a fallback), and crowd_shrink x gap if already in contact, so a "
        "crowded start stays feasible (0 = off: such a robot cannot plan)")
    check_norm: Literal["box", "euclidean"] = param("box", "", None, "ours",
        "check measure: box = no sample of the new plan within the agent_inflation of a trajectory "
        "committed meanwhile, in the optimisation's own measure (per axis, or Euclidean with clearance=ball); "
        "euclidean = 2 body radii + check_margin")
    cap_span: bool = param(True, "", None, "ours",
        "clamped knots: shorten the knot span so the start's fixed second velocity point v + a dt/2 stays within v_max")
    check_step: float = param(0.05, "s", "(0, 1]", "ours", "time step of the sampled check")
    # --- initial guess (ours: grid search instead of Octopus Search, docs) ---
    grid_resolution: float = param(0.2, "m", "(0, inf)", "ours", "cell of the per-robot search grid")
    max_expand: int = param(200000, "", "[1, 100000000]", "ours", "A* expansion budget")
    goal_disc: float = param(2.4, "m", "[0, inf)", "ours (EGO-Swarm's, planning/goals.py)",
        "per-robot goals fill a disc of this radius around the scene's goal (within the 3 m arrival radius), "
        "assigned to the spawn layout: each MADER agent has its own goal, and 15 slots in 2.4 m stay ~1 m apart, "
        "beyond agent_inflation")
    goal_tol: float = param(0.05, "m", "[0, inf)", "ours",
        "a robot whose committed plan ends this close to its goal stops replanning")

    def __post_init__(self) -> None:
        # the relation that keeps a plan finite (v_max = 5e-324 m/s made its knot span NaN)
        check_plan_steps("mader", "Ra", self.Ra, self.v_max, self.a_max, self.dt,
                         max(self.factor_alloc, self.factor_alloc_close))
