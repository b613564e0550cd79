"""The prompt P(z(k)) of HES Section 3.3, its output schema and the decoding settings.

This module is the one place where the text sent to the model is written. The prompt has the
paper's fixed three-part structure:

1. a role preamble naming the model a "swarm navigation high-level decision planner";
2. three explicit decision rules over ``can_split``, ``path_count``, ``avg_goal_distance``,
   ``can_merge`` and ``near_goal_subswarms``;
3. a strict output constraint: one JSON object ``{"decision": ..., "reason": ...}``;

followed by the state vector z(k) of eq. (18) as JSON. The three fixed parts are the system
message (:data:`SYSTEM`), the state is the user message (:func:`messages`): the chat models
(Ollama's, OpenAI-compatible servers, SmolLM2's own template in llama.cpp) are trained to
take instructions as a system turn, and a fixed system prefix lets llama.cpp reuse its
evaluated tokens from one call to the next. A model without a chat template that keeps a
system turn (Gemma 3 270M's GGUF has none) gets the same text as one user message.
"""

from __future__ import annotations

import json
import math
from typing import Any, Mapping

#: The structural action set A_str of HES Section 3.1.
ACTIONS = ("split", "merge", "keep")

#: Fields of z(k), eq. (18), in the paper's order (the keys of ``DecisionState.to_dict()``).
STATE_FIELDS = (
    "k", "dt", "S", "path_count", "w_max", "w_min", "avg_goal_distance",
    "near_goal_subswarms", "d_swarm_min", "can_split", "can_merge",
)

#: Decoding settings, HES Section 3.3: greedy decoding and at most 64 output tokens.
TEMPERATURE = 0.0
MAX_TOKENS = 64

#: JSON schema of the answer, passed to the back ends that constrain decoding with it
#: (Ollama ``format``, llama.cpp ``response_format.schema``). ``maxLength`` keeps the reason
#: short enough that the object closes within MAX_TOKENS (our choice: 64 tokens hold the
#: 25-token JSON frame plus about 120 characters of reason).
SCHEMA: dict[str, Any] = {
    "type": "object",
    "properties": {
        "decision": {"type": "string", "enum": list(ACTIONS)},
        "reason": {"type": "string", "maxLength": 120},
    },
    "required": ["decision", "reason"],
}

ROLE = (
    "You are a swarm navigation high-level decision planner. A swarm of UAVs flies through a "
    "cluttered corridor to a goal. It is organised in sub-swarms, each following a subleader. "
    "Every few seconds you choose one structural action for the whole swarm: \"split\" (divide "
    "into more sub-swarms that take different passable corridors), \"merge\" (join sub-swarms "
    "again) or \"keep\" (keep the current structure)."
)

FIELDS = (
    "State fields: k = step, dt = step length [s], S = number of sub-swarms, path_count = "
    "number of passable corridors towards the goal, w_max / w_min = widest / narrowest corridor "
    "width [m], avg_goal_distance = mean sub-swarm distance to the goal [m], "
    "near_goal_subswarms = sub-swarms close to the goal, d_swarm_min = smallest distance "
    "between two sub-swarms [m] (null with one sub-swarm), can_split / can_merge = whether a "
    "split / merge is feasible now."
)

RULES = (
    "Decision rules:\n"
    "1. If can_split is true, path_count >= 2 and avg_goal_distance is still large, choose "
    "\"split\" so the sub-swarms use the separate corridors.\n"
    "2. If can_merge is true and near_goal_subswarms >= 2 (sub-swarms meet near the goal), "
    "choose \"merge\".\n"
    "3. Otherwise choose \"keep\". Never choose split when can_split is false, nor merge when "
    "can_merge is false."
)

OUTPUT = (
    "Output: answer with exactly one JSON object and nothing else, in the form "
    "{\"decision\": \"split\" | \"merge\" | \"keep\", \"reason\": \"<one short sentence>\"}."
)


def state_json(state: Mapping[str, Any]) -> str:
    """The fields of z(k) (STATE_FIELDS, in the paper's order) as JSON; other keys of
    ``state`` are left out. Non-finite numbers become null (e.g. d_swarm_min with one
    sub-swarm) and floats are rounded to 3 decimals."""
    return json.dumps({k: jsonable(state[k]) for k in STATE_FIELDS if k in state}, separators=(", ", ": "))


#: The fixed part of P(z(k)): role preamble, field glossary, three rules, output constraint.
SYSTEM = "\n\n".join((ROLE, FIELDS, RULES, OUTPUT))
STATE_PREFIX = "Current state: "


def build_prompt(state: Mapping[str, Any]) -> str:
    """P(z(k)): :data:`SYSTEM`, then z(k) (the whole text, as the transcript records it)."""
    return SYSTEM + "\n\n" + STATE_PREFIX + state_json(state)


def messages(prompt: str, system: bool = True) -> list[dict[str, str]]:
    """The chat messages of ``prompt``: :data:`SYSTEM` as the system message and the rest as
    the user message when ``system`` and the prompt starts with SYSTEM; else one user message."""
    head = SYSTEM + "\n\n"
    if system and prompt.startswith(head):
        return [{"role": "system", "content": SYSTEM}, {"role": "user", "content": prompt[len(head):]}]
    return [{"role": "user", "content": prompt}]


def jsonable(v: Any, digits: int | None = 3) -> Any:
    """A state value as strict JSON: bools stay bools, non-finite floats become None, other
    floats are rounded to ``digits`` decimals (None: kept exact, for the transcript)."""
    if isinstance(v, bool) or v is None or isinstance(v, str):
        return v
    if hasattr(v, "item"):  # numpy scalar
        v = v.item()
    if isinstance(v, int):
        return v
    f = float(v)
    if not math.isfinite(f):
        return None
    return f if digits is None else round(f, digits)

