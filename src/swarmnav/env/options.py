"""The options of the RL environments: one frozen record, each field with its unit, range and
source (``swarmnav.params``), so an unknown or out-of-range option is a one-line ConfigError."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Literal

from swarmnav.errors import ConfigError
from swarmnav.metrics.navigation import MetricParams
from swarmnav.params import build, param

_M = MetricParams()


@dataclass(frozen=True, slots=True)
class EnvOptions:
    """Every option of :func:`swarmnav.env.parallel_env` and ``swarmnav/Swarm-v0``.

    The defaults are the HES world (its step, damped double integrator, acceleration bound,
    LiDAR range) and the simulator's metric thresholds (goal radius r_succ, d_safe, body radius),
    so an episode is scored the way ``swarmnav run`` scores a run.
    """

    # ------------------------------------------------------------------ dynamics
    dt: float = param(0.1, "s", "[0.0001, 1]", "HES Section 5.1", "step of the environment")
    horizon: float = param(100.0, "s", "(0, 1e6]", "HES Section 5.1 (1000 steps of 0.1 s)",
        "episode length: truncation after round(horizon / dt) steps")
    dynamics: Literal["damped", "saturated"] = param("damped", "", None, "HES eq. (5)-(7) / SPH eq. (2)",
        "damped: HES's damped double integrator with inverse model (v' = a); "
        "saturated: the SPH paper's, speed clipped to v_max")
    a_max: float = param(2.6, "m/s^2", "(0, inf)", "HES Table A1",
        "acceleration bound: an action of norm 1 commands a_max")
    v_max: float | None = param(None, "m/s", "(0, inf)", "ours",
        "speed bound of the saturated dynamics (SPH Table I: 1.0; None: unbounded); the damped "
        "dynamics has none")
    # ------------------------------------------------------------------ observation
    lidar_rays: int = param(360, "", "[4, 36000]", "HES Table A1", "rays of the simulated LiDAR ring")
    n_rays: int = param(36, "", "[1, 36000]", "ours",
        "rays observed: the ring pooled by the minimum over lidar_rays / n_rays adjacent rays")
    lidar_range: float = param(20.0, "m", "(0, inf)", "HES Table A1", "LiDAR range R_L")
    k_neighbors: int = param(6, "", "[0, 64]", "ours", "nearest other agents observed")
    # ------------------------------------------------------------------ episode and reward
    goal_radius: float = param(_M.r_succ, "m", "(0, inf)", "HES Section 5.1 (r_succ)",
        "an agent within this distance of the goal has arrived: terminated, it hovers there")
    terminate_at_goal: bool = param(True, "", None, "ours",
        "true: an arrived agent is terminated and hovers; false: every agent flies to the step "
        "limit, as swarmnav run scores a run")
    d_safe: float = param(_M.d_safe, "m", "[0, inf)", "HES Table A1", "unsafe obstacle clearance")
    body_radius: float = param(_M.body_radius, "m", "[0, inf)", "ours (as docs/metrics.md)",
        "contact: clearance below it, or another agent nearer than twice it")
    w_progress: float = param(1.0, "1/m", "[0, inf)", "ours", "reward per metre of progress to the goal")
    w_goal: float = param(10.0, "", "[0, inf)", "ours", "reward on arrival in the goal region")
    w_contact: float = param(50.0, "1/s", "[0, inf)", "ours",
        "penalty rate in contact with an obstacle, and again with another agent (x dt per step: "
        "5 per 0.1 s step)")
    w_unsafe: float = param(1.0, "1/s", "[0, inf)", "ours",
        "penalty rate with clearance below d_safe (x dt per step: 0.1 per 0.1 s step)")

    @property
    def max_steps(self) -> int:
        """Steps of one episode: round(horizon / dt), at least one."""
        return max(1, int(round(self.horizon / self.dt)))


def env_options(options: dict[str, Any] | None) -> EnvOptions:
    """``options`` checked into an :class:`EnvOptions` (ConfigError naming a bad key or value)."""
    o = build(EnvOptions, options, context="env")
    if o.lidar_rays % o.n_rays:
        raise ConfigError(f"env: n_rays = {o.n_rays} must divide lidar_rays = {o.lidar_rays} "
                          "(each observed ray pools the same number of LiDAR rays)")
    if o.dynamics == "damped" and o.v_max is not None:
        raise ConfigError(f"env: v_max = {o.v_max:g} m/s needs dynamics='saturated' "
                          "(the damped double integrator has no speed bound)")
    return o
