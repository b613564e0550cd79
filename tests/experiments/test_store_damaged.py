"""A results store SQLite cannot use (random bytes, a truncated database, a directory in its
place) is bad input: every command that opens it ends with one line naming the file, exit 2."""

import shutil

import pytest

from swarmnav.cli import main
from swarmnav.experiments import load_experiment, run_experiment

SWEEP = ["apf-scenes", "--seeds", "1", "--set", "steps=5", "--quiet"]


@pytest.fixture(scope="module")
def good_store(tmp_path_factory):
    out = tmp_path_factory.mktemp("good")
    run_experiment(load_experiment("apf-scenes", overrides={"steps": "5"}, seeds="1"), out, progress=False)
    return out


def _random_bytes(db):
    db.write_bytes(bytes(range(256)) * 20)


def _truncated(db):
    data = db.read_bytes()
    assert len(data) > 8192  # a real database of several pages, cut inside its first page
    db.write_bytes(data[:1000])


def _directory(db):
    db.unlink()
    db.mkdir()


@pytest.mark.parametrize("damage", [_random_bytes, _truncated, _directory])
@pytest.mark.parametrize("command", [["report", "D"], ["report", "D", "--no-viewers"],
                                     ["experiment", *SWEEP, "--out", "D"]])
def test_a_damaged_store_is_one_line_naming_the_file(good_store, tmp_path, capsys, damage, command):
    d = tmp_path / "d"
    shutil.copytree(good_store, d)
    damage(d / "results.sqlite")
    assert main([a.replace("D", str(d)) if a == "D" else a for a in command]) == 2
    err = [ln for ln in capsys.readouterr().err.splitlines() if ln.strip()]
    assert len(err) == 1 and str(d / "results.sqlite") in err[0], err
    assert "not a usable results store (SQLite: " in err[0]


def test_the_undamaged_copy_still_reports_and_resumes(good_store, tmp_path, capsys):
    # the same commands on the intact store succeed: the damage, not the command, is what fails above
    d = tmp_path / "d"
    shutil.copytree(good_store, d)
    assert main(["experiment", *SWEEP, "--out", str(d)]) == 0
    assert main(["report", str(d), "--no-viewers"]) == 0
    assert (d / "report.md").exists()
