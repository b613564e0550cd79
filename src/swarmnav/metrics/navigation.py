"""Navigation metrics of HES Section 5.1, plus inter-agent spacing and collisions.

Index conventions follow the paper exactly: a run has steps ``k = 0 .. K`` (K + 1 recorded
states); ``R_unsafe``, ``R_below_*`` and ``d_clr_min`` use ``k = 1 .. K-1``; the path length
sums ``||p(k) - p(k-1)||`` over ``k = 1 .. K-1``. Statistics over agents are population forms.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from swarmnav.metrics._pairs import inter_agent

if TYPE_CHECKING:
    from swarmnav.world.scenario import Scenario


def norms(a: np.ndarray) -> np.ndarray:
    """``np.linalg.norm(a, axis=-1)``, the same bits: for planar vectors written out as
    ``sqrt(x * x + y * y)``, which is what numpy's reduction computes there, at a fraction of its
    cost on a long array of short rows."""
    if a.shape[-1] == 2 and a.dtype == np.float64:
        x, y = a[..., 0], a[..., 1]
        return np.sqrt(x * x + y * y)
    return np.linalg.norm(a, axis=-1)


@dataclass(frozen=True, slots=True)
class MetricParams:
    r_succ: float = 8.0  # single-UAV success radius [m], HES Section 5.1
    tau_ms: float = 0.8  # mission success threshold on R_goal [-], HES Section 5.1
    d_safe: float = 1.5  # unsafe-clearance threshold [m], HES Table A1
    r_s: float = 1.5  # clearance normaliser of S_scene [m]; our choice = d_safe, which reproduces
    #                   the paper's S_scene = 0.885 from its Table 2/3 default-corridor means
    body_radius: float = 0.2  # UAV body radius [m] for collision counting (our choice)


def navigation_metrics(
    positions: np.ndarray,
    clearance: np.ndarray,
    goal: np.ndarray | None,
    n_subswarms: np.ndarray | None = None,
    n_events: int = 0,
    params: MetricParams = MetricParams(),
    periodic_box: float | None = None,
    reached: np.ndarray | None = None,
) -> dict[str, float]:
    """All scalar run metrics.

    Args:
        positions: (K + 1, N, d) positions [m], d = 2 or 3.
        clearance: (K + 1, N) signed distance of every agent to the nearest obstacle [m]
            (+inf in an obstacle-free world).
        goal: (d,) goal position [m]; None for a scene without a goal (a periodic box): the
            goal metrics (E_*, R_goal, Y, path_stretch, S_scene) are then left out.
        n_subswarms: (K + 1,) sub-swarm count per step (None: one swarm throughout).
        n_events: number of structural (split / merge) events.
        reached: (N,) whether each agent ended at the goal, as the referee judges it (within the
            goal radius, in line of sight of the goal, inside the world, not crashed: see
            :func:`goal_reached`); None: within ``r_succ`` of the goal.
    """
    K = positions.shape[0] - 1
    N = positions.shape[1]
    p = params
    has_goal = goal is not None
    if not has_goal:
        goal = positions[0].mean(axis=0)  # a placeholder: nothing measured against it is reported
    e = norms(positions[-1] - goal)  # terminal goal error e_i [m]
    R_goal = float(np.mean(e <= p.r_succ if reached is None else reached))
    d_min = clearance.min(axis=1)  # d_min(k): min over agents [m]
    inner = d_min[1:K] if K >= 2 else d_min[:0]
    frac = (lambda thr: float(np.mean(inner < thr))) if len(inner) else (lambda thr: 0.0)
    d_clr_min = float(inner.min()) if len(inner) else float(d_min.min())
    R_unsafe = frac(p.d_safe)
    # per agent (ours, beyond the paper): each agent's own share of steps 1..K-1 within d_safe,
    # averaged over agents; <= R_unsafe, which counts a step if *any* agent is within d_safe
    R_unsafe_agent = float(np.mean(clearance[1:K] < p.d_safe)) if K >= 2 else 0.0
    steps = norms(np.diff(positions[:K], axis=0)) if K >= 2 else np.zeros((0, N))
    if periodic_box is not None:  # minimum-image displacement on the torus
        d = np.diff(positions[:K], axis=0)
        d -= periodic_box * np.round(d / periodic_box)
        steps = norms(d)
    L = steps.sum(axis=0)  # L_i [m]
    direct = norms(positions[0] - goal)
    stretch = float(np.mean(L / np.maximum(direct, 1e-9)))
    Y = float(R_goal >= p.tau_ms)
    clr_term = float(np.clip(d_clr_min / p.r_s, 0.0, 1.0)) if np.isfinite(d_clr_min) else 1.0
    S_scene = 0.4 * Y + 0.3 * R_goal + 0.15 * (1.0 - R_unsafe) + 0.15 * clr_term
    min_ij, agent_hits = inter_agent(positions, 2 * p.body_radius, periodic_box)
    obstacle_hits = _rising_edges(clearance < p.body_radius)
    out = {
        "E_mean": float(e.mean()),
        "E_90": float(np.percentile(e, 90)),
        "sigma_E": float(e.std()),
        "R_goal": R_goal,
        "Y": Y,
        "R_unsafe": R_unsafe,
        "R_unsafe_agent": R_unsafe_agent,
        "d_clr_min": d_clr_min,
        "R_below_0_75": frac(0.75),
        "R_below_0_30": frac(0.30),
        "L_mean": float(L.mean()),
        "path_stretch": stretch,
        "S_scene": float(S_scene),
        "min_inter_agent_distance": min_ij,
        "collisions": float(agent_hits + obstacle_hits),
        "N_swarm": float(np.mean(n_subswarms)) if n_subswarms is not None else 1.0,
        "N_event": float(n_events),
    }
    if not has_goal:
        for k in GOAL_METRICS:
            del out[k]
    return out


#: The metrics measured against the goal, left out for a scene without one.
GOAL_METRICS = ("E_mean", "E_90", "sigma_E", "R_goal", "Y", "L_mean", "path_stretch", "S_scene")


def _rising_edges(flags: np.ndarray) -> int:
    """Number of False -> True transitions per column of a (K + 1, M) bool array (a contact
    present at k = 0 counts once)."""
    if flags.size == 0:
        return 0
    prev = np.vstack([np.zeros((1, flags.shape[1]), dtype=bool), flags[:-1]])
    return int(np.count_nonzero(flags & ~prev))


def goal_reached(scn: Scenario, final: np.ndarray, crashed: np.ndarray | None = None,
                 goal_radius: float | None = None) -> np.ndarray:
    """(N,) whether each agent ended at the goal: within ``rules.goal_radius`` of it, in line of
    sight of it (no obstacle or wall between), inside the bounds of a walled world and not
    crashed. ``final`` is the last recorded (N, d) state; ``crashed`` (N,) bool (None: none);
    ``goal_radius`` [m] overrides the scene's."""
    from swarmnav.sensing import segments_blocked

    goal = scn.goal_array
    x = np.asarray(final, dtype=np.float64)
    r = scn.rules.goal_radius if goal_radius is None else float(goal_radius)
    ok = norms(x - goal) <= r
    if crashed is not None:
        ok &= ~np.asarray(crashed, dtype=bool)
    if scn.boundary == "wall":
        ok &= np.all((x >= scn.lower) & (x <= scn.upper), axis=1)
    if ok.any() and not scn.geometry.is_empty:
        idx = np.flatnonzero(ok)
        ok[idx] = ~segments_blocked(scn.geometry, x[idx], np.repeat(goal[None, :], len(idx), axis=0))
    return ok
