"""``swarmnav experiment --variants``: fly some variants of a spec, the rest later or elsewhere,
into one store whose report covers the whole spec."""

import sqlite3
from pathlib import Path

from _helpers.cli import run_cli
from swarmnav.experiments import Store

SPEC = """name = "three"
method = "apf"
scenario = "default_corridor"
steps = 4
seeds = "1-2"
[[variants]]
name = "a/1"
[[variants]]
name = "a/2"
[variants.params]
k_att = 3.0
[[variants]]
name = "b/1"
[variants.params]
k_att = 4.0
"""


def _variants_done(out: Path) -> list[tuple[str, int]]:
    with sqlite3.connect(out / "results.sqlite") as db:
        return sorted(db.execute("SELECT variant, seed FROM runs WHERE status = 'done'").fetchall())


def test_only_the_matching_variants_fly_and_the_rest_join_later(tmp_path):
    spec = tmp_path / "three.toml"
    spec.write_text(SPEC)
    out = tmp_path / "out"
    p = run_cli("experiment", "--spec", spec, "--out", out, "--variants", "a/*", "--quiet")
    assert p.returncode == 0, p.stderr
    assert _variants_done(out) == [("a/1", 1), ("a/1", 2), ("a/2", 1), ("a/2", 2)]
    assert "b/1" not in p.stdout  # a variant with nothing stored is not summarised
    p = run_cli("experiment", "--spec", spec, "--out", out, "--variants", "b/1", "--quiet")
    assert p.returncode == 0, p.stderr
    assert len(_variants_done(out)) == 6 and Store(out).count() == {"done": 6}
    p = run_cli("experiment", "--spec", spec, "--out", out, "--quiet")  # the whole spec: nothing left to fly
    assert p.returncode == 0 and "6 runs (0 failed)" in p.stdout
    assert Store(out).count() == {"done": 6}


def test_a_pattern_that_matches_nothing_is_one_line_before_anything_runs(tmp_path):
    spec = tmp_path / "three.toml"
    spec.write_text(SPEC)
    for arg, words in (("c/*", "'c/*' matches no variant"), ("a/3", "did you mean"), (" , ", "give one or more")):
        p = run_cli("experiment", "--spec", spec, "--out", tmp_path / "out", "--variants", arg)
        assert p.returncode == 2 and words in p.stderr, p.stderr
        assert "Traceback" not in p.stderr and len(p.stderr.strip().splitlines()) == 1
    assert not (tmp_path / "out" / "results.sqlite").exists()
