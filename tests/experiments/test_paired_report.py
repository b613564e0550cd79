"""``swarmnav report DIR --compare A B``: the paired-seed percent change of B against A (HES Fig. 5),
checked against runs.csv by hand, through the files the report writes."""

import csv
import math
import re
import xml.etree.ElementTree as ET

import pytest

from swarmnav.cli import main
from swarmnav.errors import ConfigError
from swarmnav.experiments import Store, load_experiment
from swarmnav.experiments.report import paired_changes, write_report

SIM2_METRICS = ["E_mean", "L_mean", "path_stretch", "d_clr_min", "R_unsafe", "R_below_0_75", "R_below_0_30",
                "collisions", "crashes"]  # the spec's metrics, then the referee's (in every report)
SVG = "{http://www.w3.org/2000/svg}"


@pytest.fixture(scope="module")
def sim2(tmp_path_factory):
    """A real, short Simulation 2 sweep: four variants, seeds 1-3, 50 steps."""
    d = tmp_path_factory.mktemp("sim2")
    assert main(["experiment", "hes-sim2", "--seeds", "1-3", "--set", "steps=50", "--out", str(d), "--quiet"]) == 0
    return d


def _by_hand(d, a, b):
    """{(metric, seed): (100 (B - A) / |A| or None where A = 0 != B, B - A)} from runs.csv."""
    runs = {(r["variant"], int(r["seed"])): r for r in csv.DictReader(open(d / "runs.csv"))}
    out = {}
    for m in SIM2_METRICS:
        for s in (1, 2, 3):
            va, vb = float(runs[a, s][m]), float(runs[b, s][m])
            out[m, s] = ((100.0 * (vb - va) / abs(va) if va != 0 else 0.0 if vb == 0 else None), vb - va)
    return out


def _md_table(md, title):
    """Rows of the markdown table under heading ``title``: {first cell: cells}."""
    block = md.split(f"## {title}\n", 1)[1].split("\n## ", 1)[0]
    lines = [ln for ln in block.splitlines() if ln.startswith("| ")][1:]  # without the header
    return {cells[0]: cells for cells in ([c.strip() for c in ln.strip("|").split("|")] for ln in lines)}


def _svg_groups(path):
    root = ET.parse(path).getroot()
    return {g.get("id"): g for g in root.iter(f"{SVG}g") if g.get("id")}


def test_compare_gives_the_percentages_computed_by_hand_from_runs_csv(sim2, capsys):
    a, b = "safety_stack_on", "without_acceleration_bound"  # not the spec's declared pair: any two
    assert main(["report", str(sim2), "--compare", a, b]) == 0
    want = _by_hand(sim2, a, b)
    # per seed, in the CSV beside the figure
    got = list(csv.DictReader(open(sim2 / "report_files" / "paired.csv")))
    assert len(got) == len(SIM2_METRICS) * 3
    for r in got:
        pct, diff = want[r["metric"], int(r["seed"])]
        assert (r["change_pct"] == "") == (pct is None)
        if pct is not None:
            assert float(r["change_pct"]) == pytest.approx(pct, rel=1e-12, abs=1e-12)  # same floats, same formula
        assert float(r["b_minus_a"]) == pytest.approx(diff, rel=1e-12, abs=1e-15)
    # the table's median and seed count per metric (printed to 3 significant digits)
    md = (sim2 / "report.md").read_text()
    rows = _md_table(md, f"Paired by seed: {b} vs {a}")
    assert "over the 3 seeds both finished (1-3)" in md
    for m in SIM2_METRICS:
        pcts = sorted(p for (mm, _), (p, _) in want.items() if mm == m and p is not None)
        row = next(cells for name, cells in rows.items() if name.split(" [")[0] == m)
        assert row[1] == f"{len(pcts)}/3"
        if pcts:
            median = pcts[len(pcts) // 2] if len(pcts) % 2 else (pcts[0] + pcts[1]) / 2
            assert float(row[2]) == pytest.approx(median, rel=5e-3, abs=0.5 if abs(median) >= 100 else 1e-9)
        zero_a = sum(1 for (mm, _), (p, _) in want.items() if mm == m and p is None)
        assert (f"{zero_a} with A = 0" in row[6]) == (zero_a > 0)
    # the figure: one panel per metric, one dot per defined percentage, a median line each
    groups = _svg_groups(sim2 / "report_files" / "paired.svg")
    for m in SIM2_METRICS:
        assert f"paired-{m}" in groups
        n = sum(1 for (mm, _), (p, _) in want.items() if mm == m and p is not None)
        dots = groups.get(f"seeds-{m}")
        assert (len(list(dots.iter(f"{SVG}use"))) if dots is not None else 0) == n
        assert (f"median-{m}" in groups) == (n > 0)
    assert (sim2 / "report_files" / "paired.png").stat().st_size > 10_000
    assert "![paired.png](report_files/paired.png)" in md
    # the Python function gives the same per-seed table
    p = paired_changes(sim2, a, b)
    assert p.seeds == (1, 2, 3) and list(p.metrics) == SIM2_METRICS
    assert [(r["metric"], r["seed"], r["change_pct"]) for r in p.rows] == [
        (r["metric"], int(r["seed"]), float(r["change_pct"]) if r["change_pct"] else None) for r in got]


def test_report_draws_the_pair_the_spec_declares(sim2, capsys):
    """hes-sim2 declares [report] compare = [safety_stack_on, safety_stack_off]: Table 3's toggle."""
    assert main(["report", str(sim2)]) == 0
    md = (sim2 / "report.md").read_text()
    assert "## Paired by seed: safety_stack_off vs safety_stack_on" in md
    html = (sim2 / "report.html").read_text()
    assert "<h2>Paired by seed: safety_stack_off vs safety_stack_on</h2>" in html
    assert html.count("data:image/png;base64,") == 3  # bars, boxes, paired


@pytest.mark.parametrize("pair, fragment", [
    (["safety_stack_on", "safty_stack_of"], "unknown variant 'safty_stack_of' (did you mean safety_stack_off"),
    (["safety_stack_on", "safety_stack_on"], "two different variants"),
])
def test_a_bad_compare_pair_is_one_line_exit_2(sim2, capsys, pair, fragment):
    assert main(["report", str(sim2), "--compare", *pair]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and fragment in err
    with pytest.raises(ConfigError, match="unknown variant"):
        paired_changes(sim2, "safety_stack_on", "nope")


def test_spec_compare_names_are_checked_at_load(tmp_path):
    spec = tmp_path / "s.toml"
    spec.write_text('name = "s"\nmethod = "apf"\nscenario = "default_corridor"\nsteps = 5\n'
                    '[[variants]]\nname = "base"\n[[variants]]\nname = "strong"\nparams = { k_att = 3.0 }\n'
                    '[report]\ncompare = ["base", "strnog"]\n')
    with pytest.raises(ConfigError, match=r"\[report\] compare: unknown variant 'strnog' \(did you mean strong"):
        load_experiment(str(spec))


def _synthetic_store(d):
    """Variants A and B over seeds 1-4, B's seed 4 failed; metric x has A = 0 on seed 1 (B = 0.5),
    metric y has A = B = 0 on seed 1, A < 0 on seed 2 and A = inf on seed 3, metric z has A = 0
    on every seed."""
    a = {"x": [0.0, 2.0, 4.0, 1.0], "y": [0.0, -2.0, math.inf, 1.0], "z": [0.0, 0.0, 0.0, 0.0]}
    b = {"x": [0.5, 3.0, 2.0, 0.0], "y": [0.0, -1.0, 2.0, 1.0], "z": [1.0, 2.0, 3.0, 0.0]}
    store, rows, jobs = Store(d), [], []
    for name, vals in (("A", a), ("B", b)):
        for s in range(1, 5):
            key = f"{name}{s}"
            jobs.append([key, name, s])
            rows.append({"key": key, "experiment": "syn", "variant": name, "scenario": "default_corridor",
                         "method": "apf", "seed": s, "n": 20, "steps": 10, "params": {}, "config": {},
                         "status": "failed" if (name, s) == ("B", 4) else "done", "error": "", "version": "test",
                         "trajectory": "", "metrics": {m: v[s - 1] for m, v in vals.items()}, "wall_time_s": 0.0})
    store.put_many(rows)
    store.set_meta("experiment:syn", {"name": "syn", "description": "", "seeds": [1, 2, 3, 4],
                                      "variants": [{"name": n, "columns": {"variant": n}} for n in "AB"],
                                      "keys": [j[0] for j in jobs], "jobs": jobs,
                                      "report": {"metrics": ["x", "y", "z"], "compare": ["A", "B"]}})
    store.set_meta("last_experiment", "syn")


def test_zero_baseline_infinite_values_and_unpaired_seeds_are_said_not_hidden(tmp_path):
    _synthetic_store(tmp_path)
    p = paired_changes(tmp_path, "A", "B")
    assert p.seeds == (1, 2, 3) and p.only_a == (4,) and p.only_b == ()
    cell = {(r["metric"], r["seed"]): (r["change_pct"], r["b_minus_a"]) for r in p.rows}
    assert cell["x", 1] == (None, 0.5)  # A = 0: no percent, the absolute difference instead
    assert cell["x", 2] == (50.0, 1.0) and cell["x", 3] == (-50.0, -2.0)
    assert cell["y", 1] == (0.0, 0.0)  # equal zeros: no change
    assert cell["y", 2] == (50.0, 1.0)  # -2 -> -1 is up by half of |A|
    assert cell["y", 3] == (None, None)  # A = inf: skipped
    md, _ = write_report(tmp_path)
    text = md.read_text()
    assert "over the 3 seeds both finished (1-3). Seeds only `A` finished, not compared: 4." in text
    rows = _md_table(text, "Paired by seed: B vs A")
    assert rows["x"][1:] == ["2/3", "0", "0", "-50", "+50", "1 with A = 0: median B − A = +0.5"]
    assert rows["y"][1:3] == ["2/3", "+25"] and rows["y"][6] == "1 skipped (missing or not finite)"
    assert rows["z"][1:3] == ["0/3", "–"] and rows["z"][6] == "3 with A = 0: median B − A = +2"
    groups = _svg_groups(tmp_path / "report_files" / "paired.svg")
    assert {"paired-x", "paired-y", "paired-z", "median-x", "median-y"} <= set(groups) and "median-z" not in groups


def test_a_report_without_a_pair_removes_an_earlier_comparison(tmp_path):
    _synthetic_store(tmp_path)
    write_report(tmp_path)
    assert (tmp_path / "report_files" / "paired.svg").exists()
    meta = Store(tmp_path).meta("experiment:syn")
    meta["report"].pop("compare")
    Store(tmp_path).set_meta("experiment:syn", meta)
    md, html = write_report(tmp_path)
    assert not any((tmp_path / "report_files").glob("paired.*"))
    assert "Paired by seed" not in md.read_text() and "Paired by seed" not in html.read_text()
