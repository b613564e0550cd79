"""decision=oracle (docs/oracle.md): deterministic, never differs from the rule without a gain,
its cost reported, and refused where it cannot fly copies of the run."""

from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest

import swarmnav
from swarmnav.errors import ConfigError

# off_axis_goal, seed 3: I_split holds from step 19 on, so a short run meets decision points
SCENE, SEED, K = "off_axis_goal", 3, 60
ORACLE = {"decision": "oracle", "oracle_horizon": 2.0}


@pytest.fixture(scope="module")
def oracle_run():
    return swarmnav.run("hes", SCENE, seed=SEED, steps=K, **ORACLE)


def test_the_oracle_is_deterministic_for_a_seed(oracle_run):
    again = swarmnav.run("hes", SCENE, seed=SEED, steps=K, **ORACLE)
    assert np.array_equal(again.positions, oracle_run.positions)
    assert np.array_equal(again.labels, oracle_run.labels)
    keys = [k for k in oracle_run.metrics if k.startswith("hes_oracle")]
    assert keys and all(again.metrics[k] == oracle_run.metrics[k] for k in keys)


def test_the_oracle_reports_its_decisions_and_cost(oracle_run):
    m, horizon = oracle_run.metrics, round(ORACLE["oracle_horizon"] / 0.1)
    d = m["hes_oracle_decisions"]
    assert d >= 1  # split is feasible here: split and keep were both flown
    assert m["hes_oracle_changed"] <= m["hes_oracle_spread"] <= d
    # two or three actions per decision point, each flown for the horizon or to the run's last step
    assert 2 * d <= m["hes_oracle_steps"] <= 3 * d * horizon
    assert m["hes_oracle_steps_per_decision"] == pytest.approx(m["hes_oracle_steps"] / d)
    assert m["hes_oracle_gap"] >= 0.0 and m["hes_oracle_gain"] >= 0.0
    t = oracle_run.timings
    assert t["oracle_s"] > 0.0 and t["oracle_ms_per_decision"] == pytest.approx(1e3 * t["oracle_s"] / d)


def test_without_a_gain_the_oracle_flies_the_rule_run():
    """A margin no gain can pass: every decision point is flown, and the run is the rule's, bit for bit
    (the copies flown at each step leave the run itself untouched)."""
    rule = swarmnav.run("hes", SCENE, seed=SEED, steps=K)
    tied = swarmnav.run("hes", SCENE, seed=SEED, steps=K, oracle_margin=1e9, **ORACLE)
    assert tied.metrics["hes_oracle_decisions"] >= 1 and tied.metrics["hes_oracle_changed"] == 0
    assert np.array_equal(tied.positions, rule.positions)
    assert np.array_equal(tied.labels, rule.labels)


def test_the_oracle_changes_a_decision_where_the_lookahead_shows_a_gain(oracle_run):
    """Measured: at step 19 the rule splits; a 2 s lookahead scores keeping the swarm whole higher
    (more mean progress to the goal), so the oracle keeps it, and no other point of this short
    run offers a choice."""
    rule = swarmnav.run("hes", SCENE, seed=SEED, steps=K)
    assert [(e["step"], e["action"]) for e in rule.events if e.get("action") == "split"] == [(19, "split")]
    m = oracle_run.metrics
    assert m["hes_oracle_decisions"] == 1 and m["hes_oracle_changed"] == 1 and m["hes_oracle_gain"] > 0.0
    assert m["hes_splits"] == 0 and not any(e.get("action") == "split" for e in oracle_run.events)
    assert np.array_equal(oracle_run.positions[:20], rule.positions[:20])  # the same run up to the decision
    assert not np.array_equal(oracle_run.labels, rule.labels)


@pytest.mark.parametrize("bad", [{"oracle_horizon": 0.0}, {"oracle_w_crash": -1.0}, {"oracle_margin": math.nan}])
def test_bad_oracle_parameters_are_config_errors(bad):
    with pytest.raises(ConfigError):
        swarmnav.run("hes", SCENE, seed=SEED, steps=2, decision="oracle", **bad)


@pytest.mark.parametrize("option", [{"net.latency": 0.2}, {"vehicle": "quadrotor"}])
def test_the_oracle_needs_the_ideal_network_and_the_point_vehicle(option):
    with pytest.raises(ConfigError, match="ideal network"):
        swarmnav.run("hes", SCENE, seed=SEED, steps=2, decision="oracle", **option)


def test_llm_check_refuses_the_oracle():
    out = subprocess.run([sys.executable, "-m", "swarmnav", "llm", "check", "--decision", "oracle"],
                         capture_output=True, text=True)
    assert out.returncode == 2 and "oracle" in out.stderr and "Traceback" not in out.stderr
