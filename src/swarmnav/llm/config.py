"""LLM decision parameters: which back end, where, how often, and how its latency counts."""

from __future__ import annotations

import importlib.util
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from swarmnav.errors import ConfigError

#: Values of ``decision``: the rule policy, an LLM back end, or the lookahead oracle (a bound, not a
#: back end: the method builds it, docs/oracle.md).
DECISIONS = ("rule", "ollama", "openai", "llamacpp", "replay", "oracle")


@dataclass(frozen=True, slots=True)
class LlmParams:
    """Parameters of the LLM decision layer (HES Section 3.3). A method that offers LLM
    decisions carries these fields under the same names (``--set llm_timeout=...``)."""

    decision: str = "rule"  # rule | ollama | openai | llamacpp | replay | oracle
    llm_url: str = ""  # server URL; "" = the back end's default (Ollama :11434, OpenAI-compatible :8000/v1)
    llm_model: str = "qwen2.5:3b"  # model name, HES Section 3.3 (ignored by llamacpp and replay)
    llm_timeout: float = 120.0  # per-call timeout [s], HES Section 3.3
    llm_interval: int = 50  # T_llm [steps] between calls, eq. (20) (50 steps = 5 s at dt = 0.1 s)
    llm_gguf: str = ""  # decision=llamacpp: a .gguf path or a model name (swarmnav.llm.models); "" = smollm2
    llm_latency: str = "blocking"  # blocking | real | fixed:SECONDS (ours, beyond the paper; see LatencyMode)
    llm_replay: str = ""  # transcript (or run directory) for decision=replay
    llm_response_format: str = "json_object"  # openai back end: json_object | json_schema | none
    llm_threads: int = 0  # llama.cpp CPU threads; 0 = llama-cpp-python's default

    def __post_init__(self) -> None:
        validate(self)


@dataclass(frozen=True, slots=True)
class LatencyMode:
    """How a model's answer time enters the simulation (our extension, not in the paper).

    - ``blocking`` (the paper's setting): the simulation waits; the decision applies at the
      step it was asked for.
    - ``real``: the swarm flies on under the rule policy while the model thinks; the answer
      applies ``ceil(latency / dt)`` steps after the call, latency being the measured wall time.
    - ``fixed:S``: the same with a fixed latency of S seconds (reproducible without timing noise).
    """

    kind: str  # "blocking", "real" or "fixed"
    seconds: float = 0.0  # for "fixed" [s]

    @classmethod
    def parse(cls, text: str) -> LatencyMode:
        t = str(text).strip().lower()
        if t in ("blocking", "real"):
            return cls(t)
        if t.startswith("fixed:"):
            try:
                s = float(t[6:])
            except ValueError:
                s = math.nan
            if math.isfinite(s) and s >= 0:
                return cls("fixed", s)
        raise ConfigError(f"llm_latency: expected blocking, real or fixed:SECONDS (>= 0), got {text!r}")

    def delay_steps(self, latency: float, dt: float) -> int:
        """Steps between the call and the step its decision applies."""
        if self.kind == "blocking":
            return 0
        seconds = self.seconds if self.kind == "fixed" else latency
        return max(0, math.ceil(seconds / dt - 1e-9))


def validate(p: Any) -> None:
    """Check the LLM fields of any parameter record that carries them (raises ConfigError)."""
    if p.decision not in DECISIONS:
        raise ConfigError(f"decision: expected one of {', '.join(DECISIONS)}, got {p.decision!r}")
    if not (p.llm_timeout > 0):
        raise ConfigError(f"llm_timeout: must be > 0 s, got {p.llm_timeout!r}")
    if p.llm_interval < 1:
        raise ConfigError(f"llm_interval: must be >= 1 step, got {p.llm_interval!r}")
    LatencyMode.parse(p.llm_latency)
    if getattr(p, "llm_response_format", "json_object") not in ("json_object", "json_schema", "none"):
        raise ConfigError("llm_response_format: expected json_object, json_schema or none, "
                          f"got {p.llm_response_format!r}")
    # what a back end needs, checked here so that a sweep fails before its first run
    if p.decision == "llamacpp":
        from swarmnav.llm.models import resolve_gguf

        resolve_gguf(p.llm_gguf, assemble=False)
        if importlib.util.find_spec("llama_cpp") is None:
            raise ConfigError("decision=llamacpp needs llama-cpp-python: pip install 'swarmnav[llm]'")
    if p.decision == "replay":
        if not p.llm_replay:
            raise ConfigError("decision=replay needs llm_replay=PATH (a run directory or its llm_transcript.jsonl)")
        t = Path(p.llm_replay).expanduser()
        if not (t / "llm_transcript.jsonl" if t.is_dir() else t).is_file():
            raise ConfigError(f"llm_replay: no transcript at {t}")


def backend_of(p: Any) -> str:
    """``p.decision`` if it names an LLM back end or ``rule``; ConfigError for ``oracle``, which
    is no model to ask: it flies copies of a run (docs/oracle.md)."""
    if p.decision == "oracle":
        raise ConfigError("decision=oracle is no LLM back end: it decides by flying copies of a run, "
                          "so only `swarmnav run` / experiments fly it (docs/oracle.md)")
    return p.decision


def llm_params(p: Any) -> LlmParams:
    """The LLM fields of parameter record ``p`` (any object with the LlmParams attributes)."""
    from dataclasses import fields

    return LlmParams(**{f.name: getattr(p, f.name) for f in fields(LlmParams) if hasattr(p, f.name)})
