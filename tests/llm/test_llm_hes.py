"""HES with LLM decisions end to end (Section 3.3): against a loopback model server that
misbehaves in every way, every run completes, every fault falls back to the rule and is
counted, good answers are not; a transcript replays to the identical trajectory."""

import json

import numpy as np
import pytest

import swarmnav
from swarmnav.cli import main
from swarmnav.methods.hes import Hes, Proposal

STEPS = 300  # the rule policy splits within these steps on this scene and seed
SCENE, SEED = "default_corridor", 1
URL = {"ollama": "", "openai": "/v1"}
FAULTS = ["garbage", "empty", "http500", "drop", "late"]


@pytest.fixture(scope="module")
def rule_run():
    return swarmnav.run("hes", SCENE, seed=SEED, steps=STEPS)


def llm_run(server, kind, **kw):
    kw.setdefault("llm_timeout", 1.0)  # well above a loopback answer on a loaded 2-core machine
    return swarmnav.run("hes", SCENE, seed=SEED, steps=STEPS, decision=kind, llm_url=server.url + URL[kind], **kw)


def test_rule_run_has_structure_to_decide(rule_run):
    assert "split" in [e["action"] for e in rule_run.events]
    assert rule_run.metrics["llm_calls"] == 0


@pytest.mark.parametrize("kind", URL)
@pytest.mark.parametrize("fault", FAULTS)
def test_every_fault_falls_back_to_the_rule_and_is_counted(fake_server, rule_run, kind, fault):
    s = fake_server(fault, delay=3.0)
    r = llm_run(s, kind)
    calls = STEPS // 50  # k = 0, 50, ..., 250 (T_llm = 50)
    assert r.metrics["llm_calls"] == calls and r.metrics["llm_fallback_used"] == calls
    # the rule decided every step: the very trajectory of the rule run
    np.testing.assert_array_equal(r.positions, rule_run.positions)
    assert [{**e, "reason": ""} for e in r.events] == [{**e, "reason": ""} for e in rule_run.events]
    assert all(e["source"] == "rule" for e in r.events)
    recs = [json.loads(line) for line in r.artifacts["llm_transcript.jsonl"].splitlines()]
    assert [x["step"] for x in recs] == list(range(0, STEPS, 50))
    want = {"garbage": "parse", "empty": "empty", "http500": "http", "drop": "connection", "late": "timeout"}[fault]
    assert all(x["fallback"].startswith(want) for x in recs), recs[0]["fallback"]
    assert r.metrics["llm_latency_max_s"] < 2.0  # late answers (3 s) were cut at the 1 s timeout
    assert s.violations == []


@pytest.mark.parametrize("kind", URL)
def test_good_answers_are_not_fallbacks(fake_server, kind):
    s = fake_server("rules")
    r = llm_run(s, kind, llm_interval=1, llm_timeout=5)  # the model decides every step
    assert r.metrics["llm_calls"] == STEPS and r.metrics["llm_fallback_used"] == 0
    assert s.violations == []
    assert [(e["action"], e["source"]) for e in r.events][:1] == [("split", "llm")]


def test_infeasible_answers_are_projected_not_counted(fake_server):
    s = fake_server("answer", answer='{"decision": "merge", "reason": "always merge"}')
    r = llm_run(s, "ollama", llm_interval=10, llm_timeout=5)
    assert r.metrics["llm_fallback_used"] == 0
    assert r.metrics["llm_projected"] >= 1  # merge is infeasible with one sub-swarm
    recs = [json.loads(line) for line in r.artifacts["llm_transcript.jsonl"].splitlines()]
    for x in recs:
        assert x["executed"] == ("merge" if x["state"]["can_merge"] else "keep")
    assert r.metrics["hes_projected_to_keep"] >= r.metrics["llm_projected"]


class AlwaysSplit:
    """A non-LLM decision source that proposes split every step: its proposals reach Pi_feas
    only through Hes, the rule path."""

    def propose(self, z, step):
        return Proposal("split", "always split", "rule")


def test_llm_answers_are_projected_exactly_as_the_rule_path_projects(fake_server, tmp_path):
    # a model that answers split at every step (infeasible at most steps: one sub-swarm only
    # splits once, then max_subswarms and the cooldown forbid it), recorded and then replayed
    s = fake_server("answer", answer='{"decision": "split", "reason": "always split"}')
    live = llm_run(s, "ollama", llm_interval=1, llm_timeout=5)
    replayed = swarmnav.run("hes", SCENE, seed=SEED, steps=STEPS, decision="replay",
                            llm_replay=str(live.save(tmp_path / "a")), llm_interval=1)
    rule = swarmnav.run(Hes().use_source(AlwaysSplit()), SCENE, seed=SEED, steps=STEPS)
    n_keep = rule.metrics["hes_projected_to_keep"]
    assert 0 < n_keep < STEPS  # both feasible and infeasible proposals were made
    for r in (live, replayed):
        assert r.metrics["llm_fallback_used"] == 0
        np.testing.assert_array_equal(r.positions, rule.positions)
        assert [{**e, "reason": "", "source": ""} for e in r.events] == \
               [{**e, "reason": "", "source": ""} for e in rule.events]
        # the LLM layer's record of what it executed is the method's projection, step by step
        assert r.metrics["llm_projected"] == r.metrics["hes_projected_to_keep"] == n_keep
        recs = [json.loads(line) for line in r.artifacts["llm_transcript.jsonl"].splitlines()]
        splits = {e["step"] for e in rule.events if e["action"] == "split"}
        assert [x["executed"] for x in recs] == ["split" if x["step"] in splits else "keep" for x in recs]


def test_mixed_faults_count_only_the_faults(fake_server):
    script = ["rules", "garbage", "rules", "http500", "drop", "rules", "empty", "late", "rules", "rules"]
    s = fake_server("rules", script=script, delay=1.5)
    r = llm_run(s, "openai", llm_interval=30)
    assert r.metrics["llm_calls"] == 10 and r.metrics["llm_fallback_used"] == 5


@pytest.mark.parametrize("latency", ["blocking", "fixed:1.2"])
def test_transcript_replays_to_the_identical_run(fake_server, tmp_path, latency):
    s = fake_server("rules", script=["rules", "drop", "rules", "garbage"])
    a = llm_run(s, "ollama", llm_interval=1, llm_timeout=5, llm_latency=latency)
    assert a.metrics["llm_fallback_used"] == 2
    out = a.save(tmp_path / "a")
    b = swarmnav.run("hes", SCENE, seed=SEED, steps=STEPS, decision="replay", llm_replay=str(out),
                     llm_interval=1, llm_latency=latency)
    np.testing.assert_array_equal(a.positions, b.positions)
    np.testing.assert_array_equal(a.labels, b.labels)
    assert a.events == b.events
    assert {k: v for k, v in a.metrics.items() if k.startswith("llm_")} == \
           {k: v for k, v in b.metrics.items() if k.startswith("llm_")}
    if latency == "blocking":
        assert any(e["source"] == "llm" for e in a.events)  # the replayed run is the model's, not the rule's


def test_replay_of_another_run_is_refused(fake_server, tmp_path):
    s = fake_server("rules")
    out = llm_run(s, "ollama", llm_timeout=5).save(tmp_path / "a")
    with pytest.raises(swarmnav.SwarmnavError, match="diverged|no LLM call"):
        swarmnav.run("hes", SCENE, seed=SEED + 1, steps=STEPS, decision="replay", llm_replay=str(out))


@pytest.mark.parametrize("kind", URL)
@pytest.mark.parametrize("fault", ["garbage", "empty", "http500", "drop", "late"])
def test_cli_run_completes_against_each_fault(fake_server, tmp_path, capsys, kind, fault):
    s = fake_server(fault, delay=2.0)
    out = tmp_path / "r"
    assert main(["run", "--method", "hes", "--scenario", SCENE, "--steps", "150", "--out", str(out), "--quiet",
                 "--decision", kind, "--llm-url", s.url + URL[kind], "--llm-model", "qwen2.5:3b",
                 "--llm-timeout", "1"]) == 0
    m = json.loads((out / "metrics.json").read_text())
    assert m["llm_calls"] == 3 and m["llm_fallback_used"] == 3
    assert len((out / "llm_transcript.jsonl").read_text().splitlines()) == 3
    assert "LLM: 3 calls, 3 fallbacks" in capsys.readouterr().out


def test_hes_params_carry_every_llm_field_with_the_same_default():
    from dataclasses import fields

    from swarmnav.llm import LlmParams
    from swarmnav.methods.hes import HesParams

    hes = {f.name: f.default for f in fields(HesParams)}
    for f in fields(LlmParams):
        assert hes.get(f.name) == f.default, f.name
