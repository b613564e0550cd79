"""The answer parser of HES Section 3.3: a JSON block first, then a keyword search.

Order of attempts on the raw model text:

1. ``json``: a JSON object found by regex (the outermost ``{...}``, else each flat ``{...}``)
   that has a ``decision`` field; the action is read from that field only.
2. ``field``: a ``"decision": "<word>"`` pair found by regex, for an object cut off by the
   token limit before it closed.
3. ``keyword``: the words split / merge / keep (and their inflections) in the whole text,
   accepted only when exactly one of the three actions is named.

Anything else is a parse failure, and the caller falls back to the rule action (Section 3.3:
"If the LLM back end fails (timeout, empty response, or parsing failure), the system falls back
to a_rule"). Naming two actions ("do not split, keep") is ambiguous, hence a failure too.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass

from swarmnav.llm.prompt import ACTIONS

#: Longest answer the parser looks at [characters]; the rest is ignored (bounded work on
#: arbitrary server output; 64 tokens are a few hundred characters).
MAX_CHARS = 4000

_OUTER = re.compile(r"\{.*\}", re.S)
_FLAT = re.compile(r"\{[^{}]*\}")
# a value followed by "|" is the echoed answer template, not a choice (possessive: no backtracking)
_FIELD = re.compile(r"[\"']?decision[\"']?\s*[:=]\s*[\"']?\s*([A-Za-z]++)[\"']?+(?!\s*\|)", re.I)
_WORD = re.compile(r"\b(split|merg|keep)\w*", re.I)
_REASON = re.compile(r"[\"']?reason[\"']?\s*:\s*\"([^\"]*)", re.I)


@dataclass(frozen=True, slots=True)
class Parsed:
    """A parsed answer: ``action`` in ACTIONS, or None with ``error`` saying why."""

    action: str | None
    reason: str = ""
    how: str = ""  # "json", "field" or "keyword"; "" on failure
    error: str = ""


def parse_answer(text: str | None) -> Parsed:
    """Parse a raw model answer into a structural action (see module docstring)."""
    if text is None or not text.strip():
        return Parsed(None, error="empty answer")
    text = text[:MAX_CHARS]
    obj = _json_object(text)
    if obj is not None:
        value = obj.get("decision")
        reason = obj.get("reason")
        reason = reason if isinstance(reason, str) else ""
        action = _one_action(value) if isinstance(value, str) else None
        if action is None:
            return Parsed(None, reason, error=f"JSON decision {value!r} is not one of {'/'.join(ACTIONS)}")
        return Parsed(action, reason, "json")
    m = _FIELD.search(text)
    if m:
        action = _one_action(m.group(1))
        if action is None:
            return Parsed(None, error=f"decision {m.group(1)!r} is not one of {'/'.join(ACTIONS)}")
        r = _REASON.search(text)
        return Parsed(action, r.group(1) if r else "", "field")
    action = _one_action(text)
    if action is not None:
        return Parsed(action, "", "keyword")
    named = sorted({_canonical(w) for w in _WORD.findall(text)})
    if named:
        return Parsed(None, error=f"ambiguous answer naming {', '.join(named)}")
    return Parsed(None, error="no JSON decision and no split/merge/keep keyword")


def _json_object(text: str) -> dict | None:
    """The first JSON object in ``text`` that has a ``decision`` key, else None."""
    candidates = []
    m = _OUTER.search(text)
    if m:
        candidates.append(m.group(0))
    candidates.extend(_FLAT.findall(text))
    for c in candidates:
        try:
            obj = json.loads(c)
        except (ValueError, RecursionError):
            continue
        if isinstance(obj, dict) and "decision" in obj:
            return obj
    return None


def _one_action(text: str) -> str | None:
    """The single action named in ``text`` (split/merge/keep or an inflection), else None."""
    named = {_canonical(w) for w in _WORD.findall(text)}
    return named.pop() if len(named) == 1 else None


def _canonical(stem: str) -> str:
    s = stem.lower()
    return "merge" if s == "merg" else s
