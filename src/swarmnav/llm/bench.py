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

When the states carry the oracle's labels (``swarmnav.llm.labels``: the objective J [m] of
every feasible action from the oracle's lookahead, and its choice), each answer is also scored
against the oracle:

- ``agree_oracle``: answers equal to the oracle's choice;
- ``regret_m``: J(oracle's choice) - J(executed action) [m], where the executed action is what a
  run would execute: the answer through Pi_feas (an infeasible answer is keep), the rule's action
  when the answer is invalid (a run's fallback). It is >= 0, and 0 for the oracle's own choice;
- the same two over the ``choice`` states only (two or more feasible actions: the only states
  where an answer can lose anything).

``rule`` answers the recorded rule action (the reference: 1.0 / 1.0 by construction);
``replay`` re-reads the raw answers of a bench transcript (``--llm-replay``), so a model's
bench can be re-scored exactly without the model.
"""

from __future__ import annotations

import csv
import io
import json
import math
import time
from collections import Counter, defaultdict
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any, TextIO

import numpy as np

from swarmnav.errors import ConfigError
from swarmnav.llm.backends import LlmError, make_backend
from swarmnav.llm.config import LlmParams, backend_of
from swarmnav.llm.decider import feasible_in
from swarmnav.llm.labels import check_label, executed
from swarmnav.llm.parse import parse_answer
from swarmnav.llm.prompt import ACTIONS, build_prompt


#: best and worst feasible actions' J further apart than this [m] = a state where the decision matters
#: (oracle_margin's default, docs/oracle.md)
MATTERS_M = 0.01


def load_states(path: str | Path | None = None) -> list[dict[str, Any]]:
    """The recorded decision states (the shipped, labelled file unless ``path`` is given).

    Raises:
        ConfigError: an unreadable file, a line that is not a JSON object with ``state``,
            ``rule`` (an action) and ``feasible`` (actions, keep among them), an inconsistent
            oracle label, or a file where only some states are labelled.
    """
    name = str(path) if path else "decision states"
    if path:
        try:
            text = Path(path).expanduser().read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError) as e:
            raise ConfigError(f"--states {path}: cannot read it ({getattr(e, 'strerror', None) or e})") from None
    else:
        text = resources.files("swarmnav.llm").joinpath("data", "decision_states.jsonl").read_text("utf-8")
    rows = []
    for n, line in enumerate(text.splitlines(), 1):
        if not line.strip():
            continue
        try:
            r = json.loads(line)
        except ValueError as e:
            raise ConfigError(f"{name} line {n}: not JSON ({e})") from None
        if (not isinstance(r, dict) or not ({"state", "rule", "feasible"} <= set(r)) or r["rule"] not in ACTIONS
                or not isinstance(r["state"], dict) or not isinstance(r["feasible"], list)
                or not set(r["feasible"]) <= set(ACTIONS) or "keep" not in r["feasible"]):
            raise ConfigError(f"{name} line {n}: needs state, rule (an action) and feasible (actions, keep among them)")
        if "oracle" in r:
            check_label(r, f"{name} line {n}")
        rows.append(r)
    if not rows:
        raise ConfigError(f"{name}: no decision states")
    labelled = sum("oracle" in r for r in rows)
    if 0 < labelled < len(rows):
        raise ConfigError(f"{name}: {labelled} of {len(rows)} states carry oracle labels; label all of them "
                          "(swarmnav llm label) or none")
    return rows


@dataclass
class BenchResult:
    """Answers of one back end on the recorded states."""

    backend: str
    model: str
    records: list[dict[str, Any]] = field(default_factory=list)

    @property
    def labelled(self) -> bool:
        """Whether the states carried the oracle's labels (regret is scored)."""
        return bool(self.records) and all("regret_m" in r for r in self.records)

    def summary(self, records: list[dict[str, Any]] | None = None) -> dict[str, float]:
        """The scores over ``records`` (default: all); with labels also the oracle's (module docstring)."""
        recs = self.records if records is None else records
        n = len(recs)
        lat = np.array([r["latency_s"] for r in recs], dtype=float)
        valid = [r for r in recs if r["parsed"] is not None]
        out = {
            "states": float(n),
            "valid": len(valid) / n if n else math.nan,
            "invalid": 1 - len(valid) / n if n else math.nan,
            "call_failures": float(sum(r["raw"] is None for r in recs)),
            "feasible": sum(feasible_in(r["parsed"], r["state"]) for r in valid) / n if n else math.nan,
            "agree": sum(r["parsed"] == r["rule_action"] for r in valid) / n if n else math.nan,
            "latency_median_s": float(np.median(lat)) if n else math.nan,
            "latency_p95_s": float(np.percentile(lat, 95)) if n else math.nan,
        }
        if n and all("regret_m" in r for r in recs):
            choice = [r for r in recs if r["choice"]]
            reg = np.array([r["regret_m"] for r in recs])
            creg = np.array([r["regret_m"] for r in choice])
            out.update({
                "agree_oracle": sum(r["parsed"] == r["oracle_action"] for r in recs) / n,
                "regret_mean_m": float(reg.mean()), "regret_max_m": float(reg.max()),
                "choice_states": float(len(choice)),
                "agree_oracle_choice": (sum(r["parsed"] == r["oracle_action"] for r in choice) / len(choice)
                                        if choice else math.nan),
                "agree_rule_choice": (sum(r["parsed"] == r["rule_action"] for r in choice) / len(choice)
                                      if choice else math.nan),
                "regret_mean_choice_m": float(creg.mean()) if choice else math.nan,
                "lost_choice": (float(np.count_nonzero(creg > 0)) / len(choice)) if choice else math.nan,
                # the room to decide (a property of the states): best and worst feasible actions apart
                "matters_choice": (sum(r["spread_m"] > MATTERS_M for r in choice) / len(choice)) if choice else math.nan,
                "spread_mean_choice_m": float(np.mean([r["spread_m"] for r in choice])) if choice else math.nan,
            })
        return out

    def groups(self) -> dict[tuple[str, str], dict[str, float]]:
        """The summary per (scene, build) of the states (rows without them: ``-``)."""
        by: dict[tuple[str, str], list] = defaultdict(list)
        for r in self.records:
            by[(r.get("scene") or "-", r.get("build") or "-")].append(r)
        return {key: self.summary(recs) for key, recs in sorted(by.items())}

    def table(self) -> list[dict[str, Any]]:
        """One row per (scene, build) and one for all states: the JSON / CSV summary."""
        head = {"backend": self.backend, "model": self.model}
        rows = [{**head, "scene": "all", "build": "all", **self.summary()}]
        rows += [{**head, "scene": sc, "build": b, **s} for (sc, b), s in self.groups().items()]
        return rows

    def write_summary(self, path: str | Path) -> None:
        """The summary table as JSON (``.json``: a list of rows) or CSV (any other suffix)."""
        rows = self.table()
        p = Path(path).expanduser()
        if p.suffix == ".json":
            text = json.dumps([{k: (None if isinstance(v, float) and not math.isfinite(v) else v)
                                for k, v in r.items()} for r in rows], indent=1) + "\n"
        else:
            keys = list(dict.fromkeys(k for r in rows for k in r))
            buf = io.StringIO()
            w = csv.DictWriter(buf, fieldnames=keys, lineterminator="\n")
            w.writeheader()
            w.writerows(rows)
            text = buf.getvalue()
        try:
            p.write_text(text, encoding="utf-8")
        except OSError as e:
            raise ConfigError(f"--summary {path}: cannot write it ({e.strerror})") from None

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
    rec = {"step": i, "id": row.get("id", str(i)), "model": model, "state": row["state"], "rule_action": row["rule"],
           "raw": raw, "parsed": action, "parse": parsed.how if parsed is not None and parsed.how else None,
           "latency_s": float(latency), "fallback": failure}
    if "scene" in row:
        rec.update(scene=row["scene"], build=row.get("build") or "swarmnav")
    if "oracle" in row:
        feasible, J = row["feasible"], row["oracle"]["J"]
        # what a run executes: the answer through Pi_feas, the rule's action on a fallback
        done = executed(row["rule"] if action is None else action, feasible)
        rec.update(oracle_action=row["oracle"]["choice"], executed=done, choice=len(feasible) > 1,
                   regret_m=float(J[row["oracle"]["choice"]] - J[done]), spread_m=float(max(J.values()) - min(J.values())))
    return rec


def report(res: BenchResult, out: TextIO) -> None:
    """The summary line and the (rule action x answer) table."""
    s = res.summary()
    print(f"{res.backend} ({res.model}) on {s['states']:.0f} recorded states:", file=out)
    print(f"  feasible (accuracy vs the feasible set) {s['feasible']:.3f}   agree with rule {s['agree']:.3f}   "
          f"invalid {s['invalid']:.3f} ({s['call_failures']:.0f} call failures)   "
          f"latency median {s['latency_median_s']:.3f} s, p95 {s['latency_p95_s']:.3f} s", file=out)
    if res.labelled:
        print(f"  against the oracle: agree {s['agree_oracle']:.3f}   mean regret {s['regret_mean_m']:.3f} m "
              f"(max {s['regret_max_m']:.2f} m)", file=out)
        print(f"  on the {s['choice_states']:.0f} states with a choice: agree with oracle "
              f"{s['agree_oracle_choice']:.3f}, with rule {s['agree_rule_choice']:.3f}   mean regret "
              f"{s['regret_mean_choice_m']:.3f} m   states lost (regret > 0) {s['lost_choice']:.3f}", file=out)
        print(f"  {'scene':<26}{'build':<10}{'states':>7}{'choice':>7}{'agree oracle':>14}{'agree rule':>12}"
              f"{'regret [m]':>12}{'regret, choice [m]':>20}{'matters':>9}{'best-worst [m]':>16}", file=out)
        for (scene, build), g in res.groups().items():
            c = g["choice_states"] > 0
            fmt = lambda key, spec: format(g[key], spec) if c else "-"  # noqa: E731
            print(f"  {scene:<26}{build:<10}{g['states']:>7.0f}{g['choice_states']:>7.0f}{g['agree_oracle']:>14.3f}"
                  f"{g['agree']:>12.3f}{g['regret_mean_m']:>12.3f}{fmt('regret_mean_choice_m', '.3f'):>20}"
                  f"{fmt('matters_choice', '.2f'):>9}{fmt('spread_mean_choice_m', '.1f'):>16}", file=out)
        print(f"  (choice: states with two or more feasible actions; matters: of these, the share where the best and "
              f"worst actions' J differ by more than {MATTERS_M} m)", file=out)
    conf = res.confusion()
    answers = [*ACTIONS, "invalid"]
    print("  rule \\ answer " + "".join(f"{a:>9}" for a in answers), file=out)
    for a in ACTIONS:
        print(f"  {a:<14}" + "".join(f"{conf.get((a, b), 0):>9d}" for b in answers), file=out)
