"""The robustness report (``[one_at_a_time]`` + ``[report.robustness]``) on a small real store: APF and
Vasarhelyi, 6 robots, one forest scene, 2 seeds, message loss 0 and 1, 20 s. Its figure data, its CSV
and its "first below the threshold" table are checked against runs.csv by hand; the spec's
one-factor-at-a-time variants and its validation."""

import csv
import math

import numpy as np
import pytest

from swarmnav.cli import main
from swarmnav.errors import ConfigError
from swarmnav.experiments import Store
from swarmnav.experiments.report import build_tables
from swarmnav.experiments.robustness import series
from swarmnav.experiments.spec import from_dict

SCENE = "random_forest:density=0.2,seed={seed},length=6,r_min=1.0,r_max=2.0,min_passage=1.0"
SPEC = f"""name = "tiny-robust"
scenario = "{SCENE}"
horizon = 20.0
n = 6
seeds = "1-2"
[matrix]
method = ["apf", "vasarhelyi"]
[one_at_a_time]
"net.loss" = [0.0, 1.0]
[report]
metrics = ["Y", "R_goal", "osc_hf_speed"]
trajectory_metrics = ["osc_hf_speed"]
[report.robustness]
success = "Y"
threshold = 0.4
metrics = ["min_inter_robot_distance", "min_robot_obstacle_distance"]
title = "tiny robustness"
[report.robustness.groups]
"forest" = ["{SCENE}"]
"""
METHODS, LEVELS = ("apf", "vasarhelyi"), (0.0, 1.0)


@pytest.fixture(scope="module")
def tiny(tmp_path_factory):
    """Four variants, eight runs (~5 s of CPU), and their report."""
    d = tmp_path_factory.mktemp("robust")
    (d / "spec.toml").write_text(SPEC)
    assert main(["experiment", "--spec", str(d / "spec.toml"), "--out", str(d / "o"), "--quiet"]) == 0
    assert main(["report", str(d / "o"), "--no-viewers"]) == 0
    return d / "o"


def _by_cell(out, metric):
    """Per (method, level) the per-seed values of ``metric``, from runs.csv."""
    with open(out / "runs.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    cells = {}
    for r in rows:
        level = 0.0 if r["variant"].endswith("/baseline") else float(r["variant"].split("=")[-1])
        cells.setdefault((r["method"], level), []).append(float(r[metric]))
    return cells


def _first_below(means, threshold):
    for level in LEVELS:
        if means[level] < threshold:
            return level
    return None


def test_variants_are_the_baseline_and_each_level_of_one_factor():
    exp = from_dict({"method": "apf", "scenario": "default_corridor", "steps": 5,
                     "one_at_a_time": {"net.latency": [0.0, 0.1, 0.2], "net.loss": [0.0, 0.5]}}, "s", {}, "1")
    assert [v.name for v in exp.variants] == ["default/baseline", "default/net.latency=0.1", "default/net.latency=0.2",
                                              "default/net.loss=0.5"]
    # every factor is set in every variant: the others at their baseline, never crossed
    assert [(v.params["net.latency"], v.params["net.loss"]) for v in exp.variants] == [
        (0.0, 0.0), (0.1, 0.0), (0.2, 0.0), (0.0, 0.5)]
    assert [v.variables["varied"] for v in exp.variants] == ["", "net.latency", "net.latency", "net.loss"]


def test_adding_a_factor_keeps_every_other_variant_and_its_run_keys():
    from swarmnav.experiments.jobs import plan

    one = from_dict({"method": "apf", "scenario": "default_corridor", "steps": 5,
                     "one_at_a_time": {"net.latency": [0.0, 0.1]}}, "s", {}, "1")
    two = from_dict({"method": "apf", "scenario": "default_corridor", "steps": 5,
                     "one_at_a_time": {"net.latency": [0.0, 0.1], "net.loss": [0.0, 0.3]}}, "s", {}, "1")
    keys_one = {j.variant.name: j.key for j in plan(one)}
    keys_two = {j.variant.name: j.key for j in plan(two)}
    assert keys_one == {k: v for k, v in keys_two.items() if k in keys_one}
    assert set(keys_two) - set(keys_one) == {"default/net.loss=0.3"}
    # and the baseline is the run without a network at all
    plain = from_dict({"method": "apf", "scenario": "default_corridor", "steps": 5}, "s", {}, "1")
    assert plan(plain)[0].key == keys_one["default/baseline"]


def test_first_below_table_matches_runs_csv(tiny):
    cells = _by_cell(tiny, "Y")
    text = (tiny / "report.md").read_text()
    for m in METHODS:
        means = {lv: float(np.mean(cells[(m, lv)])) for lv in LEVELS}
        level = _first_below(means, 0.4)
        cell = "never" if level is None else f"{level:g} ({means[level]:.2f} of {len(cells[(m, level)])})"
        assert f"| forest | {m} | {cell} |" in text


def test_figure_points_match_runs_csv(tiny):
    rows = list(csv.DictReader(open(tiny / "report_files" / "robustness.csv", newline="")))
    assert (tiny / "report_files" / "robustness-net.loss-forest.png").stat().st_size > 10_000
    assert (tiny / "report_files" / "robustness-net.loss-forest.svg").is_file()
    for metric in ("Y", "min_inter_robot_distance", "min_robot_obstacle_distance"):
        cells = _by_cell(tiny, metric)
        for m in METHODS:
            for lv in LEVELS:
                got = [r for r in rows if r["metric"] == metric and r["curve"] == m and float(r["level"]) == lv]
                assert len(got) == 1
                assert float(got[0]["mean"]) == pytest.approx(np.mean(cells[(m, lv)]), rel=1e-12)
                assert int(got[0]["runs"]) == 2
    # what the curves show: with every message lost each robot flies as if alone, and comes closer to the others
    near = _by_cell(tiny, "min_inter_robot_distance")
    for m in METHODS:
        assert np.mean(near[(m, 1.0)]) < np.mean(near[(m, 0.0)])


def test_first_below_on_a_continuous_outcome_and_never(tiny):
    """The same store read with another outcome and threshold: a level for one method, "never" for
    the other, and a Student-t interval (not Wilson's) for values that are not 0/1."""
    store = Store(tiny)
    t = build_tables(store, "tiny-robust")
    cells = _by_cell(tiny, "min_inter_robot_distance")
    means = {m: {lv: float(np.mean(cells[(m, lv)])) for lv in LEVELS} for m in METHODS}
    lo, hi = sorted(means[m][1.0] for m in METHODS)
    threshold = 0.5 * (lo + hi)  # between the two methods at loss 1: one falls below it, one does not
    assert lo < threshold < hi and all(means[m][0.0] > threshold for m in METHODS)
    cfg = {"success": "min_inter_robot_distance", "threshold": threshold,
           "groups": {"forest": [SCENE]}}
    panels, firsts = series(t["variants"], cfg)
    for m in METHODS:
        expected = _first_below(means[m], threshold)
        got = firsts[("forest", m, "net.loss")]
        assert got.level == expected and got.complete
        assert got.text() == ("never" if expected is None else f"{expected:g} ({means[m][expected]:.2f} of 2)")
    (panel,) = panels
    assert not panel.binary["min_inter_robot_distance"]
    line = panel.curves["min_inter_robot_distance"][METHODS[0]]
    vals = cells[(METHODS[0], 0.0)]
    half = 12.706 * np.std(vals, ddof=1) / math.sqrt(2)  # t(0.975, 1 dof) x standard error
    assert line.high[0] - line.mean[0] == pytest.approx(half, rel=1e-3)


def test_trajectory_metric_is_computed_from_each_stored_trajectory(tiny):
    from swarmnav.methods import registry
    from swarmnav.metrics.oscillation import hf_speed

    t = build_tables(Store(tiny), "tiny-robust")
    rows = list(csv.DictReader(open(tiny / "runs.csv", newline="")))
    for v in t["variants"]:
        mine = sorted((r for r in rows if r["variant"] == v["name"]), key=lambda r: int(r["seed"]))
        dt = registry.make(v["method"]).dt
        expected = [hf_speed(np.load(tiny / r["trajectory"])["positions"], dt) for r in mine]
        assert len(expected) == 2 and all(x > 0 for x in expected)
        assert v["values"]["osc_hf_speed"] == pytest.approx(expected, rel=1e-12)
    assert "osc_hf_speed [m/s]" in (tiny / "report.md").read_text()


@pytest.mark.parametrize("means, runs, text", [
    ([0.9, 0.7, 0.2], [10, 10, 10], "0.1 (0.70 of 10)"),  # the first level below, not the lowest rate
    ([0.5, 0.9, 0.9], [10, 10, 10], "0 (0.50 of 10)"),  # below already at the baseline
    ([0.9, 0.8, 0.85], [10, 10, 10], "never"),  # 0.8 itself is not below 0.8
    ([0.9, 0.85, math.nan], [10, 10, 0], "not below up to 0.1"),  # the last level not flown yet
    ([math.nan, 0.5, math.nan], [0, 4, 0], "0.1 (0.50 of 4)"),  # a level without runs is skipped
    ([math.nan] * 3, [0, 0, 0], "not run"),
])
def test_first_below_reads_levels_in_order(means, runs, text):
    from swarmnav.experiments.lines import Line
    from swarmnav.experiments.robustness import first_below

    x = np.array([0.0, 0.1, 0.3])
    line = Line(x, np.array(means), np.array(means), np.array(means), np.array(runs), np.zeros(3, dtype=int))
    assert first_below(line, 0.8, [0.0, 0.1, 0.3]).text() == text


@pytest.mark.parametrize("table, match", [
    ({"net.loss": [0.0]}, "two or more levels"),
    ({"net.loss": [0.0, 0.0]}, "a level twice"),
    ({"method": ["apf", "sph"]}, "cannot be a factor"),
])
def test_bad_one_at_a_time_is_one_line(table, match):
    with pytest.raises(ConfigError, match=match):
        from_dict({"method": "apf", "scenario": "default_corridor", "steps": 5, "one_at_a_time": table}, "s", {}, "1")


@pytest.mark.parametrize("robust, match", [
    ({"success": "Y", "threshold": 1.5}, "threshold"),
    ({"success": "Y", "groups": {"g": ["no_such_scene"]}}, "no variant flies"),
    ({"success": "Y", "colour": "red"}, "unknown key"),
])
def test_bad_robustness_table_is_one_line(robust, match):
    with pytest.raises(ConfigError, match=match):
        from_dict({"method": "apf", "scenario": "default_corridor", "steps": 5,
                   "one_at_a_time": {"net.loss": [0.0, 0.5]}, "report": {"robustness": robust}}, "s", {}, "1")


def test_robustness_without_factors_is_refused():
    with pytest.raises(ConfigError, match="one factor at a time"):
        from_dict({"method": "apf", "scenario": "default_corridor", "steps": 5,
                   "report": {"robustness": {"success": "Y"}}}, "s", {}, "1")
