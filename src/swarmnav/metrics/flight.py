"""Flight metrics of the SPH paper's Table II and Fig. 3(E-G), for every method in an open world
(the rollout leaves them out of periodic worlds: no goal to arrive at, and the wrap jumps would
count as path and jerk).

Per robot ``i`` the flight ends at its arrival step ``a_i``: the first step at which it is
within ``r_goal`` of the goal (the horizon K if it never is). Then

- ``flight_distance``: mean over robots of the path length up to ``a_i`` [m];
- ``flight_time``: mean over robots of ``a_i dt`` [s] (never arrived: the horizon, a censored
  value);
- ``avg_velocity``: total distance over total time, ``sum L_i / sum T_i`` [m/s] (Table II's
  Vel column is Dist / Time: 23.1 / 26.8 = 0.86, ...);
- ``jerk_energy``: mean over robots of ``int_0^T ||d^3 q / dt^3||^2 dt`` up to ``a_i``, with the
  jerk as the third finite difference of the recorded positions at the method's step [m^2/s^5];
- ``comm_mbps``: aggregate load of every robot broadcasting its position at ``broadcast_hz``
  in ``msg_bytes`` messages [Mbit/s]: the figure for a method that does not count its messages.
  The planners (SPH and the Table II peers) count what they actually send
  (``swarmnav.planning.messages``) and their own ``comm_mbps`` replaces this one;
- ``min_inter_robot_distance``, ``min_robot_obstacle_distance``: over the whole run [m]
  (Fig. 3 F, G); the obstacle distance is the signed clearance (negative inside);
- ``sph_arrived_fraction``: share of robots within ``r_goal`` of the goal at the last step;
- ``sph_success``: 1.0 if every robot is within ``r_goal`` of the goal at the last step and no
  robot ever touched another (distance < 2 body radii) or an obstacle (clearance < 1 body
  radius), else 0.0; its mean over trials is Table II's Rate. Both carry the paper's name
  because they are its test, not the run's: a method that does not gather within ``r_goal``
  by design (HES parks on its encircle ring ~6 m out) scores 0 here with Y = 1 (docs/metrics.md);
- ``sph_swarm_goal_radius``, ``sph_swarm_arrived_fraction``, ``sph_swarm_success``: the success test for any
  swarm size (issue 36; docs/metrics.md, *Success for a swarm*). The goal disc grows with the
  swarm so that it holds N robots at the density at which 15 fill the Table II disc:
  ``r(N) = r_goal sqrt(max(N, n_ref) / n_ref)`` [m] (3 m up to 15 robots, 4.24 m for 30, 6 m
  for 60, 7.75 m for 100). A robot has arrived once it has been inside r(N) at some step;
  ``sph_swarm_success`` is 1.0 if every robot arrived by the horizon, none ever touched another or
  an obstacle (the contact rule of ``sph_success``) and none crashed, else 0.0. Arrival rather
  than presence at the last step: a swarm's task is to cross the field to the goal, and where
  its robots settle after arriving depends on the method's spacing rule, not on navigation;
  contacts after arrival still fail the run;
- ``coordination_time``: first time the swarm moves as one body (Fig. 6): the speed of its
  centre, ``|mean_i v_i|``, first reaches ``phi_coord`` times its median over the flight up
  to the first arrival (the cruise, free of the crowding at the goal) [s] (horizon if never).
  Common-mode speed rather than polarisation:
  in a forest the polarisation ``|sum v_i| / sum |v_i|`` fluctuates around 0.75-1.0 as robots
  pass trees on either side, so the first crossing of a fixed threshold like 0.9 was either
  the spawn transient (~1.2 s) or an arbitrary later moment (up to the horizon); relative to
  the run's own cruise the measure does not depend on how fast the method flies.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from swarmnav.metrics._pairs import inter_agent
from swarmnav.metrics.navigation import MetricParams, norms


@dataclass(frozen=True, slots=True)
class FlightParams:
    r_goal: float = 3.0  # goal radius [m] for arrival and success (our choice, see docs/methods/sph.md)
    body_radius: float = MetricParams().body_radius  # [m], the same contact rule as navigation.py
    broadcast_hz: float = 10.0  # position broadcast rate [Hz], SPH paper Section IV-A
    msg_bytes: int = 64  # position message [B]: 3 x float64 position, float64 stamp, uint32 id,
    #                      UDP (8) + IPv4 (20) headers (our choice; the paper gives none; planning/messages.py)
    n_ref: int = 15  # swarm size the r_goal disc is made for (Table II's 15 robots) [-]
    phi_coord: float = 0.8  # coordinated once the swarm's centre moves at this fraction of its
    #                         median flight speed [-] (our choice; the paper does not define it)


def swarm_goal_radius(n: int, params: FlightParams = FlightParams()) -> float:
    """r(N) of the swarm test: ``r_goal sqrt(max(N, n_ref) / n_ref)`` [m] (module docstring)."""
    return params.r_goal * float(np.sqrt(max(n, params.n_ref) / params.n_ref))


def flight_metrics(
    positions: np.ndarray,
    velocities: np.ndarray,
    clearance: np.ndarray,
    goal: np.ndarray,
    dt: float,
    params: FlightParams = FlightParams(),
    min_pair: float | None = None,
    crashed: np.ndarray | None = None,
) -> dict[str, float]:
    """Table II metrics of one run (see the module docstring).

    Args:
        positions, velocities: (K + 1, N, d) [m], [m/s], d = 2 or 3.
        clearance: (K + 1, N) signed distance to the nearest obstacle [m] (+inf: none).
        goal: (d,) goal [m]; dt: step of the recorded states [s].
        min_pair: the smallest robot-robot distance of the run [m] if already known (the rollout
            passes navigation_metrics' ``min_inter_agent_distance``: one pass over the run, not two).
        crashed: (N,) robots the referee found crashed (None: none); they fail ``sph_swarm_success``.
    """
    K = positions.shape[0] - 1
    n = positions.shape[1]
    p = params
    dist_goal = norms(positions - goal)  # (K + 1, N)
    inside = dist_goal <= p.r_goal
    arrival = np.where(inside.any(axis=0), inside.argmax(axis=0), K)  # (N,) step index
    steps = norms(np.diff(positions, axis=0))  # (K, N)
    cum = np.vstack([np.zeros((1, n)), np.cumsum(steps, axis=0)])
    L = cum[arrival, np.arange(n)]
    T = arrival * dt
    jerk = np.diff(positions, n=3, axis=0) / dt**3 if K >= 3 else np.zeros((0, n, positions.shape[2]))
    j2 = np.einsum("knd,knd->kn", jerk, jerk) * dt
    cj = np.vstack([np.zeros((1, n)), np.cumsum(j2, axis=0)])
    E = cj[np.clip(arrival - 2, 0, len(j2)), np.arange(n)]  # jerk samples 0 .. a_i - 3
    min_ij = inter_agent(positions, 2 * p.body_radius, None)[0] if min_pair is None else float(min_pair)
    min_obs = float(clearance.min()) if clearance.size else float("inf")
    touched = min_ij < 2 * p.body_radius or min_obs < p.body_radius
    success = bool(inside[-1].all()) and not touched
    r_swarm = swarm_goal_radius(n, p)
    arrived = (dist_goal <= r_swarm).any(axis=0)  # (N,) inside r(N) at some step
    crash_free = crashed is None or not bool(np.any(crashed))
    swarm_success = bool(arrived.all()) and not touched and crash_free
    centre = norms(velocities.mean(axis=1))  # (K + 1,) common-mode speed [m/s]
    cruise = float(np.median(centre[: max(int(arrival.min()), 1) + 1]))  # before anyone has arrived
    coord = centre >= p.phi_coord * cruise
    t_coord = float(np.argmax(coord)) * dt if cruise > 0 and coord.any() else K * dt
    return {
        "flight_distance": float(L.mean()),
        "flight_time": float(T.mean()),
        "avg_velocity": float(L.sum() / T.sum()) if T.sum() > 0 else 0.0,
        "jerk_energy": float(E.mean()),
        "comm_mbps": n * p.broadcast_hz * p.msg_bytes * 8 / 1e6,
        "min_inter_robot_distance": min_ij,
        "min_robot_obstacle_distance": min_obs,
        "sph_arrived_fraction": float(inside[-1].mean()),
        "sph_success": float(success),
        "sph_swarm_goal_radius": r_swarm,
        "sph_swarm_arrived_fraction": float(arrived.mean()),
        "sph_swarm_success": float(swarm_success),
        "coordination_time": t_coord,
    }
