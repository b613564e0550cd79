"""``swarmnav llm bench``: the shipped decision states and the scores of a back end on them."""

import json

import pytest

from swarmnav.cli import main
from swarmnav.llm.bench import bench, load_states
from swarmnav.llm.config import LlmParams
from swarmnav.llm.prompt import ACTIONS


def test_shipped_states_are_consistent():
    rows = load_states()
    assert len(rows) >= 200
    assert {r["scene"] for r in rows} == {"default_corridor", "narrow_alternating_gates", "dense_cross_blocks",
                                          "off_axis_goal"}
    for r in rows:
        z = r["state"]
        # the feasible set is what Pi_feas lets through: keep always, split / merge by I_split / I_merge
        assert r["feasible"] == [a for a in ACTIONS if a == "keep" or (a == "split" and z["can_split"])
                                 or (a == "merge" and z["can_merge"])], r["id"]
        assert r["rule"] in r["feasible"], r["id"]
    # not only keep: the rule split and merged on some of them
    assert {r["rule"] for r in rows} == set(ACTIONS)


def test_rule_scores_one_by_construction(capsys):
    assert main(["llm", "bench", "--decision", "rule"]) == 0
    out = capsys.readouterr().out
    n = len(load_states())
    assert f"rule (-) on {n} recorded states" in out
    assert "feasible (accuracy vs the feasible set) 1.000   agree with rule 1.000   invalid 0.000" in out


def test_a_rule_following_server_agrees_and_its_transcript_replays(fake_server, tmp_path, capsys):
    s = fake_server("rules")
    states = load_states()
    # the states the rule split or merged on, and as many keeps: every row of the table is exercised
    pick = [i for i, r in enumerate(states) if r["rule"] != "keep"]
    pick += [i for i, r in enumerate(states) if r["rule"] == "keep"][: len(pick)]
    sub = tmp_path / "states.jsonl"
    sub.write_text("".join(json.dumps(states[i]) + "\n" for i in pick))
    t = tmp_path / "t.jsonl"
    assert main(["llm", "bench", "--decision", "ollama", "--llm-url", s.url, "--llm-timeout", "5",
                 "--states", str(sub), "--transcript", str(t)]) == 0
    live = capsys.readouterr().out
    assert s.violations == [] and len(s.requests) == len(pick)
    # the fake follows the prompt's three rules, which are the rule policy's first two: it agrees
    # wherever the rule split or merged near the goal; rule 3 (merge when close, ours) it does not know
    res = bench(LlmParams(decision="replay", llm_replay=str(t)), load_states(sub))
    summ = res.summary()
    assert summ["valid"] == 1.0 and summ["feasible"] == 1.0
    conf = res.confusion()
    assert conf.get(("split", "split"), 0) == sum(states[i]["rule"] == "split" for i in pick)
    assert conf.get(("keep", "keep"), 0) == sum(states[i]["rule"] == "keep" for i in pick)
    assert main(["llm", "bench", "--decision", "replay", "--llm-replay", str(t), "--states", str(sub)]) == 0
    replayed = capsys.readouterr().out
    # the same answers, scored the same (latencies are the recorded ones)
    assert replayed.split("\n", 1)[1] == live.split("\n", 1)[1]


@pytest.mark.parametrize("fault, kind", [("garbage", "invalid"), ("http500", "call")])
def test_failed_answers_count_as_invalid_and_infeasible(fake_server, fault, kind):
    s = fake_server(fault)
    res = bench(LlmParams(decision="openai", llm_url=s.url + "/v1", llm_timeout=5), load_states()[:5])
    summ = res.summary()
    assert summ["invalid"] == 1.0 and summ["feasible"] == 0.0 and summ["agree"] == 0.0
    assert summ["call_failures"] == (5.0 if kind == "call" else 0.0)
    assert res.confusion().get(("keep", "invalid"), 0) == sum(r["rule"] == "keep" for r in load_states()[:5])
