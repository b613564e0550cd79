"""Parameters of the ``nmpc`` method: the predictive swarm of Soria, Schiano & Floreano (Nature
Machine Intelligence 2021), with the shared dynamics bounds of the SPH Table II comparison.

The paper's Methods text was not available to us; the values marked "authors' code" are those of
the authors' published MATLAB release (cl_init.m, param_swarm.m, swarming_model_max_neig.m),
read, not copied. docs/methods/nmpc.md gives every reading."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar, Literal

from swarmnav.params import param


@dataclass(frozen=True, slots=True)
class NmpcParams:
    """Distributed NMPC swarm (Soria et al. 2021). Values marked "ours" are our choices."""

    #: ``swarmnav`` is the default build (the paper's controller with our crowd rule on);
    #: ``paper`` turns our part off. Both keep the readings the paper leaves open.
    PRESETS: ClassVar[dict[str, dict[str, Any]]] = {
        "swarmnav": {},
        "paper": {"crowd_shrink": 0.0, "direction": "squared", "reach_guard": "off", "control_dt": 0.1},
    }
    DEFAULT_BUILD: ClassVar[str] = "swarmnav"
    PRESET_DOCS: ClassVar[dict[str, str]] = {
        "swarmnav": "our build: the paper's controller with parts of ours: direction=signed (forward, not "
                    "either way along u_ref), crowd_shrink=0.9 (a crowded start stays feasible), reach_guard=on "
                    "(no robot-robot contact from stale predictions) and control_dt=0.2 s (20 steps over the same "
                    "4 s: 4x less CPU); docs/methods/nmpc.md",
        "paper": "the paper's cost, constraints, horizon and weights, with the readings it leaves open",
    }

    # --- dynamics and control ---
    dt: float = param(0.01, "s", "[0.001, 0.1]", "SPH Table I (the shared simulation step)",
        "integration step of the simulation; the MPC acts every control_dt")
    control_dt: float = param(0.2, "s", "[0.01, 1]", "ours (authors' code, preset=paper: cl_init.m dt = 0.1 s)",
        "MPC step and prediction step: one solve per robot per control_dt, its first acceleration held "
        "(zero-order hold); 0.2 s halves the steps over the horizon and the solves (docs/methods/nmpc.md)")
    prediction_horizon: float = param(4.0, "s", "(0, 20]", "authors' code (cl_init.m: T_p = 4 s)",
        "prediction horizon: round(prediction_horizon / control_dt) steps")
    v_max: float = param(1.0, "m/s", "(0, inf)", "SPH Table I (shared)", "speed bound (norm), in the MPC and the dynamics")
    a_max: float = param(1.5, "m/s^2", "(0, inf)", "SPH Table I (shared)", "acceleration bound (norm)")
    # --- cost ---
    v_ref: float = param(0.9, "m/s", "[0, inf)", "ours (SPH Table II: NMPC flew 0.83-0.92 m/s)",
        "migration speed (J_nav); scaled down within slow_radius of the robot's goal")
    d_ref: float = param(1.2, "m", "(0, inf)", "ours (a robot's goal slot ~1 m apart; the authors' crazyflies 0.8 m)",
        "reference inter-agent distance of the separation / cohesion terms")
    w_sep: float = param(1.0, "1/m^4", "[0, inf)", "authors' code (W_sep = 1)", "weight of J_sep (neighbours closer than d_ref)")
    w_coh: float = param(1.0, "1/m^4", "[0, inf)", "authors' code (the same spring term as W_sep)",
        "weight of J_coh (neighbours farther than d_ref); = w_sep is the paper's single separation term")
    w_dir: float = param(5.0, "", "[0, inf)", "authors' code (W_dir = 5)", "weight of J_dir (migration direction)")
    w_nav: float = param(5.0, "s^4/m^4", "[0, inf)", "authors' code (W_nav = 5)", "weight of J_nav (migration speed)")
    w_u: float = param(0.4, "s^4/m^2", "[0, inf)", "authors' code (W_u = 0.4)", "weight of the control effort |u|^2")
    direction: Literal["squared", "signed"] = param("signed", "", None, "authors' code (squared); signed: ours",
        "J_dir: squared = (1 - (v.u)^2 / |v|^2)^2, indifferent to flying backwards along u_ref; "
        "signed = (1 - v.u / |v|)^2 (|v|^2 + eps_v under the roots)")
    eps_v: float = param(0.01, "m^2/s^2", "(0, inf)", "ours", "regularises J_dir = (1 - (v.u)^2 / (|v|^2 + eps_v))^2 at rest")
    max_neig: int = param(3, "", "[1, 64]", "authors' code (param_swarm.m: max_neig = 3)",
        "closest neighbours in the separation / cohesion terms")
    # --- constraints ---
    col_neig: int = param(6, "", "[1, 64]", "ours (the authors constrain every pair of a 5-drone swarm)",
        "closest neighbours whose predicted trajectories are hard constraints")
    col_margin: float = param(0.1, "m", "[0, inf)", "ours (authors' code: r_coll 0.1 m per drone)",
        "least predicted distance between two robots: 2 body radii + this")
    max_obs: int = param(8, "", "[1, 64]", "ours", "nearest obstacles in the constraints")
    obs_margin: float = param(0.1, "m", "[0, inf)", "ours (authors' code: safety_margin 0.2 m on r^2)",
        "least predicted clearance from an obstacle: body radius + this")
    sensing_range: float = param(8.0, "m", "(0, inf)", "ours (= MADER's)",
        "neighbours and obstacles (bounding box) within this enter a robot's problem")
    crowd_shrink: float = param(0.9, "", "[0, 1)", "ours",
        "a neighbour or obstacle already nearer than its clearance keeps max(crowd_shrink x the present gap, the "
        "clearance less half its margin), below that max(crowd_shrink x gap, contact + 5 mm) "
        "(0 = off: such a robot's problem is infeasible, a fallback)")
    reach_guard: Literal["on", "off"] = param("on", "", None, "ours (docs/methods/nmpc.md, Contacts)",
        "on: the first predicted position keeps 2 body radii + 5 mm + one step of a neighbour's reach "
        "(a_max h^2 (n+2) / 2n, h = control_dt, n = h / dt) from where each of the col_neig closest "
        "neighbours would be one step on at its present velocity: no contact whatever they do next")
    # --- solver ---
    max_iter: int = param(100, "", "[1, 10000]", "ours", "IPOPT iterations per solve")
    tol: float = param(1e-4, "", "(0, 1)", "ours", "IPOPT tolerance")
    feas_tol: float = param(1e-4, "", "(0, 1)", "ours", "a solution violating a constraint by more is a failed solve")
    warm_start: Literal["primal", "primal-dual"] = param("primal-dual", "", None, "ours (measured: docs/methods/nmpc.md)",
        "IPOPT starts from the previous plan shifted by one step; primal-dual: its multipliers too "
        "(warm_start_init_point, bound push 1e-6)")
    fallback: Literal["shift", "brake"] = param("brake", "", None, "ours (measured: docs/methods/nmpc.md)",
        "a failed solve: shift = the previous prediction's next acceleration (brake once it is used up), "
        "brake = -v / control_dt within a_max")
    # --- goals (the paper migrates in a direction; ours: towards each robot's goal) ---
    goal_disc: float = param(2.4, "m", "[0, inf)", "ours (EGO-Swarm's and MADER's, planning/goals.py)",
        "per-robot goals fill a disc of this radius around the scene's goal; u_ref points at the robot's own")
    slow_radius: float = param(2.0, "m", "(0, inf)", "ours", "v_ref scales with distance / slow_radius within it of the goal")

    def steps(self) -> int:
        """Prediction steps H."""
        return max(1, int(round(self.prediction_horizon / self.control_dt)))

    def __post_init__(self) -> None:
        from swarmnav.errors import ConfigError

        ratio = self.control_dt / self.dt
        if abs(ratio - round(ratio)) > 1e-6 or round(ratio) < 1:
            raise ConfigError(f"nmpc: control_dt ({self.control_dt:g} s) must be a whole number of dt ({self.dt:g} s)")
        if self.prediction_horizon / self.control_dt > 200:
            raise ConfigError(f"nmpc: prediction_horizon / control_dt = "
                              f"{self.prediction_horizon / self.control_dt:g} steps, at most 200 (each step adds "
                              "variables to every robot's problem); shorten prediction_horizon")
