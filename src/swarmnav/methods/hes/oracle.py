"""``decision=oracle``: a lookahead decider that bounds what any decision source could gain over the rule.

At every step where HES asks its decision source (every step, Section 3.2) and Pi_feas (eq. 22)
leaves more than one distinct action -- keep, and split if I_split, merge if I_merge -- the oracle
flies a copy of the run once per feasible action: the action forced at this step, then
``oracle_horizon`` seconds more with the rule deciding. It scores each flight by the objective J of
:func:`objective` and takes the best; a tie, or a gain of at most ``oracle_margin``, leaves the
rule's action, so the oracle differs from the rule only where the lookahead shows a gain.

The flights are not this package's to fly (methods do not import the simulation): the run hands
the source a simulator, ``lookahead(action, k, steps) -> Outcome`` (``swarmnav.sim.flight``),
through :meth:`OracleSource.attach`. A copy of the source (in a copied run) has no simulator: it
decides by the rule, except at the step a lookahead forced (:meth:`OracleSource.force`).
It is an upper bound under its objective and horizon, not a deployable policy (docs/oracle.md).
"""

from __future__ import annotations

import copy
import math
import time
from dataclasses import dataclass
from typing import Any, Callable

from swarmnav.errors import ConfigError
from swarmnav.methods.hes.decision import A_STR, DecisionState, Proposal, RulePolicy, project


def objective(o: Any, p: Any) -> float:
    """J [m] of one lookahead outcome ``o`` under the ``oracle_*`` weights of ``p``:

    J = progress + w_reach R + w_success Y - w_crash C - w_unsafe U

    progress: mean decrease of the agents' distances to the goal region over the flight [m];
    R: fraction of agents at the goal at its end (as R_goal judges), Y: R >= 0.8 (the run's Y);
    C: fraction of agents crashed during it; U: fraction of agent-steps within d_safe of an
    obstacle (the run's R_unsafe_agent). Weights are metres of progress.
    """
    return (o.progress + p.oracle_w_reach * o.reached + p.oracle_w_success * o.success
            - p.oracle_w_crash * o.crashed - p.oracle_w_unsafe * o.unsafe)


class OracleSource:
    """The oracle decision source (module docstring); ``propose(z, step)`` as every source.

    Args:
        rule: the rule source, asked every step (its state stays that of a rule run).
        params: a record with the ``oracle_*`` fields and ``paper.dt`` (HES's parameters).
    """

    def __init__(self, rule: RulePolicy, params: Any):
        self.rule, self.params = rule, params
        self.horizon_steps = max(1, round(params.oracle_horizon / params.paper.dt))
        self.lookahead: Callable[[str, int, int], Any] | None = None
        self.forced: tuple[int, str] | None = None
        self.decisions = 0  # decision points with two or more distinct feasible actions (each flown)
        self.changed = 0  # of these, where the oracle's action differs from the rule's
        self.spread = 0  # of these, where the best and worst actions' J differ by more than oracle_margin
        self.flown = 0  # lookahead steps simulated in all
        self.wall = 0.0  # [s] wall time in the lookahead flights
        self.gap = 0.0  # sum over decision points of J(best) - J(worst) [m]
        self.gain = 0.0  # sum over decision points of J(chosen) - J(rule's action) [m]

    def attach(self, lookahead: Callable[[str, int, int], Any]) -> None:
        """The simulator of the run (called by ``swarmnav.run`` after reset)."""
        self.lookahead = lookahead

    def force(self, k: int, action: str) -> None:
        """In a copied run: propose ``action`` at step ``k``; the rule decides at every other step."""
        self.forced = (int(k), action)

    #: what a copy of the source does not take (a copy decides by the rule or a forced action)
    _not_copied: tuple[str, ...] = ("lookahead",)

    def __deepcopy__(self, memo: dict) -> OracleSource:
        new = type(self).__new__(type(self))
        memo[id(self)] = new
        for key, value in self.__dict__.items():
            setattr(new, key, None if key in self._not_copied else copy.deepcopy(value, memo))
        return new

    def propose(self, z: DecisionState, step: int) -> Proposal:
        r = self.rule.propose(z, step)  # every step, as in a rule run: the rule's memory of S(k)
        if self.forced is not None:
            if self.forced[0] == step:
                return Proposal(self.forced[1], "oracle lookahead: forced action", "oracle")
            return r
        if self.lookahead is None:
            raise ConfigError("decision=oracle flies copies of the run: fly it with swarmnav.run / swarmnav run")
        ruled = project(r.action, z)
        others = [a for a in A_STR if a != ruled and project(a, z) == a]
        if not others:
            return r
        t0 = time.perf_counter()
        p = self.params
        J = {}
        for a in (ruled, *others):
            o = self.lookahead(a, step, self.horizon_steps)
            self.flown += o.steps
            J[a] = objective(o, p)
        self.wall += time.perf_counter() - t0
        self.decisions += 1
        best = max(others, key=lambda a: J[a])  # A_STR order breaks an exact tie among the others
        self.gap += max(J.values()) - min(J.values())
        if max(J.values()) - min(J.values()) > p.oracle_margin:
            self.spread += 1
        if not J[best] > J[ruled] + p.oracle_margin:
            return r
        self.changed += 1
        self.gain += J[best] - J[ruled]
        return Proposal(best, f"oracle: J {J[best]:.2f} m against the rule's {ruled} {J[ruled]:.2f} m "
                              f"over {p.oracle_horizon:g} s", "oracle")

    def summary(self) -> dict[str, float]:
        """Run metrics: decision points flown, changed, with a spread above ``oracle_margin``,
        lookahead steps; the mean best-minus-worst J and the mean gain of the chosen action over
        the rule's, per decision point [m]."""
        d = self.decisions
        return {"hes_oracle_decisions": float(d), "hes_oracle_changed": float(self.changed),
                "hes_oracle_spread": float(self.spread), "hes_oracle_steps": float(self.flown),
                "hes_oracle_steps_per_decision": self.flown / d if d else 0.0,
                "hes_oracle_gap": self.gap / d if d else 0.0, "hes_oracle_gain": self.gain / d if d else 0.0}

    def timings(self) -> dict[str, float]:
        """Wall-clock figures: the lookahead flights per decision point [ms] and in all [s], and the
        copies of the run the simulator keeps at the start of every step [s]."""
        d = self.decisions
        return {"oracle_ms_per_decision": 1e3 * self.wall / d if d else math.nan, "oracle_s": self.wall,
                "oracle_copy_s": float(getattr(self.lookahead, "copy_wall", 0.0))}


@dataclass(frozen=True, slots=True)
class ProbePoint:
    """One decision point a :class:`OracleProbe` flew ahead.

    Attributes:
        k: step; z: z(k) as the planner saw it; rule: the rule's proposal a_k^rule;
        feasible: the actions Pi_feas lets through (A_STR order);
        J: objective [m] of each feasible action (:func:`objective`);
        outcomes: the lookahead outcome of each feasible action (``swarmnav.sim.flight.Outcome``).
    """

    k: int
    z: DecisionState
    rule: Proposal
    feasible: tuple[str, ...]
    J: dict[str, float]
    outcomes: dict[str, Any]


class OracleProbe(OracleSource):
    """A rule run that flies every feasible action ahead at the steps ``select`` picks, and
    keeps the objectives: the oracle's labels of the decision benchmark (docs/llm-bench.md).

    It always returns the rule's proposal, so the run is the rule run bit for bit (the flights
    are in copies). At a selected step it flies each action of the feasible set -- keep alone
    too, where nothing else is feasible -- for ``oracle_horizon`` seconds with the rule deciding
    afterwards, exactly as :class:`OracleSource` does at a decision point, and appends a
    :class:`ProbePoint` to ``points``.

    Args:
        rule, params: as :class:`OracleSource`.
        select: ``select(step, z, rule_action, feasible) -> bool``, the steps to fly ahead.
    """

    _not_copied = ("lookahead", "select", "points")

    def __init__(self, rule: RulePolicy, params: Any, select: Callable[[int, DecisionState, str, tuple], bool]):
        super().__init__(rule, params)
        self.select = select
        self.points: list[ProbePoint] = []

    def propose(self, z: DecisionState, step: int) -> Proposal:
        r = self.rule.propose(z, step)
        if self.forced is not None:  # a copy flying one lookahead
            return Proposal(self.forced[1], "oracle lookahead: forced action", "oracle") if self.forced[0] == step else r
        if self.lookahead is None:
            raise ConfigError("an oracle probe flies copies of the run: fly it with swarmnav.run")
        feasible = tuple(a for a in A_STR if project(a, z) == a)
        if self.select(step, z, r.action, feasible):
            t0 = time.perf_counter()
            J, outcomes = {}, {}
            for a in feasible:
                o = self.lookahead(a, step, self.horizon_steps)
                self.flown += o.steps
                J[a], outcomes[a] = objective(o, self.params), o
            self.wall += time.perf_counter() - t0
            self.decisions += 1
            self.points.append(ProbePoint(int(step), z, r, feasible, J, outcomes))
        return r
