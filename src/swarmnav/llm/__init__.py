"""LLM-assisted structural decisions, HES Section 3.3.

A local model suggests split / merge / keep every T_llm steps from the state z(k); the
suggestion goes through the same feasibility projection as the rule policy (the method's
own Pi_feas, eq. 22, handed in by the method; this package defines none), and any failure of
the model falls back to the rule action. Pieces, each usable alone on a plain dict of z(k):

- :mod:`~swarmnav.llm.prompt`: the prompt P(z(k)), the answer schema, decoding settings;
- :mod:`~swarmnav.llm.parse`: raw answer -> action (JSON block, then keyword search);
- :mod:`~swarmnav.llm.backends`: ollama, openai-compatible, llama.cpp in-process, replay;
- :mod:`~swarmnav.llm.decider`: trigger (eq. 20), applying the method's projection (eq. 22),
  fallback, transcript;
- :mod:`~swarmnav.llm.source`: the decider as a method's decision source.
"""

from swarmnav.llm.backends import LlmError, ReplayMismatch, make_backend
from swarmnav.llm.config import DECISIONS, LatencyMode, LlmParams
from swarmnav.llm.decider import TRANSCRIPT, Decision, LlmDecider
from swarmnav.llm.parse import Parsed, parse_answer
from swarmnav.llm.prompt import ACTIONS, SCHEMA, build_prompt
from swarmnav.llm.source import LlmDecisionSource, decision_source

__all__ = [
    "ACTIONS", "DECISIONS", "SCHEMA", "TRANSCRIPT", "Decision", "LatencyMode", "LlmDecider", "LlmDecisionSource",
    "LlmError", "LlmParams", "Parsed", "ReplayMismatch", "build_prompt", "decision_source", "make_backend",
    "parse_answer",
]
