"""``[report.lines]``: metrics against a sweep variable, one line per value of another (SPH Fig. 6),
checked against runs.csv by hand on a real tiny sweep (a matrix over n, a swept scenario
variable); the variables each variant records; the spec's validation."""

import csv
import math

import numpy as np
import pytest
from scipy import stats as sps

from swarmnav.cli import main
from swarmnav.errors import ConfigError
from swarmnav.experiments import Store
from swarmnav.experiments.lines import lines
from swarmnav.experiments.report import build_tables, line_series, variant_variables
from swarmnav.experiments.spec import from_dict

Z = sps.norm.ppf(0.975)
NS, DENSITIES, SEEDS = (2, 4), ("0.1", "0.2"), (1, 2)
METRICS = ["sph_success", "flight_time", "min_inter_robot_distance", "collisions"]
SPEC = """name = "tiny-lines"
method = "apf"
scenario = "random_forest:density={density},seed={seed},length=6,r_min=1.0,r_max=2.0,min_passage=1.0"
scenario_vars = { density = 0.3 }
horizon = 20.0
seeds = "1-2"
[params]
n_rays = 90
[matrix]
n = [2, 4]
[report]
metrics = ["sph_success", "flight_time"]
[report.lines]
x = "n"
series = "density"
metrics = ["sph_success", "flight_time", "min_inter_robot_distance", "collisions", "no_such_metric"]
title = "tiny lines"
"""


@pytest.fixture(scope="module")
def tiny(tmp_path_factory):
    """APF, n = 2 and 4 robots x density 0.1 and 0.2, seeds 1-2 (~5 s): four variants, eight runs."""
    d = tmp_path_factory.mktemp("lines")
    (d / "spec.toml").write_text(SPEC)
    assert main(["experiment", "--spec", str(d / "spec.toml"), "--set", "density=0.1|0.2", "--out", str(d / "o"),
                 "--quiet"]) == 0
    assert main(["report", str(d / "o"), "--no-viewers"]) == 0
    return d / "o"


def _runs(out):
    with open(out / "runs.csv", newline="") as f:
        return list(csv.DictReader(f))


def _wilson(k, n):
    p = k / n
    mid = (p + Z**2 / (2 * n)) / (1 + Z**2 / n)
    half = Z / (1 + Z**2 / n) * math.sqrt(p * (1 - p) / n + Z**2 / (4 * n**2))
    return mid - half, mid + half


def test_the_figure_is_a_png_in_both_reports_and_the_same_when_drawn_again(tiny):
    png = (tiny / "report_files" / "lines.png").read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    assert "![lines.png](report_files/lines.png)" in (tiny / "report.md").read_text()
    assert '<img alt="lines.png"' in (tiny / "report.html").read_text()
    assert "No finished run has `no_such_metric`" in (tiny / "report.md").read_text()
    assert main(["report", str(tiny), "--no-viewers"]) == 0
    assert (tiny / "report_files" / "lines.png").read_bytes() == png


def test_each_variant_records_its_matrix_and_sweep_values_in_the_store(tiny):
    meta = Store(tiny).meta("experiment:tiny-lines")
    got = {v["name"]: v["variables"] for v in meta["variants"]}
    assert got == {f"{n}[density={d}]": {"n": n, "density": d} for n in NS for d in DENSITIES}
    # a store written before variants recorded them: the same values from its columns and --set record
    for v in meta["variants"]:
        old = {k: x for k, x in v.items() if k != "variables"}
        assert {k: variant_variables(old, meta["overrides"])[k] for k in ("n", "density")} == v["variables"]


def test_the_plotted_points_are_the_means_and_intervals_computed_by_hand_from_runs_csv(tiny):
    runs = _runs(tiny)
    data = line_series(build_tables(Store(tiny), "tiny-lines"), {"x": "n", "series": "density", "metrics": METRICS})
    assert list(data) == METRICS
    for m in METRICS:
        assert list(data[m]) == [f"density = {d}" for d in DENSITIES]
        # a named 0/1 outcome is a rate with Wilson's interval; collisions (a count, 0 in every run
        # here) keeps the t interval although its values are 0 or 1
        binary = m == "sph_success"
        assert all(float(r[m]) in (0.0, 1.0) for r in runs) == (m in ("sph_success", "collisions"))
        for d in DENSITIES:
            line = data[m][f"density = {d}"]
            np.testing.assert_array_equal(line.x, NS)
            for i, n in enumerate(NS):
                vals = np.array([float(r[m]) for r in runs if r["variant"] == f"{n}[density={d}]"])
                assert len(vals) == len(SEEDS) and line.runs[i] == len(SEEDS) and line.dropped[i] == 0
                mean = vals.mean()
                if binary:
                    lo, hi = _wilson(int(vals.sum()), len(vals))
                elif np.all(vals == vals[0]):
                    lo = hi = vals[0]
                else:
                    half = sps.t.ppf(0.975, len(vals) - 1) * vals.std(ddof=1) / math.sqrt(len(vals))
                    lo, hi = mean - half, mean + half
                assert (line.mean[i], line.low[i], line.high[i]) == pytest.approx((mean, lo, hi), rel=1e-9, abs=1e-12)


def test_without_series_one_line_and_a_missing_metric_is_an_empty_line(tiny):
    t = build_tables(Store(tiny), "tiny-lines")
    data = line_series(t, {"x": "n", "metrics": ["flight_time", "no_such_metric"]})
    # density still differs between the variants: it splits the lines even when not named
    assert list(data["flight_time"]) == ["density = 0.1", "density = 0.2"]
    assert all(line.runs.sum() == 0 and np.all(np.isnan(line.mean)) for line in data["no_such_metric"].values())
    with pytest.raises(ConfigError, match=r"x must be a variable.*'steps'"):
        line_series(t, {"x": "steps", "metrics": ["flight_time"]})


def test_lines_order_series_numerically_split_by_other_swept_variables_and_refuse_one_point_twice():
    v = [(f"{n}[{d},{p}]", {"n": n, "density": d, "preset": p, "fixed": 1})
         for p in ("queue", "paper") for d in ("0.45", "0.15", "1.5") for n in (100, 15)]
    got = lines(v, "n", "density")
    assert [label for label, _ in got] == [f"density = {d}, preset = {p}" for d in ("0.15", "0.45", "1.5")
                                           for p in ("queue", "paper")]
    assert got[0][1] == [(15.0, "15[0.15,queue]"), (100.0, "100[0.15,queue]")]
    assert [label for label, _ in lines([(str(n), {"n": n}) for n in (3, 1)], "n", None)] == [""]
    with pytest.raises(ValueError, match="'a' and 'b' are the same point"):
        lines([("a", {"n": 15, "d": "0.1"}), ("b", {"n": 15, "d": "0.1"})], "n", "d")


BASE = {"name": "x", "method": "apf", "scenario": "random_forest:density={density},seed={seed}", "steps": 5,
        "scenario_vars": {"density": 0.2}, "matrix": {"n": [2, 4]}}


@pytest.mark.parametrize("table, fragment", [
    ({"x": "n", "metrics": ["a"], "colour": "red"}, "unknown key(s) ['colour']"),
    ({"x": "steps", "metrics": ["a"]}, "x must be a variable the variants differ by"),
    ({"metrics": ["a"]}, "x must be a variable the variants differ by"),
    ({"x": "n", "series": "k_att", "metrics": ["a"]}, "series must be a variable the variants differ by"),
    ({"x": "n", "series": "n", "metrics": ["a"]}, "series must differ from x"),
    ({"x": "n", "metrics": []}, "metrics must be a non-empty list"),
    ({"x": "n", "metrics": "flight_time"}, "metrics must be a non-empty list"),
    ({"x": "n", "metrics": ["a", "a"]}, "lists a metric twice"),
    ({"x": "n", "metrics": ["a"], "title": 3}, "title must be a string"),
    ({"x": "density", "series": "n", "metrics": ["a"]}, None),  # loads: density is a scenario variable
    (["n"], "must be a table"),
])
def test_a_bad_lines_table_is_one_line_at_load(table, fragment):
    if fragment is None:
        exp = from_dict({**BASE, "report": {"lines": table}}, "x.toml", {}, None)
        assert exp.report["lines"] == table
        return
    with pytest.raises(ConfigError) as e:
        from_dict({**BASE, "report": {"lines": table}}, "x.toml", {}, None)
    assert fragment in str(e.value) and "\n" not in str(e.value) and "[report.lines]" in str(e.value)


def test_x_must_take_numbers_and_a_swept_parameter_may_be_the_series():
    data = {**BASE, "matrix": {"method": ["apf", "vicsek"]}, "n": 3}
    with pytest.raises(ConfigError, match="x 'method' must take numbers"):
        from_dict({**data, "report": {"lines": {"x": "method", "metrics": ["a"]}}}, "x.toml", {}, None)
    exp = from_dict({**BASE, "report": {"lines": {"x": "n", "series": "k_att", "metrics": ["a"]}}}, "x.toml",
                    {"k_att": "1|2"}, None)
    assert [v.variables for v in exp.variants][:2] == [{"n": 2, "density": 0.2, "k_att": "1"},
                                                       {"n": 2, "density": 0.2, "k_att": "2"}]


def test_a_bad_lines_table_exits_2_with_one_line_before_anything_runs(tmp_path, capsys):
    spec = tmp_path / "bad.toml"
    spec.write_text(SPEC.replace('x = "n"', 'x = "steps"'))
    assert main(["experiment", "--spec", str(spec), "--out", str(tmp_path / "o"), "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "[report.lines] x must be a variable" in err
    assert not (tmp_path / "o" / "results.sqlite").exists()


def test_sph_scaling_draws_its_metrics_against_n_one_line_per_density():
    from swarmnav.experiments import load_experiment

    exp = load_experiment("sph-scaling", overrides={"density": "0.15|0.25|0.35|0.45"})
    assert len(exp.variants) == 16 and exp.report["lines"]["x"] == "n"
    assert {(v.variables["n"], v.variables["density"]) for v in exp.variants} == \
        {(n, d) for n in (15, 30, 60, 100) for d in ("0.15", "0.25", "0.35", "0.45")}


def test_a_stored_lines_table_that_does_not_fit_the_store_exits_2_from_report(tiny, tmp_path, capsys):
    import shutil

    d = tmp_path / "copy"
    shutil.copytree(tiny, d)
    store = Store(d)
    meta = store.meta("experiment:tiny-lines")
    meta["report"]["lines"] = {"x": "steps", "metrics": ["flight_time"]}  # as an edited or older record might say
    store.set_meta("experiment:tiny-lines", meta)
    capsys.readouterr()
    assert main(["report", str(d), "--no-viewers"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "[report.lines] x must be a variable" in err and "'steps'" in err


def test_variants_on_one_point_are_a_note_and_no_figure(tiny, tmp_path):
    import shutil

    d = tmp_path / "copy"
    shutil.copytree(tiny, d)
    store = Store(d)
    meta = store.meta("experiment:tiny-lines")
    for v in meta["variants"]:  # as `--set n=4` over the matrix would record them
        v["variables"]["n"] = 4
    store.set_meta("experiment:tiny-lines", meta)
    assert main(["report", str(d), "--no-viewers"]) == 0
    md = (d / "report.md").read_text()
    assert "Line figure (`[report.lines]`): not drawn, variants '2[density=0.1]' and '4[density=0.1]'" in md
    assert not (d / "report_files" / "lines.png").exists() and "lines.png" not in md
