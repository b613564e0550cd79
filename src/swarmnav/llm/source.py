"""The LLM decision layer as a decision source of a method (HES's ``DecisionSource``).

A method that decides structure asks a source ``propose(z, step)`` each decision step; the
rule source answers from the rules. :func:`decision_source` wraps that rule source when the
method's parameters select an LLM back end, so the method itself needs one line to gain LLM
decisions. The wrapper only needs ``z.to_dict()`` (or a dict) and the rule's proposal, whose
own class it reuses for its answer.
"""

from __future__ import annotations

from typing import Any, Callable

from swarmnav.llm.backends import make_backend
from swarmnav.llm.config import LatencyMode, backend_of, llm_params
from swarmnav.llm.decider import TRANSCRIPT, LlmDecider


class LlmDecisionSource:
    """``propose(z, step)``: the LLM's action at call steps, the rule's otherwise (eq. 21).

    The proposal is the candidate a_k, unprojected: the method projects it with Pi_feas as it
    projects the rule's; the transcript records that projection as the executed action.

    Args:
        rule: the rule source (``propose(z, step)`` -> a proposal with ``action``, ``reason``,
            ``source``), asked every step: its action is a_k^rule and the fallback.
        decider: the :class:`LlmDecider` that calls the model.
        project: the method's Pi_feas, eq. (22), as ``project(action, z)``: the very function
            the method projects the rule's proposals with (this layer has none of its own).
    """

    def __init__(self, rule: Any, decider: LlmDecider, project: Callable[[str, Any], str]):
        self.rule, self.decider, self.project = rule, decider, project

    def propose(self, z: Any, step: int) -> Any:
        r = self.rule.propose(z, step)
        state = z.to_dict() if hasattr(z, "to_dict") else dict(z)
        d = self.decider.decide(state, step, r.action, r.reason, lambda a: self.project(a, z))
        if d.source == "rule" and d.action == r.action and d.reason == r.reason:
            return r
        return type(r)(action=d.action, reason=d.reason, source=d.source)

    def __deepcopy__(self, memo: dict) -> Any:
        raise TypeError("an LLM decision source cannot be copied (its back end is a model or a server); "
                        "a copied run decides by the rule (decision=oracle, docs/oracle.md)")

    def summary(self) -> dict[str, float]:
        return self.decider.summary()

    def artifacts(self) -> dict[str, str]:
        return {TRANSCRIPT: self.decider.transcript()}


def decision_source(params: Any, rule: Any, project: Callable[[str, Any], str]) -> Any:
    """``rule`` itself for ``params.decision == "rule"``, else an :class:`LlmDecisionSource`
    on the back end the ``llm_*`` fields of ``params`` describe (raises ConfigError).

    ``project`` is the method's Pi_feas (eq. 22), which the LLM's answers go through as the
    rule's do."""
    p = llm_params(params)
    if backend_of(p) == "rule":
        return rule
    backend = make_backend(p.decision, url=p.llm_url, model=p.llm_model, timeout=p.llm_timeout, gguf=p.llm_gguf,
                           replay=p.llm_replay, response_format=p.llm_response_format, threads=p.llm_threads)
    return LlmDecisionSource(rule, LlmDecider(backend, p.llm_interval, LatencyMode.parse(p.llm_latency)), project)
