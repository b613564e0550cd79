"""The report's header says how much of the sweep is done (runs done of planned, per variant
and overall) and what it ran with (seeds, --set overrides)."""

import pytest

from swarmnav.cli import main
from swarmnav.experiments import Store, load_experiment, plan, run_experiment
from swarmnav.experiments.jobs import failed_row
from swarmnav.experiments.report import write_report

SPEC = 'name = "one"\nmethod = "apf"\nscenario = "default_corridor"\nsteps = 5\nseeds = "1-10"\n'


def _interrupted(spec, out, after):
    """Run the sweep until ``after`` runs are stored, then stop it as Ctrl-C would."""
    stored = []

    def stop(row):
        stored.append(row)
        if len(stored) == after:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run_experiment(load_experiment(str(spec)), out, progress=False, on_row=stop)


def test_an_interrupted_sweep_is_reported_incomplete_until_resumed(tmp_path):
    spec = tmp_path / "one.toml"
    spec.write_text(SPEC)
    out = tmp_path / "o"
    _interrupted(spec, out, after=6)
    md_path, html_path = write_report(out)
    md, page = md_path.read_text(), html_path.read_text()
    assert "| default | 6/10 |" in md  # done of planned, not 6/6
    assert ("6 of 10 planned runs done — **incomplete**: 6 of 10 seeds in every variant (4 not run; rerun the "
            "same `swarmnav experiment` command into this directory to finish it)") in md
    assert '<p class="incomplete">' in page and "<strong>incomplete</strong>: 6 of 10 seeds in every variant" in page
    # a failed run is not done either
    job = next(j for j in plan(load_experiment(str(spec))) if j.seed == 7)
    Store(out).put(failed_row(job, "boom"))
    md = write_report(out)[0].read_text()
    assert "6 of 10 seeds in every variant (3 not run, 1 failed;" in md
    run_experiment(load_experiment(str(spec)), out, progress=False)  # resumed: the same sweep, finished
    md_path, html_path = write_report(out)
    md, page = md_path.read_text(), html_path.read_text()
    assert "| default | 10/10 |" in md and "10 of 10 planned runs done." in md
    assert "incomplete" not in md and "<strong>incomplete" not in page and 'class="incomplete"' not in page


def test_variants_that_differ_in_progress_are_each_named(tmp_path):
    spec = tmp_path / "two.toml"
    spec.write_text(SPEC.replace('seeds = "1-10"', 'seeds = "1-4"')
                    + '[[variants]]\nname = "a"\n[[variants]]\nname = "b"\nparams = { k_att = 1.5 }\n')
    _interrupted(spec, tmp_path, after=5)  # jobs go variant by variant: a has 4 of 4, b 1 of 4
    md = write_report(tmp_path)[0].read_text()
    assert "| a | 4/4 |" in md and "| b | 1/4 |" in md
    assert "5 of 8 planned runs done — **incomplete**: b 1 of 4 seeds (3 not run;" in md


def test_the_header_lists_the_seeds_and_the_set_overrides(tmp_path, capsys):
    spec = tmp_path / "one.toml"
    spec.write_text(SPEC)
    assert main(["experiment", "--spec", str(spec), "--seeds", "1-3,7", "--set", "k_att=1.5", "--set", "steps=4",
                 "--out", str(tmp_path / "a"), "--quiet"]) == 0
    assert main(["report", str(tmp_path / "a"), "--no-viewers"]) == 0
    md, page = ((tmp_path / "a" / f).read_text() for f in ("report.md", "report.html"))
    assert "Seeds: 1-3, 7. Overrides (`--set`): `k_att=1.5` `steps=4`." in md
    assert "Seeds: 1-3, 7. Overrides (<code>--set</code>): <code>k_att=1.5</code> <code>steps=4</code>." in page
    assert "4 of 4 planned runs done." in md
    assert main(["experiment", "--spec", str(spec), "--seeds", "2", "--out", str(tmp_path / "b"), "--quiet"]) == 0
    assert main(["report", str(tmp_path / "b"), "--no-viewers"]) == 0
    assert "Seeds: 2. Overrides (`--set`): none." in (tmp_path / "b" / "report.md").read_text()
