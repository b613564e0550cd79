"""``[report.differences]``: the report's table of B − A with 95 % intervals (issue 35), checked
against runs.csv by hand on a real tiny sweep; pairs the store lacks; the spec's validation."""

import csv
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import stats as sps

from swarmnav.cli import main
from swarmnav.errors import ConfigError
from swarmnav.experiments import Store, load_experiment
from swarmnav.experiments.differences import TITLE
from swarmnav.experiments.report import paired_differences, write_report
from swarmnav.experiments.spec import from_dict

Z = sps.norm.ppf(0.975)
PAIRS = [("base", "k5"), ("base", "d0"), ("k5", "damp")]
SPEC = """name = "tiny-diff"
method = "apf"
scenario = "random_forest:density=0.2,seed={seed},length=6,r_min=1.0,r_max=2.0,min_passage=1.0"
n = 4
horizon = 30.0
seeds = "1-6"
[params]
n_rays = 90
[[variants]]
name = "base"
[[variants]]
name = "k5"
params = { k_att = 5.0 }
[[variants]]
name = "d0"
params = { d0 = 1.5 }
[[variants]]
name = "damp"
params = { k_damp = 0.5 }
[report]
metrics = ["sph_success", "flight_distance", "flight_time"]
[report.differences]
success = "sph_success"
metrics = ["flight_distance", "flight_time"]
pairs = [["base", "k5"], ["base", "d0"], ["k5", "damp"]]
"""


@pytest.fixture(scope="module")
def tiny(tmp_path_factory):
    """APF, 4 robots, four variants, seeds 1-6 on small forests (~3 s): outcomes that differ by seed."""
    d = tmp_path_factory.mktemp("diff")
    (d / "spec.toml").write_text(SPEC)
    assert main(["experiment", "--spec", str(d / "spec.toml"), "--out", str(d / "o"), "--quiet"]) == 0
    assert main(["report", str(d / "o"), "--no-viewers"]) == 0
    return d / "o"


def _wilson(k, n):
    p = k / n
    mid = (p + Z**2 / (2 * n)) / (1 + Z**2 / n)
    half = Z / (1 + Z**2 / n) * math.sqrt(p * (1 - p) / n + Z**2 / (4 * n**2))
    return mid - half, mid + half


def _by_hand(runs, a, b):
    """Per pair from runs.csv: rates, Δ success with Newcombe's paired interval (all in points),
    and per metric the mean difference with the t interval over the seeds both succeeded."""
    seeds = sorted(s for (v, s) in runs if v == a and (b, s) in runs)
    sa = [float(runs[a, s]["sph_success"]) for s in seeds]
    sb = [float(runs[b, s]["sph_success"]) for s in seeds]
    n = len(seeds)
    e = sum(x == 1 and y == 1 for x, y in zip(sa, sb))
    f = sum(x == 1 and y == 0 for x, y in zip(sa, sb))
    g = sum(x == 0 and y == 1 for x, y in zip(sa, sb))
    h = n - e - f - g
    pa, pb = (e + f) / n, (e + g) / n
    (la, ua), (lb, ub) = _wilson(e + f, n), _wilson(e + g, n)
    den = (e + f) * (g + h) * (e + g) * (f + h)
    num = e * h - f * g
    num = max(num - (e + f + g + h) / 2, 0.0) if num > 0 else num  # the continuity-corrected phi
    r = num / math.sqrt(den) if den else 0.0
    lo = pb - pa - math.sqrt(max((pb - lb) ** 2 - 2 * r * (pb - lb) * (ua - pa) + (ua - pa) ** 2, 0))
    hi = pb - pa + math.sqrt(max((ub - pb) ** 2 - 2 * r * (ub - pb) * (pa - la) + (pa - la) ** 2, 0))
    out = {"seeds": n, "table": (e, f, g, h), "rate_a": 100 * pa, "rate_b": 100 * pb,
           "success": (100 * (pb - pa), 100 * lo, 100 * hi)}
    won = [s for s, x, y in zip(seeds, sa, sb) if x == 1 and y == 1]
    for m in ("flight_distance", "flight_time"):
        d = np.array([float(runs[b, s][m]) - float(runs[a, s][m]) for s in won])
        if len(d) >= 2:
            half = sps.t.ppf(0.975, len(d) - 1) * d.std(ddof=1) / math.sqrt(len(d))
            out[m] = (d.mean(), d.mean() - half, d.mean() + half, len(d))
        else:
            out[m] = (d.mean() if len(d) else math.nan, math.nan, math.nan, len(d))
    return out


def _csv(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def _numbers(cell):
    """``+1.23 [-0.45, +2.91]`` -> [1.23, -0.45, 2.91]; ``–`` -> nan."""
    parts = cell.replace("[", " ").replace("]", " ").replace(",", " ").split()
    return [math.nan if p == "–" else float(p) for p in parts]


def _md_rows(md):
    block = md.split(f"## {TITLE}\n", 1)[1].split("\n## ", 1)[0].split("\n![", 1)[0]
    lines = [ln for ln in block.splitlines() if ln.startswith("| ")]
    header = [c.strip() for c in lines[0].strip("|").split("|")]
    return header, [[c.strip() for c in ln.strip("|").split("|")] for ln in lines[1:]]


def test_the_table_gives_the_differences_computed_by_hand_from_runs_csv(tiny):
    runs = {(r["variant"], int(r["seed"])): r for r in _csv(tiny / "runs.csv")}
    want = {p: _by_hand(runs, *p) for p in PAIRS}
    # the fixture means something: some pair disagrees on a seed, some pair has an interval of distances
    assert any(w["table"][1] + w["table"][2] > 0 for w in want.values())
    assert any(w["flight_distance"][3] >= 2 for w in want.values())
    header, rows = _md_rows((tiny / "report.md").read_text())
    assert header == ["A", "B", "seeds paired", "success A [%]", "success B [%]", "Δ success [points]",
                      "both succeeded", "Δ flight_distance [m]", "Δ flight_time [s]", "note"]
    assert [(r[0], r[1]) for r in rows] == PAIRS
    for row in rows:
        w = want[row[0], row[1]]
        assert int(row[2]) == w["seeds"] == 6 and int(row[6]) == w["table"][0]
        assert float(row[3]) == pytest.approx(w["rate_a"], abs=0.051)
        assert float(row[4]) == pytest.approx(w["rate_b"], abs=0.051)
        assert _numbers(row[5]) == pytest.approx(list(w["success"]), abs=0.051)  # one decimal shown
        for cell, m in zip(row[7:9], ("flight_distance", "flight_time")):
            mean, lo, hi, n = w[m]
            if n == 0:
                assert cell == "–"
            elif n == 1:
                assert cell.endswith("[–]") and _numbers(cell)[0] == pytest.approx(mean, rel=5e-3, abs=5e-3)
            else:  # three significant digits of the largest of the three
                assert _numbers(cell) == pytest.approx([mean, lo, hi], rel=5e-3, abs=5e-3 * max(map(abs, (lo, hi))))
    # every number at full precision in differences.csv
    got = _csv(tiny / "report_files" / "differences.csv")
    assert [(r["a"], r["b"]) for r in got] == PAIRS
    for r in got:
        w = want[r["a"], r["b"]]
        assert tuple(int(r[k]) for k in ("both_succeeded", "only_a_succeeded", "only_b_succeeded",
                                         "neither_succeeded")) == w["table"]
        assert [float(r[k]) for k in ("d_success_points", "d_success_low", "d_success_high")] == pytest.approx(
            list(w["success"]), abs=1e-9)
        for m in ("flight_distance", "flight_time"):
            mean, lo, hi, n = w[m]
            assert int(r[f"{m}_n"]) == n
            cells = [r[f"d_{m}_{k}"] for k in ("mean", "low", "high")]
            assert [math.nan if c == "" else float(c) for c in cells] == pytest.approx([mean, lo, hi], rel=1e-9,
                                                                                       nan_ok=True)
    html = (tiny / "report.html").read_text()
    assert f"<h2>{TITLE}</h2>" in html
    # the Python function gives the same
    diffs = paired_differences(tiny, PAIRS, "sph_success", ["flight_distance"])
    assert [d.table for d in diffs] == [want[p]["table"] for p in PAIRS]


def test_a_swept_pair_is_compared_at_each_value_and_a_missing_one_is_a_row_with_a_note(tmp_path, capsys):
    """A --set sweep renames every variant (base[k_sep=3], ...): the spec's pair is compared at
    each swept value; a pair the store does not have is a row that says so."""
    spec = tmp_path / "s.toml"
    spec.write_text('name = "s"\nmethod = "apf"\nscenario = "default_corridor"\nn = 3\nsteps = 5\nseeds = "1"\n'
                    '[[variants]]\nname = "base"\n[[variants]]\nname = "strong"\nparams = { k_att = 3.0 }\n'
                    '[report.differences]\nsuccess = "sph_success"\nmetrics = ["flight_distance"]\n'
                    'pairs = [["base", "strong"]]\n')
    out = tmp_path / "o"
    assert main(["experiment", "--spec", str(spec), "--set", "k_sep=3|2", "--out", str(out), "--quiet"]) == 0
    assert main(["report", str(out), "--no-viewers"]) == 0
    _, rows = _md_rows((out / "report.md").read_text())
    assert [r[:3] for r in rows] == [["base[k_sep=3]", "strong[k_sep=3]", "1"], ["base[k_sep=2]", "strong[k_sep=2]", "1"]]
    assert all(r[-1] == "–" for r in rows)
    d, gone = paired_differences(out, [("base[k_sep=3]", "strong[k_sep=3]"), ("base", "weak")], "sph_success",
                                 ["flight_distance"])
    assert len(d.seeds) == 1 and d.note == ""
    assert gone.seeds == () and gone.note == "no paired seeds: base and weak not in this store"
    meta = Store(out).meta("experiment:s")  # a spec pair neither as named nor swept: a row with a note
    meta["report"]["differences"]["pairs"] = [["base", "weak"]]
    Store(out).set_meta("experiment:s", meta)
    write_report(out)
    _, rows = _md_rows((out / "report.md").read_text())
    assert rows == [["base", "weak", "0", "–", "–", "–", "–", "–", "no paired seeds: base and weak not in this store"]]
    (r,) = _csv(out / "report_files" / "differences.csv")
    assert r["seeds_paired"] == "0" and r["d_success_points"] == "" and "not in this store" in r["note"]


def _synthetic_store(d):
    """Variants A, B, C over seeds 1-4: B's seed 4 failed; C's success is 0.5 on seed 2 (not 0/1);
    A and B both succeed on seeds 1-3 but B's distance on seed 3 is missing."""
    s = {"A": [1.0, 1.0, 1.0, 0.0], "B": [1.0, 1.0, 1.0, 1.0], "C": [1.0, 0.5, 0.0, 0.0]}
    x = {"A": [10.0, 12.0, 11.0, 5.0], "B": [11.0, 14.0, None, 6.0], "C": [9.0, 9.0, 9.0, 9.0]}
    store, rows, jobs = Store(d), [], []
    for name in "ABC":
        for k in range(1, 5):
            key = f"{name}{k}"
            jobs.append([key, name, k])
            metrics = {"ok": s[name][k - 1]} | ({"dist": x[name][k - 1]} if x[name][k - 1] is not None else {})
            rows.append({"key": key, "experiment": "syn", "variant": name, "scenario": "default_corridor",
                         "method": "apf", "seed": k, "n": 3, "steps": 10, "params": {}, "config": {},
                         "status": "failed" if key == "B4" else "done", "error": "", "version": "test",
                         "trajectory": "", "metrics": metrics, "wall_time_s": 0.0})
    store.put_many(rows)
    store.set_meta("experiment:syn", {
        "name": "syn", "description": "", "seeds": [1, 2, 3, 4],
        "variants": [{"name": n, "columns": {"variant": n}} for n in "ABC"], "keys": [j[0] for j in jobs],
        "jobs": jobs, "report": {"metrics": ["ok", "dist"], "differences": {
            "success": "ok", "metrics": ["dist"], "pairs": [["A", "B"], ["A", "C"], ["A", "Z"]]}}})
    store.set_meta("last_experiment", "syn")


def test_unpaired_seeds_missing_values_and_a_non_binary_success_are_said(tmp_path):
    _synthetic_store(tmp_path)
    ab, ac, az = paired_differences(tmp_path, [("A", "B"), ("A", "C"), ("A", "Z")], "ok", ["dist"])
    assert ab.seeds == (1, 2, 3) and ab.table == (3, 0, 0, 0) and ab.success.estimate == 0.0
    assert ab.metrics["dist"].n == 2 and ab.metrics["dist"].estimate == pytest.approx(1.5)  # seeds 1-2: +1, +2
    assert "seeds only A finished: 4" in ab.note and "dist: 1 both-succeeded seeds without a finite value" in ab.note
    assert "ok is not a 0/1 metric (C, seed 2: 0.5)" in ac.note and math.isnan(ac.success.estimate)
    assert az.seeds == () and az.note == "no paired seeds: Z not in this store"
    md, _ = write_report(tmp_path)
    _, rows = _md_rows(md.read_text())
    assert [r[:3] for r in rows] == [["A", "B", "3"], ["A", "C", "4"], ["A", "Z", "0"]]
    assert rows[1][3:8] == ["–"] * 5  # no rates, no differences from a success that is not 0/1
    assert rows[0][5] == "0.0 [-56.1, +56.1]"  # 3 of 3 both: Wilson (1 / (1 + z²/3), 1) = (0.4385, 1) twice, phi = 0
    assert rows[0][7] == "+1.50 [-4.85, +7.85]"  # d = (1, 2): 1.5 ± 12.706 · 0.5
    assert (tmp_path / "report_files" / "differences.csv").exists()
    meta = Store(tmp_path).meta("experiment:syn")  # a report without the table removes the earlier CSV
    meta["report"].pop("differences")
    Store(tmp_path).set_meta("experiment:syn", meta)
    md, _ = write_report(tmp_path)
    assert TITLE not in md.read_text() and not (tmp_path / "report_files" / "differences.csv").exists()


BASE = {"name": "x", "method": "apf", "scenario": "default_corridor", "steps": 5,
        "variants": [{"name": "a"}, {"name": "b", "params": {"k_att": 3.0}}]}


@pytest.mark.parametrize("table, fragment", [
    ({"success": "s", "pairs": [["a", "bb"]]}, "pairs[0]: unknown variant 'bb' (did you mean b"),
    ({"success": "s", "pairs": [["a", "a"]]}, "two different variants"),
    ({"success": "s", "pairs": [["a", "b", "a"]]}, "expected two variant names"),
    ({"success": "s", "pairs": ["a"]}, "pairs[0] must be a list of two variant names"),
    ({"success": "s", "pairs": []}, "pairs must be a non-empty list"),
    ({"pairs": [["a", "b"]]}, "success must be the name of a 0/1 metric"),
    ({"success": 1, "pairs": [["a", "b"]]}, "success must be the name"),
    ({"success": "s", "metrics": "dist", "pairs": [["a", "b"]]}, "metrics must be a list of metric names"),
    ({"success": "s", "metrics": ["s"], "pairs": [["a", "b"]]}, "lists the success metric"),
    ({"success": "s", "pairs": [["a", "b"]], "pair": 1}, "unknown key(s) ['pair']"),
    ("a-b", "must be a table"),
])
def test_a_bad_differences_table_is_one_line_at_load(table, fragment):
    with pytest.raises(ConfigError) as e:
        from_dict({**BASE, "report": {"differences": table}}, "x.toml", {}, None)
    assert fragment in str(e.value) and "\n" not in str(e.value) and "[report.differences]" in str(e.value)


values = st.recursive(st.none() | st.booleans() | st.integers() | st.text(max_size=4) | st.sampled_from(["a", "b"]),
                      lambda inner: st.lists(inner, max_size=3) | st.dictionaries(
                          st.sampled_from(["success", "metrics", "pairs", "x"]), inner, max_size=3), max_leaves=8)


@settings(max_examples=200, deadline=None)
@given(table=values)
def test_any_differences_value_loads_or_is_a_one_line_config_error(table):
    try:
        exp = from_dict({**BASE, "report": {"differences": table}}, "x.toml", {}, None)
    except ConfigError as e:
        assert "\n" not in str(e)
    else:  # what loads is what the report can use
        pairs = exp.report["differences"]["pairs"]
        assert all(len(p) == 2 and {p[0], p[1]} == {"a", "b"} for p in pairs)


def test_sph_table2_compares_sph_with_each_peer_on_every_forest():
    diff = load_experiment("sph-table2", seeds="1").report["differences"]
    assert diff["success"] == "sph_success" and diff["metrics"] == ["flight_distance", "flight_time"]
    want = [(f"sph/{d}", f"{peer}/{d}") for d in ("0.15", "0.25", "0.35", "0.45")
            for peer in ("sph-paper", "ego-swarm", "mader", "lsc", "nmpc")]
    assert [tuple(p) for p in diff["pairs"]] == want
