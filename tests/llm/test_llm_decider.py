"""The decision layer on z(k): trigger eq. (20), HES's projection eq. (22) applied to the
model's answers, fallback counting, delayed latency modes, transcript, replay."""

import json
from dataclasses import replace

import pytest

from swarmnav.llm import LatencyMode, LlmDecider, LlmError
from swarmnav.llm.backends import ReplayBackend, ReplayMismatch
from swarmnav.methods.hes.decision import DecisionState, project

OPEN = DecisionState(k=0, dt=0.1, S=1, n_c=2, w_max=5.0, w_min=4.0, d_goal_avg=50.0, n_near=0,
                     d_swarm_min=float("inf"), can_split=True, can_merge=False)
SHUT = replace(OPEN, can_split=False, can_merge=False)
SPLIT = '{"decision": "split", "reason": "two corridors"}'


def decide(decider, z, k, rule, reason="rule says so"):
    """One step as HES's LLM source takes it: the dict of z(k) and Pi_feas bound to z(k)."""
    return decider.decide(z.to_dict(), k, rule, reason, lambda a: project(a, z))


def drive(decider, steps, state_at=lambda k: OPEN, rule="keep"):
    return [decide(decider, replace(state_at(k), k=k), k, rule) for k in range(steps)]


def test_calls_at_first_step_and_every_interval_and_rule_in_between(scripted):
    b = scripted([SPLIT])
    d = LlmDecider(b, interval=5)
    out = drive(d, 12)
    assert [s for s, _ in b.asked] == [0, 5, 10]
    assert [o.source for o in out] == ["llm" if k in (0, 5, 10) else "rule" for k in range(12)]
    assert all(o.action == "split" for k, o in enumerate(out) if k % 5 == 0)
    assert all(o.action == "keep" for k, o in enumerate(out) if k % 5)
    assert d.summary()["llm_calls"] == 3 and d.summary()["llm_fallback_used"] == 0


def test_infeasible_answer_is_projected_to_keep_not_a_fallback(scripted):
    d = LlmDecider(scripted([SPLIT]), interval=50)
    out = decide(d, SHUT, 0, "keep")
    assert (out.action, out.executed, out.source) == ("split", "keep", "llm") and "infeasible" in out.reason
    s = d.summary()
    assert s["llm_fallback_used"] == 0 and s["llm_projected"] == 1
    rec = d.records[0]
    assert rec["parsed"] == "split" and rec["executed"] == "keep" and rec["fallback"] is None


@pytest.mark.parametrize("answer, kind", [
    (LlmError("timeout", "too slow"), "timeout"),
    (LlmError("connection", "refused"), "connection"),
    (LlmError("http", "HTTP 500"), "http"),
    ("", "parse"),
    ("no idea", "parse"),
    (RuntimeError("model exploded"), "error"),  # anything a back end raises
])
def test_every_failure_falls_back_to_the_rule_and_is_counted(scripted, answer, kind):
    d = LlmDecider(scripted([answer]), interval=3)
    out = drive(d, 7, rule="split")
    assert all(o.action == o.executed == "split" and o.source == "rule" for o in out)
    assert d.summary()["llm_calls"] == 3 and d.summary()["llm_fallback_used"] == 3
    assert all(r["fallback"].startswith(kind) and r["executed"] == "split" for r in d.records)


def test_fallback_rule_action_is_projected_too(scripted):
    d = LlmDecider(scripted([""]))
    out = decide(d, SHUT, 0, "split")
    assert (out.action, out.executed) == ("split", "keep")


def test_fixed_latency_applies_later_against_the_state_then(scripted):
    b = scripted([SPLIT])
    d = LlmDecider(b, interval=3, latency="fixed:0.35")  # ceil(0.35 / 0.1) = 4 steps > interval
    state_at = lambda k: SHUT if k == 14 else OPEN  # noqa: E731
    out = drive(d, 16, state_at, rule="keep")
    # a call is due 3 steps after the last, but none is made while an answer is pending
    assert [s for s, _ in b.asked] == [0, 5, 10, 15]
    assert [k for k, o in enumerate(out) if o.source == "llm"] == [4, 9, 14]
    assert out[4].executed == "split" and out[14].executed == "keep"  # feasibility at the apply step
    assert [(r["step"], r["apply_step"], r["executed"]) for r in d.records] == [
        (0, 4, "split"), (5, 9, "split"), (10, 14, "keep"), (15, None, None)]


def test_real_latency_uses_the_measured_time(scripted):
    d = LlmDecider(scripted([SPLIT], latency=0.21), interval=50, latency="real")
    out = drive(d, 5)
    assert [o.source for o in out] == ["rule", "rule", "rule", "llm", "rule"]


def test_latency_mode_parsing():
    assert LatencyMode.parse("fixed:2").delay_steps(99.0, 0.1) == 20
    assert LatencyMode.parse("blocking").delay_steps(99.0, 0.1) == 0
    assert LatencyMode.parse("real").delay_steps(0.3, 0.1) == 3  # not 4 from 0.3 / 0.1 = 3.0000000000000004
    with pytest.raises(Exception, match="llm_latency"):
        LatencyMode.parse("fixed:-1")


def test_transcript_records_every_call_and_replay_reproduces_it(scripted, tmp_path):
    answers = [SPLIT, "", LlmError("timeout", "slow"), '{"decision": "merge", "reason": "x"}', "Keep it."]
    d = LlmDecider(scripted(answers, latency=0.5), interval=4, latency="real")
    states = lambda k: replace(OPEN, can_merge=k > 10)  # noqa: E731
    first = drive(d, 20, states)
    lines = d.transcript().splitlines()
    assert len(lines) == len(d.records) == d.summary()["llm_calls"]
    rec = json.loads(lines[0])
    for key in ("step", "state", "prompt", "raw", "parsed", "executed", "latency_s", "fallback"):
        assert key in rec
    assert rec["state"]["d_swarm_min"] is None  # strict JSON
    (tmp_path / "llm_transcript.jsonl").write_text(d.transcript())
    r = LlmDecider(ReplayBackend(str(tmp_path)), interval=4, latency="real")
    again = drive(r, 20, states)
    assert again == first
    assert r.summary() == d.summary()
    # a different run does not silently replay
    r2 = LlmDecider(ReplayBackend(str(tmp_path)), interval=3)
    with pytest.raises(ReplayMismatch, match="no LLM call at step 3"):
        drive(r2, 6, states)
    r3 = LlmDecider(ReplayBackend(str(tmp_path)), interval=4, latency="real")
    with pytest.raises(ReplayMismatch, match="avg_goal_distance"):
        drive(r3, 1, lambda k: replace(OPEN, d_goal_avg=49.0))


def test_a_failing_back_end_warns_once_and_a_bad_answer_does_not_warn(scripted):
    lines = []
    d = LlmDecider(scripted([LlmError("connection", "cannot connect to http://x"), SPLIT,
                             LlmError("timeout", "no answer")]), interval=5, warn=lines.append)
    drive(d, 15)
    assert d.summary()["llm_fallback_used"] == 2  # every failed call falls back; one line says so
    assert lines == ["swarmnav: warning: the LLM back end (scripted) failed at step 0: connection: cannot connect "
                     "to http://x; the rule decides wherever a call fails (this run's count: llm_fallback_used in "
                     "its metrics)"]
    quiet = []
    d = LlmDecider(scripted(["lorem ipsum", ""]), interval=5, warn=quiet.append)
    drive(d, 10)  # the model answered, unusably: counted as fallbacks, but the back end works
    assert d.summary()["llm_fallback_used"] == 2 and quiet == []
