"""The command line: outputs, reproducibility of config.json, and one-line errors (exit 2)."""

import json
import tomllib
import subprocess
import sys

import numpy as np
import pytest

from swarmnav.cli import main


def _env() -> dict:
    import os
    from pathlib import Path

    import swarmnav

    src = str(Path(swarmnav.__file__).resolve().parents[1])  # works installed or from a checkout
    return {**os.environ, "PYTHONPATH": src + os.pathsep + os.environ.get("PYTHONPATH", "")}


def _run(*args):
    return subprocess.run([sys.executable, "-m", "swarmnav.cli", *args], capture_output=True, text=True, env=_env())


def test_run_writes_run_directory_and_is_reproducible(tmp_path, capsys):
    out = tmp_path / "r"
    assert main(["run", "--method", "apf", "--scenario", "default_corridor", "--seed", "3", "--steps", "30",
                 "--out", str(out), "--set", "k_att=1.5"]) == 0
    m = json.loads((out / "metrics.json").read_text())
    cfg = json.loads((out / "config.json").read_text())
    z = np.load(out / "trajectory.npz")
    assert z["positions"].shape == (31, 20, 2)
    assert cfg["seed"] == 3 and cfg["params"]["k_att"] == 1.5 and cfg["scenario"]["name"] == "default_corridor"
    assert "swarmnav_version" in cfg and {"Y", "R_goal", "E_mean", "R_unsafe"} <= set(m)
    # config.json alone reproduces the run
    from swarmnav import run
    from swarmnav.world import from_dict

    again = run(cfg["method"], from_dict(cfg["scenario"]), seed=cfg["seed"], steps=cfg["steps"], **cfg["params"])
    np.testing.assert_array_equal(again.positions, z["positions"])


def test_scenario_file_and_plot(tmp_path):
    f = tmp_path / "s.toml"
    f.write_text('[swarm]\nn = 3\nspawn = [0, 0, 2, 2]\n[goal]\nposition = [10.0, 0.0]\n'
                 '[[obstacles]]\ntype = "circle"\ncenter = [5.0, 5.0]\nradius = 1.0\n')
    assert main(["run", "--method", "apf", "--scenario-file", str(f), "--steps", "20", "--out", str(tmp_path / "o")]) == 0
    assert main(["plot", str(tmp_path / "o")]) == 0
    assert (tmp_path / "o" / "trajectory.png").stat().st_size > 1000


@pytest.mark.parametrize("args, fragment", [
    (["run", "--method", "apf", "--scenario", "nowhere", "--out", "X"], "unknown scene"),
    (["run", "--method", "apf", "--scenario", "default_corridor", "--out", "X", "--set", "bogus=1"], "unknown parameter 'bogus'"),
    (["run", "--method", "apf", "--scenario", "default_corridor", "--out", "X", "--set", "k_att=abc"], "expected a number"),
    (["run", "--method", "nope", "--scenario", "default_corridor", "--out", "X"], "unknown method"),
    (["run", "--method", "apf", "--out", "X"], "exactly one of --scenario"),
    (["run", "--method", "apf", "--scenario", "default_corridor", "--steps", "0", "--out", "X"], "--steps must be >= 1"),
    (["run", "--method", "apf", "--scenario", "default_corridor", "--seed", "-1", "--out", "X"], "seed must be an integer >= 0"),
    (["experiment", "apf-scenes", "--seeds=-3", "--out", "X"], "seeds must be >= 0"),
    (["run", "--method", "apf", "--scenario", "default_corridor", "--set", "n=2.5", "--out", "X"], "--set n: expected an integer"),
    (["run", "--method", "apf", "--scenario", "default_corridor", "--out", "F/sub"], "cannot create the directory"),
    (["experiment", "apf-scenes", "--seeds", "1", "--out", "F"], "cannot create the directory"),
    (["scenarios", "show", "default_corridor", "--plot", "F/scene.png"], "cannot create the directory"),
    (["run", "--method", "apf", "--scenario-file", "missing.toml", "--out", "X"], "no such scene file"),
    (["experiment", "nope", "--out", "X"], "unknown experiment"),
    (["experiment", "apf-scenes", "--seeds", "x-y", "--out", "X"], "--seeds"),
    (["plot", "/nonexistent/run"], "not a run directory"),
    (["run", "--method", "apf", "--out", "X", "--bogus-flag"], "unrecognized arguments"),
    (["run", "--bogus-flag"], "arguments are required"),
    # a newcomer's list (issue 14): APF parameters, scene files of the wrong format, typos
    (["run", "--method", "apf", "--scenario", "default_corridor", "--out", "X", "--set", "dt=-0.1"], "dt must be in [0.0001, 1] s, got -0.1"),
    (["run", "--method", "apf", "--scenario", "default_corridor", "--out", "X", "--set", "dt=0"], "dt must be in [0.0001, 1] s, got 0.0"),
    (["run", "--method", "apf", "--scenario", "default_corridor", "--out", "X", "--set", "a_max=-1"], "a_max must be in (0, inf) m/s^2, got -1.0"),
    (["run", "--method", "apf", "--scenario", "default_corridor", "--out", "X", "--set", "n_rays=0"], "n_rays must be in [4, 36000], got 0"),
    (["run", "--method", "apf", "--scenario", "default_corridor", "--out", "X", "--set", "lidar_range=-5"], "lidar_range must be in (0, inf) m, got -5.0"),
    (["run", "--method", "hes", "--scenario", "default_corridor", "--out", "X", "--set", "k_rep=inf"], "k_rep: expected a finite number"),
    (["run", "--method", "apf", "--scenario-file", "J", "--out", "X"], "scene files are TOML (.toml), not JSON"),
    (["run", "--method", "apf", "--scenario", "default_coridor", "--out", "X"], "did you mean default_corridor?"),
    (["run", "--method", "hse", "--scenario", "default_corridor", "--out", "X"], "did you mean hes?"),
    (["run", "--method", "hes", "--scenario", "default_corridor", "--out", "X", "--set", "preset=papers"], "unknown preset 'papers' (did you mean paper"),
    (["run", "--method", "sph", "--scenario", "default_corridor", "--out", "X", "--steps", "5", "--horizon", "3"], "not allowed with argument"),
    (["run", "--method", "sph", "--scenario", "default_corridor", "--out", "X", "--horizon", "-3"], "horizon must be finite and > 0 s"),
    (["experiment", "apf-scenes", "--set", "k_rep=-1", "--out", "X"], "variant default_corridor: apf: k_rep must be in [0, inf)"),
    (["methods", "nope"], "unknown method 'nope'"),
])
def test_bad_input_is_one_line_exit_2(args, fragment, tmp_path):
    (tmp_path / "f").write_text("a file where an output directory should go")
    (tmp_path / "scene.json").write_text('{"name": "a scene in the wrong format"}')
    p = _run(*[a.replace("X", str(tmp_path / "x")).replace("F", str(tmp_path / "f"))
               .replace("J", str(tmp_path / "scene.json")) for a in args])
    assert p.returncode == 2, p.stderr
    assert "Traceback" not in p.stderr
    lines = [l for l in p.stderr.splitlines() if l.strip()]
    assert len(lines) == 1 and fragment in lines[0], p.stderr


def test_malformed_scene_file_is_one_line(tmp_path):
    f = tmp_path / "bad.toml"
    f.write_text("[swarm\nn = 3\n")
    p = _run("run", "--method", "apf", "--scenario-file", str(f), "--out", str(tmp_path / "o"))
    assert p.returncode == 2 and "bad.toml" in p.stderr and "malformed TOML" in p.stderr
    assert len(p.stderr.strip().splitlines()) == 1


def test_scenarios_list_and_show(tmp_path, capsys):
    assert main(["scenarios"]) == 0
    out = capsys.readouterr().out
    for name in ("default_corridor", "narrow_alternating_gates", "dense_cross_blocks", "off_axis_goal"):
        assert name in out
    png = tmp_path / "s.png"
    assert main(["scenarios", "show", "off_axis_goal", "--plot", str(png)]) == 0
    assert tomllib.loads(capsys.readouterr().out)["goal"]["position"] == [70.0, 7.5]
    assert png.stat().st_size > 1000
    assert main(["scenarios", "show", "off_axis_goal", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["goal"]["position"] == [70.0, 7.5]


def test_experiment_runner_end_to_end(tmp_path):
    import csv

    out = tmp_path / "e"
    assert main(["experiment", "apf-scenes", "--seeds", "1-2", "--workers", "2", "--set", "steps=30",
                 "--out", str(out), "--quiet"]) in (0, 1)
    runs = list(csv.DictReader(open(out / "runs.csv")))
    summary = list(csv.DictReader(open(out / "summary.csv")))
    assert len(runs) == 8 and all(r["status"] == "done" for r in runs)
    assert len(summary) == 4
    s = summary[0]
    assert {"E_mean_mean", "E_mean_std", "d_clr_min_min", "Y_mean"} <= set(s)
    vals = [float(r["E_mean"]) for r in runs if r["variant"] == s["variant"]]
    assert float(s["E_mean_mean"]) == pytest.approx(np.mean(vals))
    assert float(s["E_mean_std"]) == pytest.approx(np.std(vals))
    # the same seeds serially give identical rows (per-run seeding, no shared state)
    out2 = tmp_path / "e2"
    main(["experiment", "apf-scenes", "--seeds", "1-2", "--workers", "1", "--set", "steps=30", "--out", str(out2), "--quiet"])
    runs2 = list(csv.DictReader(open(out2 / "runs.csv")))
    strip = lambda rs: [{k: v for k, v in r.items() if k != "wall_time_s"} for r in rs]  # noqa: E731
    assert strip(runs) == strip(runs2)


def test_experiment_sweep_syntax(tmp_path):
    from swarmnav.experiments import load_experiment

    exp = load_experiment("apf-scenes", overrides={"k_att": "1|2"}, seeds="1")
    assert len(exp.variants) == 8
    assert exp.variants[0].name == "default_corridor[k_att=1]"


def test_spec_params_take_nested_tables_as_dotted_names(tmp_path, capsys):
    from swarmnav.experiments import load_experiment

    spec = tmp_path / "s.toml"
    spec.write_text('name = "s"\nmethod = "hes"\nscenario = "default_corridor"\nsteps = 5\n'
                    '[params]\npassage.on = false\n[params.stall]\non = false\n'
                    '[[variants]]\nname = "a"\n[variants.params]\nablation.safety_stack_off = true\n')
    (v,) = load_experiment(str(spec), seeds="1").variants
    assert v.params == {"passage.on": False, "stall.on": False, "ablation.safety_stack_off": True}
    sim2 = {x.name: x.params for x in load_experiment("hes-sim2", seeds="1").variants}
    assert sim2["safety_stack_off"]["ablation.safety_stack_off"] is True
    spec.write_text('name = "s"\nmethod = "hes"\nscenario = "default_corridor"\nsteps = 5\nparams = 3\n')
    assert main(["experiment", "--spec", str(spec), "--seeds", "1", "--out", str(tmp_path / "o")]) == 2
    assert "params must be a table" in capsys.readouterr().err


def test_readme_main_job_command(tmp_path, capsys):
    """The README's main job: a 1000-step HES run with its figure (kept short here)."""
    out = tmp_path / "demo"
    assert main(["run", "--method", "hes", "--scenario", "default_corridor", "--seed", "1", "--steps", "120",
                 "--out", str(out), "--plot"]) == 0
    assert (out / "trajectory.png").stat().st_size > 10_000
    assert "Y =" in capsys.readouterr().out


def test_plot_and_animate_into_an_unwritable_place_are_one_line(tmp_path):
    run_dir, blocker = tmp_path / "r", tmp_path / "f"
    blocker.write_text("a file, not a directory")
    assert main(["run", "--method", "apf", "--scenario", "default_corridor", "--steps", "5", "--out", str(run_dir)]) == 0
    for cmd in (["plot", str(run_dir), "--out", str(blocker / "t.png")],
                ["animate", str(run_dir), "--out", str(blocker / "a.gif")]):
        p = _run(*cmd)
        assert p.returncode == 2 and "Traceback" not in p.stderr, p.stderr
        assert len(p.stderr.strip().splitlines()) == 1 and "cannot create the directory" in p.stderr


def test_a_closed_pipe_on_stdout_is_not_a_traceback(tmp_path):
    # `swarmnav run ... | head -1`: the reader is gone before the summary is printed
    p = subprocess.Popen([sys.executable, "-m", "swarmnav.cli", "run", "--method", "apf", "--scenario", "default_corridor",
                          "--steps", "5", "--out", str(tmp_path / "o")],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=_env())
    p.stdout.close()
    err = p.stderr.read().decode()
    assert p.wait(timeout=120) == 1 and "Traceback" not in err, err
    assert (tmp_path / "o" / "metrics.json").exists()


def test_only_a_broken_stdout_counts_as_the_reader_leaving(monkeypatch):
    import os

    from swarmnav.cli import _stdout_closed

    r, w = os.pipe()
    with os.fdopen(w, "w") as out:
        monkeypatch.setattr(sys, "stdout", out)
        assert not _stdout_closed()  # reader still there: another pipe broke, keep the traceback
        os.close(r)
        assert _stdout_closed()
        monkeypatch.undo()


def test_methods_name_lists_every_parameter_with_unit_range_and_source(capsys):
    from swarmnav.methods import registry
    from swarmnav.params import describe

    for name in registry.names():
        assert main(["methods", name]) == 0
        out = capsys.readouterr().out
        rows = {line.split()[0]: line for line in out.splitlines() if line and not line.startswith(" ")}
        for info in describe(registry.spec(name).params):
            row = rows[info.name]  # one row per parameter
            assert info.valid.split(" (")[0] in row and info.source in row, row
            assert f" {info.unit} " in row if info.unit else " - " in row
    main(["methods", "hes"])
    out = capsys.readouterr().out
    assert "builds: the default is preset=swarmnav; the paper's is preset=paper" in out
    assert "dt" in out and "[0.0001, 1]" in out and "Section 5.1" in out


def test_horizon_is_the_same_simulated_time_for_every_method(tmp_path, capsys):
    steps = {}
    for method in ("sph", "apf", "hwvem"):
        out = tmp_path / method
        assert main(["run", "--method", method, "--scenario", "hwvem_mission", "--horizon", "2", "--out", str(out),
                     "--set", "n=4", "--quiet"]) == 0
        cfg = json.loads((out / "config.json").read_text())
        assert cfg["horizon"] == pytest.approx(2.0) and cfg["steps"] * cfg["dt"] == pytest.approx(2.0)
        steps[method] = cfg["steps"]
    assert steps == {"sph": 200, "apf": 20, "hwvem": 2}
    capsys.readouterr()
    assert main(["run", "--method", "apf", "--scenario", "default_corridor", "--steps", "7", "--out",
                 str(tmp_path / "s"), "--quiet"]) == 0
    cfg = json.loads((tmp_path / "s" / "config.json").read_text())
    assert cfg["steps"] == 7 and cfg["horizon"] == pytest.approx(0.7)  # both recorded either way


def _scene_names():
    from swarmnav.world.scenario import builtin_names

    return builtin_names() + ["random_forest:density=0.25,seed=4", "random_forest_3d:density=0.15,seed=2",
                              "periodic_box:n=50,rho=4.102"]


@pytest.mark.parametrize("name", _scene_names())
def test_scenarios_show_prints_a_scene_file_that_loads_back(name, tmp_path, capsys):
    from swarmnav.world.catalog import load_scenario

    assert main(["scenarios", "show", name]) == 0
    f = tmp_path / "scene.toml"
    f.write_text(capsys.readouterr().out)
    assert load_scenario(f).to_dict() == load_scenario(name).to_dict()


def test_a_shown_scene_flies_exactly_as_the_built_in(tmp_path, capsys):
    assert main(["scenarios", "show", "narrow_alternating_gates"]) == 0
    (tmp_path / "gates.toml").write_text(capsys.readouterr().out)
    for src, out in ((["--scenario", "narrow_alternating_gates"], "a"), (["--scenario-file", str(tmp_path / "gates.toml")], "b")):
        assert main(["run", "--method", "hes", *src, "--steps", "40", "--out", str(tmp_path / out), "--quiet"]) == 0
    a, b = (np.load(tmp_path / d / "trajectory.npz") for d in "ab")
    np.testing.assert_array_equal(a["positions"], b["positions"])


def test_first_run_says_it_compiles_and_a_warm_run_does_not(tmp_path):
    """A fresh Numba cache: one notice line while the kernels compile; the next run loads them."""
    import os

    env = {**_env(), "NUMBA_CACHE_DIR": str(tmp_path / "cache")}
    args = ["run", "--method", "vem", "--scenario", "periodic_box:n=20,rho=4.102", "--steps", "2", "--out"]
    cold = subprocess.run([sys.executable, "-m", "swarmnav.cli", *args, str(tmp_path / "a")], env=env,
                          capture_output=True, text=True, timeout=600)
    assert cold.returncode == 0, cold.stderr
    assert cold.stderr.count("compiling numerical kernels, saved for later runs") == 1
    warm = subprocess.run([sys.executable, "-m", "swarmnav.cli", *args, str(tmp_path / "b")], env=env,
                          capture_output=True, text=True, timeout=600)
    assert warm.returncode == 0 and "compiling" not in warm.stderr, warm.stderr
    assert os.listdir(tmp_path / "cache")


def test_the_compile_notice_waits_for_a_compile_that_takes_time(monkeypatch, capsys):
    """A compile shorter than COMPILE_NOTICE_AFTER (one small kernel) says nothing; the notice
    comes once compiling has taken that long, and only once."""
    import numba

    from swarmnav import cli

    numba.njit(lambda x: x - 1)(1)  # Numba's own one-off start-up is not what is timed below
    listener = cli._notify_compiling()
    try:
        numba.njit(lambda x: x + 1)(1)  # ~0.05 s of compiling, far below 2 s
        assert capsys.readouterr().err == ""
    finally:
        cli._stop_notice(listener)
    monkeypatch.setattr(cli, "COMPILE_NOTICE_AFTER", 0.0)
    listener = cli._notify_compiling()
    try:
        numba.njit(lambda x: x * 2)(1)
        numba.njit(lambda x: x * 3)(1)
        assert capsys.readouterr().err == cli.COMPILE_NOTICE + "\n"
    finally:
        cli._stop_notice(listener)


def test_a_directory_in_place_of_the_trajectory_is_one_line_and_leaves_nothing(tmp_path):
    out = tmp_path / "o"
    (out / "trajectory.npz").mkdir(parents=True)
    p = _run("run", "--method", "apf", "--scenario", "default_corridor", "--steps", "5", "--out", str(out), "--quiet")
    assert p.returncode == 2 and "Traceback" not in p.stderr, p.stderr
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1 and f"{out / 'trajectory.npz'} is a directory" in lines[0], p.stderr
    assert sorted(x.name for x in out.iterdir()) == ["trajectory.npz"]  # no .tmp, no half-written run
    assert list((out / "trajectory.npz").iterdir()) == []


def test_save_never_leaves_a_temporary_file(tmp_path, monkeypatch):
    """RunResult.save (the library, under the CLI's check): a directory in the way and a write
    that fails half-way (a full disk) are one-line SwarmnavErrors, and no .tmp stays behind."""
    import errno
    import os

    from swarmnav import run
    from swarmnav.errors import SwarmnavError
    from swarmnav.world.catalog import load_scenario

    res = run("apf", load_scenario("default_corridor"), seed=1, steps=3)
    (tmp_path / "a" / "config.json").mkdir(parents=True)
    with pytest.raises(SwarmnavError, match="cannot write .*config.json: a directory"):
        res.save(tmp_path / "a")
    assert sorted(x.name for x in (tmp_path / "a").iterdir()) == ["config.json"]  # checked before writing

    def full(fd):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(os, "fsync", full)
    with pytest.raises(SwarmnavError, match="cannot write .*trajectory.npz: No space left on device"):
        res.save(tmp_path / "b")
    assert list((tmp_path / "b").iterdir()) == []


def _run_into(out, *extra, method="apf", scene="default_corridor"):
    return main(["run", "--method", method, "--scenario", scene, "--steps", "10", "--out", str(out), "--quiet", *extra])


def test_run_refuses_a_directory_that_holds_a_run_unless_forced(tmp_path, capsys):
    out = tmp_path / "o"
    assert _run_into(out, "--plot", "--view", method="hes") == 0
    first = json.loads((out / "config.json").read_text())
    (out / "notes.txt").write_text("the user's own file")
    capsys.readouterr()
    assert _run_into(out, method="apf", scene="off_axis_goal") == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f"--out {out} already holds a run" in err[0] and "--force" in err[0], err
    assert json.loads((out / "config.json").read_text()) == first  # untouched
    assert _run_into(out, "--force", method="apf", scene="off_axis_goal") == 0
    cfg = json.loads((out / "config.json").read_text())
    assert cfg["method"] == "apf" and cfg["scenario"]["name"] == "off_axis_goal"
    # the first run's figure and viewer are gone; the user's file is kept and named
    assert sorted(x.name for x in out.iterdir()) == ["config.json", "events.jsonl", "metrics.json", "notes.txt",
                                                     "trajectory.npz"]
    assert "kept files that are not a run's: notes.txt" in capsys.readouterr().err


def test_a_forced_run_that_fails_keeps_the_previous_run(tmp_path, capsys):
    out = tmp_path / "o"
    assert _run_into(out) == 0
    before = (out / "trajectory.npz").read_bytes()
    assert _run_into(out, "--force", "--set", "k_att=-1") == 2  # rejected: nothing was replaced
    assert (out / "trajectory.npz").read_bytes() == before


def test_run_into_a_directory_of_other_files_needs_no_force(tmp_path):
    out = tmp_path / "o"
    out.mkdir()
    (out / "notes.txt").write_text("not a run")
    assert _run_into(out) == 0 and (out / "notes.txt").read_text() == "not a run"


@pytest.mark.parametrize("method, default, n_diff, differs", [
    ("hes", "swarmnav", 16, ["passage.on              true -> false", "core.merge_rule         swarmnav -> paper_cooldown"]),
    ("sph", "swarmnav", 11, ["retime          0.8 -> 0", "band_guard      true -> false", "rep_cutoff      3 -> 0",
             "crowd_guard     true -> false", "pair_guard      true -> false", "pair_obstacles  true -> false"]),
    ("hwvem", "mission", 1, ["wrap_neighbours  true -> false"]),
    ("ego-swarm", "swarmnav", 2, ["retry_guide     astar -> previous"]),
])
def test_methods_names_the_default_and_the_paper_build_and_what_differs(method, default, n_diff, differs, capsys):
    assert main(["methods", method]) == 0
    out = capsys.readouterr().out
    same = " (the same build)" if default == "paper" else ""
    assert f"builds: the default is preset={default}; the paper's is preset=paper{same}" in out
    lines = out.splitlines()
    paper = next(i for i, line in enumerate(lines) if line.startswith("  paper ("))
    assert ("the default" in lines[paper]) == (default == "paper")
    if n_diff:
        assert lines[paper + 1] == f"    differs from the default in {n_diff} parameter(s) (default -> paper):"
        listed = lines[paper + 2: paper + 2 + n_diff]
        assert all(line.startswith("      ") for line in listed)
        for d in differs:
            assert f"      {d}" in listed
    if method == "sph":  # our recommended sets are named, with what they change
        guard = next(i for i, line in enumerate(lines) if line.startswith("  guard: ours, recommended in 2-D"))
        # guard = the default's 2-D set below 30 robots: retime and the crowd parts off
        listed = [line.split() for line in lines[guard + 2: guard + 8]]
        assert ["retime", "0.8", "->", "0"] in listed and ["by_dim", "true", "->", "false"] in listed
        assert ["rep_cutoff", "3", "->", "0"] in listed and ["crowd_guard", "true", "->", "false"] in listed
    if method == "hes":
        assert "  faithful: the earlier name of preset paper (still accepted, same values)" in out
