"""Property (HES eq. 22): whatever the model answers and whatever the state, the executed
action is in {split, merge, keep} and feasible, and the parser never raises."""

from hypothesis import given, settings
from hypothesis import strategies as st

from swarmnav.llm import ACTIONS, LlmDecider, LlmError, parse_answer
from swarmnav.llm.backends import Reply
from swarmnav.methods.hes.decision import DecisionState, project

finite = st.floats(min_value=0, max_value=1e4, allow_nan=False)
states = st.builds(
    DecisionState, k=st.integers(0, 10**6), dt=st.sampled_from([0.05, 0.1]), S=st.integers(1, 20),
    n_c=st.integers(0, 10), w_max=finite, w_min=finite | st.just(float("nan")), d_goal_avg=finite,
    n_near=st.integers(0, 20), d_swarm_min=finite | st.just(float("inf")), can_split=st.booleans(),
    can_merge=st.booleans(),
)
fragments = st.sampled_from(['{"decision": "split"}', '{"decision": "merge", "reason": "r"}', "keep", "Split",
                             "merging", '"decision": "', "{", "}", "|", "```json", "null", '{"decision": 3}'])
answers = st.one_of(
    st.text(max_size=200),
    st.lists(st.one_of(fragments, st.text(max_size=10)), max_size=8).map(" ".join),
    st.builds(lambda e: e, st.sampled_from([LlmError("timeout", "t"), LlmError("http", "500"),
                                            LlmError("connection", "reset"), ValueError("bug")])),
)


class One:
    name, model = "prop", "prop"

    def __init__(self, answer):
        self.answer = answer

    def complete(self, prompt, step):
        if isinstance(self.answer, Exception):
            raise self.answer
        return Reply(self.answer, 0.0)


@settings(max_examples=300, deadline=None)
@given(answer=answers, state=states, rule=st.sampled_from(ACTIONS), latency=st.sampled_from(["blocking", "fixed:0"]))
def test_executed_action_is_in_the_action_set_and_feasible(answer, state, rule, latency):
    d = LlmDecider(One(answer), interval=1, latency=latency)
    out = d.decide(state.to_dict(), 0, rule, "", lambda a: project(a, state))
    assert out.action in ACTIONS and out.executed in ACTIONS
    assert out.executed != "split" or state.can_split
    assert out.executed != "merge" or state.can_merge
    assert d.records[0]["executed"] == out.executed
    s = d.summary()
    assert s["llm_calls"] == 1
    # a fallback exactly when the answer is no action; an infeasible action is not a fallback
    parsed = None if isinstance(answer, Exception) else parse_answer(answer).action
    assert s["llm_fallback_used"] == (parsed is None)
    assert out.source == ("rule" if parsed is None else "llm")


@settings(max_examples=500, deadline=None)
@given(st.text(max_size=500))
def test_parser_total(text):
    p = parse_answer(text)
    assert p.action in ACTIONS or (p.action is None and p.error)
