"""``swarmnav llm bench`` scored by regret against the oracle's labels, and the labels themselves."""

import json

import numpy as np
import pytest

import swarmnav
from swarmnav.cli import main
from swarmnav.errors import ConfigError
from swarmnav.llm.bench import bench, load_states
from swarmnav.llm.config import LlmParams
from swarmnav.llm.labels import label_states, probe_run
from swarmnav.methods import registry
from swarmnav.methods.hes.oracle import OracleProbe


def replay_file(tmp_path, rows, answer):
    """A bench transcript answering ``answer(row)`` (raw text) to every state: what replay reads."""
    path = tmp_path / "answers.jsonl"
    path.write_text("".join(json.dumps({"step": i, "state": r["state"], "raw": answer(r), "latency_s": 0.0}) + "\n"
                            for i, r in enumerate(rows)))
    return str(path)


def choice_rows():
    """The shipped states with two or more feasible actions (where a regret can be above 0), and a few others."""
    rows = load_states()
    return [r for r in rows if len(r["feasible"]) > 1] + [r for r in rows if len(r["feasible"]) == 1][:10]


def test_shipped_states_are_labelled_by_the_oracle():
    rows = load_states()
    assert all("oracle" in r for r in rows)
    assert {r["build"] for r in rows} == {"swarmnav", "paper"}
    for r in rows:
        J = r["oracle"]["J"]
        assert sorted(J) == sorted(r["feasible"]), r["id"]
        assert J[r["oracle"]["choice"]] == max(J.values()), r["id"]
    # decisions matter somewhere: on some states the oracle's best beats the rule's action
    assert any(r["oracle"]["J"][r["oracle"]["choice"]] > r["oracle"]["J"][r["rule"]] for r in rows
               if r["rule"] in r["feasible"])


def test_an_answer_of_the_oracles_choice_agrees_and_loses_nothing(tmp_path):
    rows = choice_rows()
    sub = tmp_path / "states.jsonl"
    sub.write_text("".join(json.dumps(r) + "\n" for r in rows))
    t = replay_file(tmp_path, rows, lambda r: json.dumps({"decision": r["oracle"]["choice"], "reason": "oracle"}))
    s = bench(LlmParams(decision="replay", llm_replay=t), load_states(sub)).summary()
    assert s["agree_oracle"] == 1.0 and s["agree_oracle_choice"] == 1.0
    assert s["regret_mean_m"] == 0.0 and s["regret_max_m"] == 0.0
    # and the oracle's choice is not the rule's everywhere: agreement with the rule is below 1
    assert s["agree"] < 1.0


@pytest.mark.parametrize("answer", ["split", "merge", "keep", "nonsense"])
def test_regret_is_never_negative_and_is_the_objective_lost(tmp_path, answer):
    rows = choice_rows()
    sub = tmp_path / "states.jsonl"
    sub.write_text("".join(json.dumps(r) + "\n" for r in rows))
    t = replay_file(tmp_path, rows, lambda r: json.dumps({"decision": answer, "reason": "fixed"}))
    res = bench(LlmParams(decision="replay", llm_replay=t), load_states(sub))
    for rec, r in zip(res.records, rows, strict=True):
        assert rec["regret_m"] >= 0.0
        # what a run executes: the answer through Pi_feas, the rule's action when it does not parse
        done = (r["rule"] if answer == "nonsense" else answer)
        done = done if done in r["feasible"] else "keep"
        assert rec["executed"] == done
        assert rec["regret_m"] == r["oracle"]["J"][r["oracle"]["choice"]] - r["oracle"]["J"][done]
    s = res.summary()
    if answer == "nonsense":  # the fallback is the rule, so it loses what the rule loses
        rule = bench(LlmParams(decision="rule"), load_states(sub)).summary()
        assert s["invalid"] == 1.0 and s["regret_mean_m"] == rule["regret_mean_m"]


def test_the_bench_prints_and_writes_the_oracle_scores(tmp_path, capsys):
    out = tmp_path / "summary.csv"
    assert main(["llm", "bench", "--decision", "rule", "--choice", "--summary", str(out)]) == 0
    text = capsys.readouterr().out
    assert "against the oracle: agree" in text and "mean regret" in text
    lines = out.read_text().splitlines()
    head = lines[0].split(",")
    assert {"agree_oracle", "regret_mean_m", "scene", "build"} <= set(head)
    first = dict(zip(head, lines[1].split(","), strict=True))
    assert first["scene"] == "all" and float(first["regret_mean_m"]) >= 0.0
    js = tmp_path / "summary.json"
    assert main(["llm", "bench", "--decision", "rule", "--choice", "--summary", str(js)]) == 0
    data = json.loads(js.read_text())
    assert data[0]["regret_mean_m"] == pytest.approx(float(first["regret_mean_m"]))
    assert len(data) == len(lines) - 1


def labelled_row():
    return next(r for r in load_states() if len(r["feasible"]) > 1)


@pytest.mark.parametrize("mutate, fragment", [
    (lambda text: "{not json\n", "not JSON"),
    (lambda text: json.dumps({"state": {}, "rule": "keep"}) + "\n", "needs state, rule"),
    (lambda text: json.dumps({**json.loads(text), "oracle": {**json.loads(text)["oracle"], "J": {"keep": 1.0}}}) + "\n",
     "must give every feasible action"),
    (lambda text: json.dumps({**json.loads(text), "oracle": {**json.loads(text)["oracle"], "choice": "fly"}}) + "\n",
     "choice must be a feasible action"),
    (lambda text: text + json.dumps({k: v for k, v in json.loads(text).items() if k != "oracle"}) + "\n",
     "carry oracle labels"),
    (lambda text: "", "no decision states"),
])
def test_bad_state_files_are_one_line_exit_2(tmp_path, capsys, mutate, fragment):
    f = tmp_path / "states.jsonl"
    f.write_text(mutate(json.dumps(labelled_row()) + "\n"))
    assert main(["llm", "bench", "--decision", "rule", "--states", str(f)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and fragment in err[0], err


def test_a_missing_state_file_is_one_line_exit_2(tmp_path, capsys):
    assert main(["llm", "bench", "--decision", "rule", "--states", str(tmp_path / "none.jsonl")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "cannot read" in err[0]


# ------------------------------------------------------------------ labelling: the run re-created
STEPS = 130  # default_corridor, seed 1, default build: the rule splits at k = 98, merge is feasible after it


def test_a_probe_run_is_the_rule_run():
    hes = registry.make("hes")
    probe = OracleProbe(hes.rule_policy(), hes.params, lambda k, z, rule, feasible: len(feasible) > 1 and k % 10 == 0)
    probed = swarmnav.run(hes.use_source(probe), "default_corridor", seed=1, steps=STEPS)
    rule = swarmnav.run("hes", "default_corridor", seed=1, steps=STEPS)
    assert probe.points and all(len(p.feasible) > 1 for p in probe.points)
    np.testing.assert_array_equal(probed.positions, rule.positions)


def test_labels_are_recomputed_from_the_run_and_a_changed_state_is_refused(tmp_path):
    pick = lambda k, z, rule, feasible: k in (50, 98, 110)  # noqa: E731
    rows = probe_run("default_corridor", 1, steps=STEPS, params={}, select=pick)
    assert [r["k"] for r in rows] == [50, 98, 110] and rows[1]["rule"] == "split"
    bare = [{k: v for k, v in r.items() if k != "oracle"} for r in rows]
    src, out = tmp_path / "bare.jsonl", tmp_path / "labelled.jsonl"
    src.write_text("".join(json.dumps(r) + "\n" for r in bare))
    assert main(["llm", "label", "--states", str(src), "--out", str(out)]) == 0
    # the same run, the same lookahead: the same labels
    assert [json.loads(line) for line in out.read_text().splitlines()] == rows
    assert main(["llm", "label", "--states", str(src)]) == 2  # where to write is not optional
    bad = [dict(r) for r in bare]
    bad[1] = {**bad[1], "state": {**bad[1]["state"], "w_max": bad[1]["state"]["w_max"] + 1.0}}
    with pytest.raises(ConfigError, match="differs from the recorded one"):
        label_states(bad)
    with pytest.raises(ConfigError, match="cannot re-create its run"):
        label_states([{k: v for k, v in bare[0].items() if k != "seed"}])
