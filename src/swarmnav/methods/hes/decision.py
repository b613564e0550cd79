"""High-level decisions of HES, Section 3: task modes, feasibility, projection, decision sources.

The seam for the next issue (LLM decisions) is here: any decision source implements
:class:`DecisionSource` (``propose(z, step) -> Proposal``), reads only the state z(k) of
eq. (18) (:class:`DecisionState`, whose ``to_dict()`` is what a prompt sees), and every
proposal, whatever its source, goes through :func:`project` (Pi_feas, eq. 22) before it is
executed. :class:`RulePolicy` is the rule-based source.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Protocol

#: Structural action set A_str and task action set A_task, eq. (10).
A_STR = ("split", "merge", "keep")
A_TASK = ("navigate", "encircle")
NAVIGATE, ENCIRCLE = 0, 1


# --------------------------------------------------------------------------- task mode, eq. (11)-(12)

def target_proximity(d_centroid: float, d_subleader: float) -> float:
    """Eq. (11): ``delta_s = min(||pbar_s - p_g||, ||p_s(k) - p_g||)`` [m]."""
    return min(d_centroid, d_subleader)


def task_mode(previous: int, delta: float, r_in: float, r_out: float) -> int:
    """Eq. (12): encircle below ``r_in``, navigate at or above ``r_out``, else keep ``previous``."""
    if delta < r_in:
        return ENCIRCLE
    if delta >= r_out:
        return NAVIGATE
    return previous


# --------------------------------------------------------------------------- feasibility, eq. (13)-(17)

def split_feasible(S: int, n_c: int, k: int, k_last: int | None, cooldown_steps: int, d_goal: float,
                   r_merge: float) -> bool:
    """Eq. (13): ``S = 1``, ``n_c >= 2``, ``k - k_last >= T_cd`` and ``||pbar - p_g|| >= r_merge``.

    ``k_last`` None: no structural change yet (the cooldown is satisfied).
    """
    cooled = k_last is None or k - k_last >= cooldown_steps
    return S == 1 and n_c >= 2 and cooled and d_goal >= r_merge


def merge_feasible(S: int, n_near: int, d_swarm_min: float, d_merge: float) -> bool:
    """Eq. (16): ``n_near >= 2`` or ``d_swarm_min < d_merge`` (needs two sub-swarms)."""
    return S >= 2 and (n_near >= 2 or d_swarm_min < d_merge)


@dataclass(frozen=True, slots=True)
class DecisionState:
    """z(k) of eq. (18): what every decision source sees, and nothing else.

    Attributes:
        k: decision step; dt: step length [s].
        S: number of sub-swarms S(k).
        n_c: number of candidate corridors toward the goal wide enough to be a split path.
        w_max, w_min: widest / narrowest candidate corridor width [m] (0 if none).
        d_goal_avg: eq. (19), mean sub-swarm centroid distance to the goal [m].
        n_near: eq. (15), sub-swarms whose centroid is within r_merge of the goal.
        d_swarm_min: eq. (14), smallest centroid distance between two sub-swarms [m]
            (inf with one sub-swarm).
        can_split, can_merge: I_split(k), I_merge(k) of eq. (17).
    """

    k: int
    dt: float
    S: int
    n_c: int
    w_max: float
    w_min: float
    d_goal_avg: float
    n_near: int
    d_swarm_min: float
    can_split: bool
    can_merge: bool

    def to_dict(self) -> dict[str, Any]:
        """The fields a prompt uses, under the names of the LLM layer (``path_count`` = n_c,
        ``avg_goal_distance`` = d_goal_avg, ``near_goal_subswarms`` = ``n_near`` = n_near)."""
        return {
            "k": self.k, "dt": self.dt, "S": self.S, "path_count": self.n_c,
            "w_max": self.w_max, "w_min": self.w_min, "avg_goal_distance": self.d_goal_avg,
            "near_goal_subswarms": self.n_near, "n_near": self.n_near, "d_swarm_min": self.d_swarm_min,
            "can_split": self.can_split, "can_merge": self.can_merge,
        }


def project(action: str, z: DecisionState) -> str:
    """Pi_feas of eq. (22): split only if I_split, merge only if I_merge, otherwise keep.

    Anything outside A_str (an unparsable suggestion) also becomes keep. The one projection of
    the package: the rule's proposals and every LLM back end's answers (``swarmnav.llm`` is
    handed this function; it has no feasibility rule of its own) go through it.
    """
    if action == "split" and z.can_split:
        return "split"
    if action == "merge" and z.can_merge:
        return "merge"
    return "keep"


# --------------------------------------------------------------------------- decision sources

@dataclass(frozen=True, slots=True)
class Proposal:
    """A suggested structural action with its rationale and origin (``rule``, ``llm``, ...)."""

    action: str
    reason: str
    source: str


class DecisionSource(Protocol):
    """Anything that proposes a structural action from z(k). Proposals are projected by the
    caller with :func:`project`; a source never executes anything itself."""

    def propose(self, z: DecisionState, step: int) -> Proposal: ...


class RulePolicy:
    """The rule-based decision source a_k^rule (HES Section 3.2), on z(k) only:

    1. split when a split is feasible and at least two corridors lead to the goal;
    2. merge when a merge is feasible and two sub-swarms are near the goal;
    3. merge when a merge is feasible because two sub-swarms are closer than d_merge, no longer
       see two corridors (n_c < 2: the paths that motivated the split have rejoined) and the
       split-merge cooldown T_cd has passed since the last change of S (ours: eq. 16 puts no
       cooldown on merges, but merging two sub-swarms that have just been split, and are still
       side by side on their way to different corridors, would undo every split);
    4. keep otherwise.

    The source watches S(k) to know when the structure last changed (its only state).

    ``merge="paper"`` is Section 3.2 as written: rules 1-2, and a merge whenever it is feasible
    (eq. 16: n_near >= 2 or d_swarm_min < d_merge), with no condition of ours;
    ``merge="paper_cooldown"`` reads Table A1's "split-merge cooldown" T_cd as holding merges
    too: a feasible merge waits T_cd after the last change of S.
    """

    MERGES = ("swarmnav", "paper", "paper_cooldown")

    def __init__(self, d_merge: float, cooldown_s: float, merge: str = "swarmnav"):
        if merge not in self.MERGES:
            raise ValueError(f"merge must be one of {self.MERGES}, got {merge!r}")
        self.d_merge = float(d_merge)
        self.cooldown_s = float(cooldown_s)
        self.merge = merge
        self._S: int | None = None
        self._t_change = -math.inf

    def propose(self, z: DecisionState, step: int) -> Proposal:
        t = z.k * z.dt
        if self._S is not None and z.S != self._S:
            self._t_change = t
        self._S = z.S
        if z.can_split and z.n_c >= 2:
            return Proposal("split", f"{z.n_c} corridors toward the goal (w {z.w_min:.1f}-{z.w_max:.1f} m)", "rule")
        if z.can_merge and z.n_near >= 2 and (self.merge != "paper_cooldown" or t - self._t_change >= self.cooldown_s):
            return Proposal("merge", f"{z.n_near} sub-swarms within r_merge of the goal", "rule")
        if self.merge != "swarmnav" and z.can_merge:
            if self.merge == "paper" or t - self._t_change >= self.cooldown_s:
                return Proposal("merge", f"sub-swarms {z.d_swarm_min:.1f} m apart (< d_merge)", "rule")
            return Proposal("keep", "merge feasible, split-merge cooldown T_cd running", "rule")
        if z.can_merge and z.d_swarm_min < self.d_merge and z.n_c < 2 and t - self._t_change >= self.cooldown_s:
            return Proposal("merge", f"sub-swarms {z.d_swarm_min:.1f} m apart (< d_merge)", "rule")
        return Proposal("keep", "no structural change needed", "rule")
