"""The summary lines of ``run`` and ``experiment`` show the metrics that mean something for the
runs: navigation metrics where there is a goal, consensus metrics in a periodic box."""

from _helpers.cli import run_cli


def test_run_in_a_periodic_box_reports_consensus_not_goal_metrics(tmp_path):
    p = run_cli("run", "--method", "vem", "--scenario", "periodic_box:n=20,rho=1.0,seed=2", "--steps", "10",
                "--out", tmp_path / "r")
    assert p.returncode == 0, p.stderr
    line = p.stdout.splitlines()[1]
    assert "no goal (periodic box)" in line and "k_con = " in line and "deg_con_final = " in line
    assert "R_unsafe" not in line and "Y = " not in line and "R_goal" not in line


def test_run_with_a_goal_reports_navigation_metrics(tmp_path):
    p = run_cli("run", "--method", "apf", "--scenario", "default_corridor", "--steps", "5", "--out", tmp_path / "r")
    assert p.returncode == 0, p.stderr
    line = p.stdout.splitlines()[1]
    assert line.lstrip().startswith("Y = ") and "R_unsafe = " in line and "k_con" not in line


def test_experiment_summary_of_a_periodic_sweep_leaves_out_goal_metrics(tmp_path):
    spec = tmp_path / "box.toml"
    spec.write_text('name = "box"\nmethod = "vem"\nscenario = "periodic_box:n=20,rho=1.0,seed={seed}"\n'
                    'steps = 10\nseeds = "1-2"\n')
    p = run_cli("experiment", spec, "--out", tmp_path / "o", "--quiet")
    assert p.returncode == 0, p.stderr
    row = next(line for line in p.stdout.splitlines() if line.strip().startswith("default"))
    assert "k_con_mean=" in row and "converged_mean=" in row
    assert "R_unsafe" not in row and "Y_mean" not in row


def test_experiment_summary_shows_the_sph_success_test_only_for_an_sph_table(tmp_path):
    """HES's own tables have no use for the SPH paper's success test; a spec that names an SPH
    table shows it, whichever method flies."""
    for name, ref, shown in (("hes-like", "hes.table2", False), ("peer", "sph.table2", True)):
        spec = tmp_path / f"{name}.toml"
        spec.write_text(f'name = "{name}"\nmethod = "apf"\nscenario = "default_corridor"\nsteps = 5\nseeds = "1"\n'
                        f'[report]\nreference = "{ref}"\n')
        p = run_cli("experiment", spec, "--out", tmp_path / name, "--quiet")
        assert p.returncode == 0, p.stderr
        row = next(line for line in p.stdout.splitlines() if line.strip().startswith("default"))
        assert "Y_mean=" in row and ("sph_success_mean=" in row) == shown
