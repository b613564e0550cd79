"""``swarmnav llm check``: does a back end answer, how fast, and does the answer parse?"""

from __future__ import annotations

from typing import TextIO

from swarmnav.llm.backends import LlmError, make_backend
from swarmnav.llm.config import LlmParams, backend_of
from swarmnav.llm.parse import parse_answer
from swarmnav.llm.prompt import build_prompt

#: A representative z(k): one swarm at the corridor entrance with two corridors ahead.
SAMPLE_STATE = {
    "k": 1, "dt": 0.1, "S": 1, "path_count": 2, "w_max": 5.2, "w_min": 4.8, "avg_goal_distance": 58.0,
    "near_goal_subswarms": 0, "d_swarm_min": float("inf"), "can_split": True, "can_merge": False,
}


def check(p: LlmParams, out: TextIO) -> int:
    """Ask back end ``p.decision`` once about :data:`SAMPLE_STATE`; 0 if it answered with a
    parsable action, 1 otherwise. ``decision=rule`` needs no model and passes."""
    if backend_of(p) == "rule":
        print("decision=rule: the rule policy needs no model", file=out)
        return 0
    backend = make_backend(p.decision, url=p.llm_url, model=p.llm_model, timeout=p.llm_timeout, gguf=p.llm_gguf,
                           replay=p.llm_replay, response_format=p.llm_response_format, threads=p.llm_threads)
    where = getattr(backend, "url", None) or getattr(backend, "path", "")
    print(f"back end {backend.name} ({where}), model {backend.model or '-'}, timeout {p.llm_timeout:g} s", file=out)
    step = min(getattr(backend, "records", None) or [0])  # replay: its first recorded call
    try:
        reply = backend.complete(build_prompt(SAMPLE_STATE), step)
    except LlmError as e:
        print(f"FAIL: {e}", file=out)
        return 1
    parsed = parse_answer(reply.text)
    print(f"latency {reply.latency:.2f} s; raw answer: {reply.text.strip()[:300]!r}", file=out)
    if parsed.action is None:
        print(f"FAIL: unparsable answer ({parsed.error})", file=out)
        return 1
    print(f"OK: decision {parsed.action} (parsed from {parsed.how}); reason: {parsed.reason or '-'}", file=out)
    return 0
