"""The prompt P(z(k)) has the paper's three parts and a strict-JSON state; the parser follows
Section 3.3 (JSON block, then keywords, else a failure)."""

import json
import math
import re

import pytest

from swarmnav.llm import ACTIONS, SCHEMA, build_prompt, parse_answer
from swarmnav.llm.prompt import STATE_FIELDS

Z = {"k": 51, "dt": 0.1, "S": 2, "path_count": 2, "w_max": 5.25, "w_min": 1.5, "avg_goal_distance": 31.123456,
     "near_goal_subswarms": 0, "d_swarm_min": 7.0, "can_split": False, "can_merge": True}


def test_prompt_has_the_three_parts_in_order_and_the_state():
    p = build_prompt(Z)
    role = p.index("swarm navigation high-level decision planner")
    rules = p.index("Decision rules:")
    out = p.index('{"decision": "split" | "merge" | "keep", "reason"')
    assert role < rules < out
    rule_text = p[rules:out]
    for field in ("can_split", "path_count", "avg_goal_distance", "can_merge", "near_goal_subswarms"):
        assert field in rule_text
    assert len(re.findall(r"^\d\. ", rule_text, re.M)) == 3
    state = json.loads(p.split("Current state: ", 1)[1])
    assert list(state) == list(STATE_FIELDS)  # the paper's field order
    assert state["avg_goal_distance"] == 31.123 and state["can_split"] is False


def test_non_finite_state_values_are_null_in_strict_json():
    p = build_prompt(dict(Z, S=1, d_swarm_min=math.inf, w_min=math.nan))
    state = json.loads(p.split("Current state: ", 1)[1])
    assert "Infinity" not in p and "NaN" not in p  # Python reads them, strict JSON parsers do not
    assert state["d_swarm_min"] is None and state["w_min"] is None


def test_schema_restricts_decision_to_the_action_set():
    assert SCHEMA["properties"]["decision"]["enum"] == list(ACTIONS)
    assert set(SCHEMA["required"]) == {"decision", "reason"}


@pytest.mark.parametrize("text, action, how", [
    ('{"decision": "split", "reason": "two corridors"}', "split", "json"),
    ('Sure! ```json\n{"decision": "MERGE", "reason": "close"}\n``` done', "merge", "json"),
    ('{"decision": "keep", "reason": "a {nested} brace"}', "keep", "json"),
    ('{"plan": {"decision": "split"}}', "split", "json"),  # the flat inner object
    ('{"decision": "merge", "reason": "sub-swarms are near the go', "merge", "field"),  # cut by max tokens
    ("decision: keep", "keep", "field"),
    ("I suggest splitting the swarm.", "split", "keyword"),
    ("Merge.", "merge", "keyword"),
])
def test_parser_accepts(text, action, how):
    p = parse_answer(text)
    assert (p.action, p.how) == (action, how)


@pytest.mark.parametrize("text, error", [
    ("", "empty"),
    ("   \n", "empty"),
    (None, "empty"),
    ("lorem ipsum {{ not json", "no JSON decision"),
    ('{"decision": "explore", "reason": "we could split"}', "not one of"),  # the reason is not searched
    ('{"decision": "split" | "merge" | "keep", "reason": "..."}', "ambiguous"),  # echoed template
    ("Do not split; keep the structure.", "ambiguous"),
])
def test_parser_rejects(text, error):
    p = parse_answer(text)
    assert p.action is None and error in p.error and p.how == ""


def test_messages_put_the_fixed_part_in_the_system_turn():
    from swarmnav.llm.check import SAMPLE_STATE
    from swarmnav.llm.prompt import SYSTEM, build_prompt, messages

    prompt = build_prompt(SAMPLE_STATE)
    system, user = messages(prompt)
    assert system == {"role": "system", "content": SYSTEM} and user["role"] == "user"
    assert SYSTEM + "\n\n" + user["content"] == prompt  # nothing lost or added
    assert "swarm navigation high-level decision planner" in SYSTEM and "Current state" not in SYSTEM
    # without a system turn (Gemma's GGUF), or for text not built by build_prompt: one user message
    assert messages(prompt, system=False) == [{"role": "user", "content": prompt}]
    assert messages("hello") == [{"role": "user", "content": "hello"}]
