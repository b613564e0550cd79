"""A report sets each variant beside its own column of a published table (``variant_map`` to
``[key, index]``) and reads the paper's metric names and units (``metric_map``)."""

from swarmnav.experiments import load_experiment, run_experiment
from swarmnav.experiments.report import write_report

SPEC = """name = "cols"
method = "apf"
steps = 3
seeds = "1"
[[variants]]
name = "a/0.15"
scenario = "random_forest:density=0.15,seed={seed},length=12,r_min=1.0,r_max=2.0"
[[variants]]
name = "a/0.45"
scenario = "random_forest:density=0.45,seed={seed},length=12,r_min=1.0,r_max=2.0"
[report]
reference = "sph.table2"
metrics = ["flight_distance", "sph_success", "crashes"]
metric_map = { flight_distance = "dist_m", sph_success = ["success_rate", 0.01] }
variant_map = { "a/0.15" = ["ego_swarm", 0], "a/0.45" = ["ego_swarm", 3] }
"""


def test_each_variant_reads_its_density_column_in_our_units(tmp_path):
    spec = tmp_path / "cols.toml"
    spec.write_text(SPEC)
    run_experiment(load_experiment(str(spec)), tmp_path / "o", progress=False)
    md = write_report(tmp_path / "o")[0].read_text()
    rows = {line.split("|")[1].strip(): [c.strip() for c in line.split("|")[2:-1]]
            for line in md.splitlines() if line.startswith("| a/")}
    head = next(line for line in md.splitlines() if line.startswith("| variant"))
    cols = [c.strip() for c in head.split("|")[2:-1]]
    dist, rate = cols.index("flight_distance (paper)"), cols.index("sph_success (paper)")
    assert rows["a/0.15"][dist] == "25.500 ± 2.300" and rows["a/0.45"][dist] == "32.500 ± 2.900"  # EGO-Swarm
    assert rows["a/0.15"][rate] == "1.000" and rows["a/0.45"][rate] == "0.750"  # 100 % and 75 %
    assert "crashes (paper)" not in cols  # the paper has no such column
    assert rows["a/0.45"][cols.index("paper row")] == "ego_swarm [3]"


def test_report_names_the_build_that_ran_and_the_paper_row_beside_it(tmp_path):
    spec = tmp_path / "b.toml"
    spec.write_text('name = "b"\nmethod = "hes"\nscenario = "default_corridor"\nsteps = 3\nseeds = "1"\n'
                    '[[variants]]\nname = "ours"\n[variants.params]\npreset = "faithful"\n'
                    '[report]\nreference = "hes.table2"\nmetrics = ["Y"]\nvariant_map = { ours = "rule" }\n')
    run_experiment(load_experiment(str(spec)), tmp_path / "o", progress=False)
    md = write_report(tmp_path / "o")[0].read_text()
    head = next(line for line in md.splitlines() if line.startswith("| variant"))
    row = next(line for line in md.splitlines() if line.startswith("| ours"))
    cols = [c.strip() for c in head.split("|")[1:-1]]
    cells = [c.strip() for c in row.split("|")[1:-1]]
    assert cells[cols.index("build")] == "preset=paper"  # "faithful", the earlier name, labelled by the current one
    assert cells[cols.index("paper row")] == "rule"  # our variant is set beside the paper's rule row


def test_a_run_without_a_preset_is_labelled_with_its_default_build(tmp_path):
    spec = tmp_path / "d.toml"
    spec.write_text('name = "d"\nmethod = "hes"\nscenario = "default_corridor"\nsteps = 3\nseeds = "1"\n'
                    '[[variants]]\nname = "ours"\n[[variants]]\nname = "paper"\n[variants.params]\npreset = "paper"\n'
                    '[report]\nmetrics = ["Y"]\n')
    run_experiment(load_experiment(str(spec)), tmp_path / "o", progress=False)
    md = write_report(tmp_path / "o")[0].read_text()
    head = next(line for line in md.splitlines() if line.startswith("| variant"))
    cols = [c.strip() for c in head.split("|")[1:-1]]
    build = {cells[0]: cells[cols.index("build")] for cells in
             ([c.strip() for c in line.split("|")[1:-1]] for line in md.splitlines() if line.startswith(("| ours", "| paper")))}
    assert build == {"ours": "preset=swarmnav", "paper": "preset=paper"}


def test_both_builds_swept_keep_the_paper_row_and_say_which_build_ran(tmp_path):
    spec = tmp_path / "s.toml"
    spec.write_text('name = "s"\nmethod = "hes"\nscenario = "default_corridor"\nsteps = 3\nseeds = "1"\n'
                    '[[variants]]\nname = "rule"\n[variants.params]\ndecision = "rule"\n'
                    '[report]\nreference = "hes.table2"\nmetrics = ["Y"]\n')
    exp = load_experiment(str(spec), overrides={"preset": "paper|swarmnav"})
    run_experiment(exp, tmp_path / "o", progress=False)
    md = write_report(tmp_path / "o")[0].read_text()
    head = next(line for line in md.splitlines() if line.startswith("| variant"))
    cols = [c.strip() for c in head.split("|")[1:-1]]
    rows = {cells[0]: cells for cells in ([c.strip() for c in line.split("|")[1:-1]] for line in md.splitlines()
                                          if line.startswith("| rule["))}
    assert set(rows) == {"rule[preset=paper]", "rule[preset=swarmnav]"}
    for build, cells in zip(("paper", "swarmnav"), (rows["rule[preset=paper]"], rows["rule[preset=swarmnav]"])):
        assert cells[cols.index("build")] == f"preset={build} decision=rule"
        assert cells[cols.index("paper row")] == "rule"  # the paper's rule row beside each build
