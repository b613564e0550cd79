"""``swarmnav llm bench``: a decision back end on recorded decision states, without a simulation.

The states (``data/decision_states.jsonl``, recorded by ``benchmarks/record_llm_states.py``)
are z(k) as HES's planner saw it in rule runs on the paper's four scenes: at the LLM call
steps of eq. (20) (k = 0, 50, ...) and at every step where the rule split or merged. Each has
the rule's action a_k^rule and the feasible set (the actions Pi_feas, eq. 22, lets through).
The back end is asked with the same prompt, parser and decoding settings as in a run, and the
bench reports, over all states:

- ``valid``: answers that parsed to an action (``invalid`` = the rest: call failures and
  unparsable answers, the cases a run falls back to the rule);
- ``feasible``: answers in the state's feasible set (invalid ones count as not feasible) —
  the accuracy against the feasible set;
- ``agree``: answers equal to the rule's action on that state;
- latency per call (median, p95) [s].

``rule`` answers the recorded rule action (the reference: 1.0 / 1.0 by construction);
``replay`` re-reads the raw answers of a bench transcript (``--llm-replay``), so a model's
bench can be re-scored exactly without the model.
"""

from __future__ import annotations

import json
import math
import time
from collections import Counter
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any, TextIO

import numpy as np

from swarmnav.errors import ConfigError
from swarmnav.llm.backends import LlmError, make_backend
from swarmnav.llm.config import LlmParams, backend_of
from swarmnav.llm.decider import feasible_in
from swarmnav.llm.parse import parse_answer
from swarmnav.llm.prompt import ACTIONS, build_prompt


def load_states(path: str | Path | None = None) -> list[dict[str, Any]]:
    """The recorded decision states (the shipped file unless ``path`` is given)."""
    if path:
        text = Path(path).expanduser().read_text(encoding="utf-8")
    else:
        text = resources.files("swarmnav.llm").joinpath("data", "decision_states.jsonl").read_text("utf-8")
    rows = [json.loads(line) for line in text.splitlines() if line.strip()]
    for n, r in enumerate(rows, 1):
        if not ({"state", "rule", "feasible"} <= set(r)) or r["rule"] not in ACTIONS:
            raise ConfigError(f"decision states line {n}: needs state, rule (an action) and feasible")
    return rows


@dataclass
class BenchResult:
    """Answers of one back end on the recorded states."""

    backend: str
    model: str
    records: list[dict[str, Any]] = field(default_factory=list)

    def summary(self) -> dict[str, float]:
        n = len(self.records)
        lat = np.array([r["latency_s"] for r in self.records], dtype=float)
        valid = [r for r in self.records if r["parsed"] is not None]
        return {
            "states": float(n),
            "valid": len(valid) / n if n else math.nan,
            "invalid": 1 - len(valid) / n if n else math.nan,
            "call_failures": float(sum(r["raw"] is None for r in self.records)),
            "feasible": sum(feasible_in(r["parsed"], r["state"]) for r in valid) / n if n else math.nan,
            "agree": sum(r["parsed"] == r["rule_action"] for r in valid) / n if n else math.nan,
            "latency_median_s": float(np.median(lat)) if n else math.nan,
            "latency_p95_s": float(np.percentile(lat, 95)) if n else math.nan,
        }

    def confusion(self) -> dict[tuple[str, str], int]:
        """(rule action, answer) -> count; answer ``invalid`` when none parsed."""
        return dict(Counter((r["rule_action"], r["parsed"] or "invalid") for r in self.records))

    def transcript(self) -> str:
        """The raw answers as JSON lines, keyed by state index (``step``): what ``replay`` reads."""
        return "".join(json.dumps(r, allow_nan=False) + "\n" for r in self.records)


def bench(p: LlmParams, states: list[dict[str, Any]], progress: TextIO | None = None,
          sink: TextIO | None = None) -> BenchResult:
    """Ask back end ``p.decision`` about every state (``rule``: the recorded rule action).

    ``sink``: each answer is written there as a transcript line as soon as it is in, so an
    interrupted bench keeps what it measured."""
    if backend_of(p) == "rule":
        res = BenchResult("rule", "-")
        for i, row in enumerate(states):
            res.records.append(_record(i, row, "rule", row["rule"], 0.0, None))
        if sink is not None:
            sink.write(res.transcript())
        return res
    backend = make_backend(p.decision, url=p.llm_url, model=p.llm_model, timeout=p.llm_timeout, gguf=p.llm_gguf,
                           replay=p.llm_replay, response_format=p.llm_response_format, threads=p.llm_threads)
    res = BenchResult(backend.name, getattr(backend, "model", ""))
    check = getattr(backend, "check_state", None)
    for i, row in enumerate(states):
        if check is not None:
            check(i, row["state"])
        t0 = time.perf_counter()
        try:
            reply = backend.complete(build_prompt(row["state"]), i)
            raw, latency, failure = reply.text, reply.latency, None
        except LlmError as e:
            raw, latency, failure = None, e.latency if e.latency is not None else time.perf_counter() - t0, str(e)
        res.records.append(_record(i, row, res.model, raw, latency, failure))
        if sink is not None:
            sink.write(json.dumps(res.records[-1], allow_nan=False) + "\n")
            sink.flush()
        if progress is not None and (i + 1) % 25 == 0:
            s = res.summary()
            print(f"  {i + 1}/{len(states)} states: valid {s['valid']:.3f}, feasible {s['feasible']:.3f}, "
                  f"agree {s['agree']:.3f}, median {s['latency_median_s']:.2f} s", file=progress, flush=True)
    return res


def _record(i: int, row: dict, model: str, raw: str | None, latency: float, failure: str | None) -> dict:
    parsed = parse_answer(raw) if raw is not None else None
    action = parsed.action if parsed is not None else None
    if failure is None and action is None:
        failure = f"parse: {parsed.error}" if parsed is not None else "no answer"
    return {"step": i, "id": row.get("id", str(i)), "model": model, "state": row["state"], "rule_action": row["rule"],
            "raw": raw, "parsed": action, "parse": parsed.how if parsed is not None and parsed.how else None,
            "latency_s": float(latency), "fallback": failure}


def report(res: BenchResult, out: TextIO) -> None:
    """The summary line and the (rule action x answer) table."""
    s = res.summary()
    print(f"{res.backend} ({res.model}) on {s['states']:.0f} recorded states:", file=out)
    print(f"  feasible (accuracy vs the feasible set) {s['feasible']:.3f}   agree with rule {s['agree']:.3f}   "
          f"invalid {s['invalid']:.3f} ({s['call_failures']:.0f} call failures)   "
          f"latency median {s['latency_median_s']:.3f} s, p95 {s['latency_p95_s']:.3f} s", file=out)
    conf = res.confusion()
    answers = [*ACTIONS, "invalid"]
    print("  rule \\ answer " + "".join(f"{a:>9}" for a in answers), file=out)
    for a in ACTIONS:
        print(f"  {a:<14}" + "".join(f"{conf.get((a, b), 0):>9d}" for b in answers), file=out)
