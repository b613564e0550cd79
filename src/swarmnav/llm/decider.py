"""The LLM decision layer of HES Section 3.3, on a plain dict of the state z(k).

Per step k the caller gives the state, the rule action a_k^rule and the feasibility
projection Pi_feas. Pi_feas is the method's own (for HES, ``methods.hes.decision.project``,
the one the rule's proposals go through too): this layer never writes a feasibility rule of
its own, so an LLM and the rule cannot disagree about what is feasible. The decider:

- calls the model when I_llm(k) = 1, eq. (20): at the first step it is asked about and then
  whenever k - k_llm >= T_llm (k_llm = the previous call's step);
- takes the model's action as the candidate at a call step, the rule action otherwise, eq. (21);
- projects the candidate with Pi_feas, eq. (22), exactly as the rule's own actions are
  projected: an answer that parses but is infeasible is executed as ``keep``, and that is not
  a fallback;
- falls back to the rule action on any failure of the model (connection refused, timeout,
  HTTP error, dropped connection, empty or unparsable answer), counted in llm_fallback_used;
  the first call the back end itself fails (not an unparsable answer, and not a replayed
  failure) also writes one warning line on stderr, once per decider, i.e. once per run;
- records every call in a transcript (state, prompt, raw answer, parsed and executed action,
  latency, fallback reason).

With a delayed latency mode (``real`` / ``fixed:S``) a successful answer is held and applied,
projected against the state at that later step, once its latency has elapsed in simulated
time; meanwhile the rule decides and no new call is made.
"""

from __future__ import annotations

import json
import math
import sys
import time
from dataclasses import dataclass
from typing import Any, Callable, Mapping

import numpy as np

from swarmnav.llm.backends import Backend, LlmError, ReplayMismatch
from swarmnav.llm.config import LatencyMode
from swarmnav.llm.parse import parse_answer
from swarmnav.llm.prompt import build_prompt, jsonable

TRANSCRIPT = "llm_transcript.jsonl"


def _warn_stderr(line: str) -> None:
    from tqdm import tqdm

    tqdm.write(line, file=sys.stderr)  # above a progress bar, not through it


def feasible_in(action: str, state: Mapping[str, Any]) -> bool:
    """Whether ``action`` is in the feasible set of ``state``: keep always, split when
    can_split, merge when can_merge (what Pi_feas, eq. 22, lets through unchanged)."""
    return action == "keep" or (action == "split" and bool(state.get("can_split"))) or \
        (action == "merge" and bool(state.get("can_merge")))


@dataclass(frozen=True, slots=True)
class Decision:
    """The structural action of one step and where it came from."""

    action: str  # the candidate a_k of eq. (21), in ACTIONS; the caller projects it
    executed: str  # Pi_feas(a_k), eq. (22): what the caller will execute
    reason: str
    source: str  # "llm" (the model's suggestion) or "rule"


class LlmDecider:
    """Trigger, call, parse, project, fall back and record (see module docstring)."""

    def __init__(self, backend: Backend, interval: int = 50, latency: LatencyMode | str = "blocking",
                 warn: Callable[[str], None] | None = None):
        self.backend = backend
        self.interval = int(interval)
        self.latency = latency if isinstance(latency, LatencyMode) else LatencyMode.parse(latency)
        self.warn = warn or _warn_stderr  # where the one warning of a run whose back end fails goes
        self._warned = False
        self.records: list[dict[str, Any]] = []
        self._k_llm: int | None = None
        self._pending: tuple[int, dict] | None = None  # (apply step, record) of a delayed answer

    def due(self, step: int) -> bool:
        """I_llm(k) of eq. (20); no new call while a delayed answer is pending."""
        if self._pending is not None:
            return False
        return self._k_llm is None or step - self._k_llm >= self.interval

    def decide(self, state: Mapping[str, Any], step: int, rule_action: str, rule_reason: str,
               projection: Callable[[str], str]) -> Decision:
        """The candidate action at step ``step`` and its projection.

        Args:
            state: z(k) as a dict (``DecisionState.to_dict()``).
            rule_action: a_k^rule, the rule policy's action now.
            projection: the method's Pi_feas, eq. (22), bound to this step's state.
        """
        if self._pending is not None and step >= self._pending[0]:
            _, rec = self._pending
            self._pending = None
            return self._apply(rec, step, projection)
        if not self.due(step):
            return Decision(rule_action, projection(rule_action), rule_reason, "rule")
        self._k_llm = step
        rec = self._call(state, step, rule_action)
        if rec["fallback"] is not None:
            action = projection(rule_action)
            rec.update(apply_step=step, executed=action)
            why = f"LLM fallback ({rec['fallback']})"
            return Decision(rule_action, action, f"{why}; rule: {rule_reason}" if rule_reason else why, "rule")
        delay = self.latency.delay_steps(rec["latency_s"], float(state["dt"]))
        if delay == 0:
            return self._apply(rec, step, projection)
        self._pending = (step + delay, rec)
        return Decision(rule_action, projection(rule_action), rule_reason, "rule")

    def _call(self, state: Mapping[str, Any], step: int, rule_action: str) -> dict[str, Any]:
        prompt = build_prompt(state)
        rec: dict[str, Any] = {
            "step": int(step), "backend": self.backend.name, "model": getattr(self.backend, "model", ""),
            "state": {k: jsonable(v, digits=None) for k, v in state.items()}, "prompt": prompt,
            "raw": None, "parsed": None, "parse": None, "reason": None, "rule_action": rule_action,
            "latency_s": None, "apply_step": None, "executed": None, "fallback": None,
        }
        check = getattr(self.backend, "check_state", None)
        if check is not None:
            check(step, rec["state"])
        t0 = time.perf_counter()
        try:
            reply = self.backend.complete(prompt, step)
        except ReplayMismatch:
            raise
        except LlmError as e:
            rec.update(latency_s=e.latency if e.latency is not None else time.perf_counter() - t0, fallback=str(e))
            self._warn_once(step, rec["fallback"])
        except Exception as e:  # a model must never crash the simulation
            rec.update(latency_s=time.perf_counter() - t0, fallback=f"error: {type(e).__name__}: {e}")
            self._warn_once(step, rec["fallback"])
        else:
            parsed = parse_answer(reply.text)
            rec.update(raw=reply.text, latency_s=reply.latency, parsed=parsed.action, parse=parsed.how or None,
                       reason=parsed.reason or None)
            if parsed.action is None:
                rec["fallback"] = f"parse: {parsed.error}"
        self.records.append(rec)
        return rec

    def _warn_once(self, step: int, why: str) -> None:
        """The run's one warning that its back end failed and the rule decides instead: without
        it a run against a server that is down would end with exit 0 and no word. A replay
        re-enacts the recorded run's failures on purpose, so it stays silent."""
        if self._warned or self.backend.name == "replay":
            return
        self._warned = True
        self.warn(f"swarmnav: warning: the LLM back end ({self.backend.name}) failed at step {step}: "
                  f"{' '.join(str(why).split())}; the rule decides wherever a call fails (this run's count: "
                  f"llm_fallback_used in its metrics)")

    def _apply(self, rec: dict[str, Any], step: int, proj: Callable[[str], str]) -> Decision:
        action = proj(rec["parsed"])
        rec.update(apply_step=int(step), executed=action)
        if action != rec["parsed"]:
            reason = f"LLM suggested {rec['parsed']}, infeasible: projected to {action}"
        else:
            reason = f"LLM: {rec['reason']}" if rec["reason"] else "LLM"
        return Decision(rec["parsed"], action, reason, "llm")

    def summary(self) -> dict[str, float]:
        """Run metrics: call and fallback counts, projections, how the answers compare with the
        rule on the same state, latency statistics [s].

        Counts over calls: ``llm_valid`` answers that parsed to an action; ``llm_feasible``
        valid answers feasible in the state they were asked about (keep, split with can_split,
        merge with can_merge); ``llm_agree_rule`` valid answers equal to the rule's action on
        that state; ``llm_differs_feasible`` feasible answers that differ from the rule's (the
        calls where the model changed the decision).
        """
        recs = self.records
        lat = np.array([r["latency_s"] for r in recs], dtype=float)
        some = lat.size > 0
        valid = [r for r in recs if r["parsed"] is not None]
        feasible = [r for r in valid if feasible_in(r["parsed"], r["state"])]
        return {
            "llm_calls": float(len(recs)),
            "llm_fallback_used": float(sum(r["fallback"] is not None for r in recs)),
            "llm_projected": float(sum(r["executed"] is not None and r["parsed"] is not None
                                       and r["executed"] != r["parsed"] for r in recs)),
            "llm_valid": float(len(valid)),
            "llm_feasible": float(len(feasible)),
            "llm_agree_rule": float(sum(r["parsed"] == r["rule_action"] for r in valid)),
            "llm_differs_feasible": float(sum(r["parsed"] != r["rule_action"] for r in feasible)),
            "llm_latency_mean_s": float(lat.mean()) if some else math.nan,
            "llm_latency_median_s": float(np.median(lat)) if some else math.nan,
            "llm_latency_p95_s": float(np.percentile(lat, 95)) if some else math.nan,
            "llm_latency_max_s": float(lat.max()) if some else math.nan,
            "llm_latency_total_s": float(lat.sum()),
        }

    def transcript(self) -> str:
        """The audit transcript as JSON lines, one record per call."""
        return "".join(json.dumps(r, allow_nan=False) + "\n" for r in self.records)

