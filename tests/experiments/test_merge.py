"""``swarmnav merge``: sweeps flown into separate results directories are reported together, and
the experiment run into the merged directory finds their runs done."""

from pathlib import Path

from _helpers.cli import run_cli
from swarmnav.experiments import Store, load_experiment, run_experiment
from swarmnav.experiments.report import write_report

SPEC = """name = "two"
method = "apf"
scenario = "default_corridor"
steps = 4
seeds = "1-3"
[[variants]]
name = "a"
[[variants]]
name = "b"
[variants.params]
k_att = 3.0
"""


def _half(tmp_path: Path, variant: str, out: str) -> Path:
    """The spec with only ``variant``: one half of the sweep, flown on its own."""
    head, _, rest = SPEC.partition("[[variants]]")
    blocks = ["[[variants]]" + b for b in rest.split("[[variants]]")]
    spec = tmp_path / f"{variant}.toml"
    spec.write_text(head.replace('"two"', f'"{variant}-only"') + next(b for b in blocks if f'"{variant}"' in b))
    run_experiment(load_experiment(str(spec)), tmp_path / out, progress=False)
    return tmp_path / out


def test_merged_halves_make_the_whole_sweep_without_flying_again(tmp_path):
    a, b = _half(tmp_path, "a", "oa"), _half(tmp_path, "b", "ob")
    p = run_cli("merge", a, b, "--into", tmp_path / "all")
    assert p.returncode == 0, p.stderr
    assert "merged 6 run(s)" in p.stdout and "(0 already there)" in p.stdout
    store = Store(tmp_path / "all")
    assert store.count() == {"done": 6}
    for row in store.rows():  # every row's trajectory came along, byte for byte
        assert (tmp_path / "all" / row["trajectory"]).read_bytes() == (
            (a if row["variant"] == "a" else b) / row["trajectory"]).read_bytes()
    assert "a-only" in Path(write_report(tmp_path / "all", experiment="a-only")[0]).read_text()
    spec = tmp_path / "two.toml"
    spec.write_text(SPEC)
    rows, _ = run_experiment(load_experiment(str(spec)), tmp_path / "all", progress=False, force=True)
    assert len(rows) == 6 and all(r["status"] == "done" for r in rows)
    assert store.count() == {"done": 6}  # nothing flown again
    again = run_cli("merge", a, "--into", tmp_path / "all")
    assert "merged 0 run(s)" in again.stdout and "(3 already there)" in again.stdout


def test_merge_refuses_a_directory_without_a_store_and_the_target_itself(tmp_path):
    (tmp_path / "empty").mkdir()
    p = run_cli("merge", tmp_path / "empty", "--into", tmp_path / "all")
    assert p.returncode == 2 and "holds no results store" in p.stderr and "Traceback" not in p.stderr
    a = _half(tmp_path, "a", "oa")
    p = run_cli("merge", a, "--into", a)
    assert p.returncode == 2 and "is the target store itself" in p.stderr
