"""Imperfect perception: what each agent believes of itself, and what its range sensor returns.

Own state. Agent i's estimate of its own position at time t [s] is

    p_hat_i(t) = p_i(t) + w_i t + n_i(t),    v_hat_i(t) = v_i(t) + m_i(t),

p_i, v_i the true state; ``w_i`` a drift velocity [m/s] drawn once per agent, N(0, drift^2) on
each axis, so the drift of the estimate grows as ``w_i t`` (standard deviation ``drift * t`` per
axis: a dead-reckoning estimate whose velocity error is constant); ``n_i`` and ``m_i`` white
noise, N(0, pos_noise^2) and N(0, vel_noise^2) per axis, drawn afresh every control step.

Range returns. Rays are cast from the agent's true position (the sensor rides on the body), so a
method that places a return in the world from its own estimate misplaces it by its estimation
error, as a real robot does. Each return that hits something gets Gaussian noise N(0,
range_noise^2), clipped to ``[0, max_range]``; a ray that hits nothing stays ``max_range``. A
lost return (probability ``dropout``, independently per ray and step) and a ray outside the field
of view (angle to the heading above ``fov / 2``; in 3-D a cone about the heading) read
``max_range``: no return, the same as a ray that hits nothing. The heading is the direction of
the agent's true velocity, kept while it hovers (speed below 1e-9 m/s), at the start toward the
scene's goal (without a goal: +x).

Every draw comes from a stream of its own derived from the run's seed (own state and range
returns from two children of ``SeedSequence([seed, TAG])``), so the same seed gives the same
errors, the own-state errors are the same for every method, and a method's own random draws are
unchanged. Perfect perception (every ``sense.*`` at its default) is no perception model: the
rollout passes the true state and the exact ranges, bit for bit as before it existed.

Parameters are the run's, not a method's: ``--set sense.pos_noise=0.05`` (docs/sensing.md).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Literal

import numpy as np

from swarmnav.errors import ConfigError
from swarmnav.params import as_dict, build, param

#: The run-option names of the perception parameters (``sense.NAME``).
PREFIX = "sense."
#: The stream tag of perception draws ("sen"): SeedSequence([seed, TAG]).
TAG = 0x73656E
#: The options a method honours only if it reads a range sensor (``range_sensor = True``).
RANGE_OPTIONS = ("range_noise", "dropout", "fov")
#: The options that shape the scans a map-based planner builds its map from (``sense.map = scans``).
SCAN_OPTIONS = ("scan_rays", "scan_range", "scan_rate", "scan_fill")
#: The options a method honours only if it can build its map from scans (``map_sensor = True``).
MAP_OPTIONS = ("map", *SCAN_OPTIONS)
#: [m/s] below this speed an agent's heading is the one it last had.
HOVER = 1e-9


@dataclass(frozen=True, slots=True)
class SenseParams:
    """Each agent's perception (module docstring). Defaults: perfect perception."""

    pos_noise: float = param(0.0, "m", "[0, 1000]", "ours",
                             "standard deviation of the white noise on each agent's estimate of its own position, "
                             "per axis, drawn every control step")
    vel_noise: float = param(0.0, "m/s", "[0, 1000]", "ours",
                             "standard deviation of the white noise on each agent's estimate of its own velocity, "
                             "per axis, drawn every control step")
    drift: float = param(0.0, "m/s", "[0, 100]", "ours",
                         "drift rate of the position estimate: a constant drift velocity per agent, N(0, drift^2) "
                         "per axis, so the drift after t seconds has standard deviation drift * t per axis")
    range_noise: float = param(0.0, "m", "[0, 1000]", "ours",
                               "standard deviation of the Gaussian noise on each range return that hits an "
                               "obstacle (clipped to [0, max range])")
    dropout: float = param(0.0, "", "[0, 1]", "ours",
                           "fraction of range returns lost, independently per ray and step; a lost return reads "
                           "the sensor's max range (no return)")
    fov: float = param(360.0, "deg", "(0, 360]", "ours",
                       "field of view of the range sensor centred on the heading (the direction of flight); "
                       "rays outside read the max range; 360: all round")
    map: Literal["known", "scans"] = param("known", "", None, "ours",
                                           "what a map-based planner (sph, ego-swarm, lsc) knows of the obstacles: "
                                           "known, every obstacle within its sensing range from the world; scans, "
                                           "the cells its own range scans hit, accumulated as it flies "
                                           "(planning/scanned.py)")
    scan_rays: int = param(360, "", "[8, 100000]", "ours (1 deg, a planar 2-D LiDAR such as the RPLIDAR A2's ~1 deg)",
                           "rays per scan of the map's range sensor (2-D: an evenly spaced ring; 3-D: the "
                           "Fibonacci sphere); sense.map = scans only")
    scan_range: float = param(0.0, "m", "[0, 1000]", "ours",
                              "max range of the map's range sensor; 0: the planner's own sensing range (sph: R, "
                              "the paper equates the two, Section IV; ego-swarm, lsc: sensing_range); "
                              "sense.map = scans only")
    scan_rate: float = param(10.0, "Hz", "(0, 1000]", "ours (10 Hz: a Livox Mid-360 / Velodyne VLP-16 default)",
                             "scans per second, every robot at once, at most one a control step; sense.map = scans only")
    scan_fill: float = param(0.0, "m", "[0, 100]", "ours (docs/sensing.md, Filling behind a return)",
                             "depth behind each return also marked hit, along the surface's inward normal (2-D: "
                             "from the neighbouring returns of the ring; 3-D: along the ray), so a seen face has a "
                             "solid inside instead of a free one; 0: the hit cell only; sense.map = scans only")

    @property
    def perfect(self) -> bool:
        return self == SenseParams()

    @property
    def ranged(self) -> list[str]:
        """The range-sensor options set away from their defaults."""
        base = SenseParams()
        return [k for k in RANGE_OPTIONS if getattr(self, k) != getattr(base, k)]

    @property
    def scanning(self) -> list[str]:
        """The scan options set away from their defaults."""
        base = SenseParams()
        return [k for k in SCAN_OPTIONS if getattr(self, k) != getattr(base, k)]


def sense_params(options: dict) -> SenseParams:
    """The perception of a run from its ``sense.*`` options (unknown or out-of-range: ConfigError;
    a scan option without ``sense.map = scans``: ConfigError, it would change nothing)."""
    p = build(SenseParams, {k[len(PREFIX):] if k.startswith(PREFIX) else k: v for k, v in options.items()},
              context="sense")
    if p.map != "scans" and p.scanning:
        raise ConfigError(f"sense: {', '.join('sense.' + k for k in p.scanning)} shape the scans of sense.map=scans; "
                          f"with sense.map={p.map} they change nothing")
    return p


class Perception:
    """The perception of one run (module docstring). :meth:`observe` is called once per control
    step with the true state and gives the estimates a method sees; :meth:`scan` turns a method's
    range-sensor kernel into the imperfect sensor."""

    def __init__(self, p: SenseParams, positions: np.ndarray, seed: int, goal: np.ndarray | None = None):
        self.p = p
        n, d = positions.shape
        state, ranges = np.random.SeedSequence([int(seed), TAG]).spawn(2)
        self.rng = np.random.default_rng(state)  # own-state errors: the same for every method
        self.range_rng = np.random.default_rng(ranges)  # range returns: drawn only by methods that scan
        self.drift = self.rng.normal(0.0, p.drift, (n, d)) if p.drift > 0 else None  # [m/s] w_i
        self.cos_half = math.cos(math.radians(p.fov) / 2.0)
        self.heading = np.zeros((n, d))
        self.heading[:, 0] = 1.0
        goal = None if goal is None else np.asarray(goal, dtype=np.float64)
        if goal is not None and goal.shape in ((d,), (n, d)):  # one goal, or one per agent
            to_goal = goal - positions
            norm = np.linalg.norm(to_goal, axis=1)
            at = norm > HOVER
            self.heading[at] = to_goal[at] / norm[at, None]
        self.true = self.estimate = positions
        self.error_sum = 0.0
        self.error_max = 0.0
        self.steps = 0
        self.returns = 0
        self.lost = 0

    def observe(self, t: float, pos: np.ndarray, vel: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Each agent's estimate of its own position (N, d) [m] and velocity (N, d) [m/s] at time
        ``t`` [s] from the true state."""
        p = self.p
        est, vest = pos, vel
        if self.drift is not None:
            est = est + self.drift * t
        if p.pos_noise > 0:
            est = est + self.rng.normal(0.0, p.pos_noise, pos.shape)
        if p.vel_noise > 0:
            vest = vel + self.rng.normal(0.0, p.vel_noise, vel.shape)
        if p.fov < 360.0:
            speed = np.linalg.norm(vel, axis=1)
            moving = speed > HOVER
            self.heading[moving] = vel[moving] / speed[moving, None]
        self.true, self.estimate = pos, est
        err = np.linalg.norm(est - pos, axis=1)
        self.error_sum += float(err.mean())
        self.error_max = max(self.error_max, float(err.max()))
        self.steps += 1
        return est, vest

    def scan(self, cast: Callable[[np.ndarray], np.ndarray], x: np.ndarray, directions: np.ndarray,
             max_range: float) -> np.ndarray:
        """The imperfect reading of a range sensor: ``cast(origins)`` is the method's exact
        kernel, (N, R) ranges [m] along ``directions`` (R, d) from ``origins`` (N, d); ``x`` the
        positions the method would cast from (its estimates: row i is agent i). Rays leave from
        the true positions (``x`` moved by each agent's estimation error) and come back with the
        noise, dropouts and field of view of the module docstring."""
        if x.shape != self.true.shape:
            raise ValueError(f"scan: x must be every agent's position {self.true.shape}, got {x.shape}")
        origins = self.true if x is self.estimate else self.true + (x - self.estimate)
        ring = np.array(cast(np.ascontiguousarray(origins, dtype=np.float64)), dtype=np.float64)
        p, max_range = self.p, float(max_range)
        lost = np.zeros(ring.shape, dtype=bool)
        if p.range_noise > 0:
            hit = ring < max_range
            noisy = ring + self.range_rng.normal(0.0, p.range_noise, ring.shape)
            ring = np.where(hit, np.clip(noisy, 0.0, max_range), ring)
        if p.dropout > 0:
            lost |= self.range_rng.random(ring.shape) < p.dropout
        if p.fov < 360.0:
            u = np.asarray(directions, dtype=np.float64)
            u = u / np.linalg.norm(u, axis=1)[:, None]
            lost |= (self.heading @ u.T) < self.cos_half - 1e-12
        ring[lost] = max_range
        self.returns += ring.size
        self.lost += int(lost.sum())
        return ring

    def summary(self) -> dict[str, float]:
        """Run metrics of the perception: the mean and largest error of the own-position estimate
        [m] over the agents and steps, and (for a method that read its range sensor) the fraction
        of range returns lost to dropouts and the field of view."""
        out = {"sense_pos_error_mean": self.error_sum / max(self.steps, 1), "sense_pos_error_max": self.error_max}
        if self.returns:
            out["sense_returns_lost_fraction"] = self.lost / self.returns
        return out


def record(p: SenseParams) -> dict:
    """The perception of a run as its config records it."""
    return as_dict(p)
