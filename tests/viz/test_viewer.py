"""The replay viewer's page, without a browser: self-contained, its data decode to the stored
run within the stated quantisation error, and bad input is one line with exit code 2."""

from __future__ import annotations

import re

import numpy as np
import pytest

from swarmnav.cli import main
from swarmnav.sim import run
from swarmnav.viz.viewer import LEVELS, quantisation_error, quantise

from _helpers.viewer import decode, page_data


@pytest.fixture(scope="module")
def hes_dir(tmp_path_factory):
    d = tmp_path_factory.mktemp("hes")
    run("hes", "default_corridor", seed=1, steps=400).save(d)
    return d


def test_view_writes_one_self_contained_page(hes_dir, capsys):
    out = hes_dir / "v.html"
    assert main(["view", str(hes_dir), "--out", str(out)]) == 0
    assert f"wrote {out}" in capsys.readouterr().out
    text = out.read_text()
    # nothing is fetched when the page opens: no external script, stylesheet, image or fetch
    assert not re.search(r'(src|href)\s*=\s*["\']?(https?:|//)', text)
    from importlib import resources

    own = resources.files("swarmnav.viz").joinpath("viewer", "viewer.js").read_text()
    assert "fetch(" not in own and "XMLHttpRequest" not in own and "import(" in own  # modules from blob URLs
    assert 'id="lib-core"' in text and 'id="lib-orbit"' in text  # three.js travels inside


def test_three_js_is_vendored_at_its_pinned_version_with_its_licence():
    from importlib import resources

    from swarmnav.viz.viewer import THREE_VERSION

    d = resources.files("swarmnav.viz").joinpath("vendor", "three")
    assert "three.js authors" in d.joinpath("LICENSE").read_text()
    assert f"three@{THREE_VERSION}" in d.joinpath("README.md").read_text()


def test_page_positions_equal_the_run_within_the_stated_error(hes_dir):
    from swarmnav.sim import RunResult

    main(["view", str(hes_dir)])
    d = page_data(hes_dir / "viewer.html")
    res = RunResult.load(hes_dir)
    q = d["quant"]
    lo, hi = np.array(q["lo"]), np.array(q["hi"])
    P = lo + decode(d["arrays"]["positions"]) * (hi - lo) / LEVELS
    err = np.linalg.norm(P - res.positions, axis=2)
    assert err.max() <= q["error"] + 1e-12
    # the bound is half a step per axis: a 90 m x 26 m corridor gives well under a millimetre
    assert q["error"] == pytest.approx(quantisation_error(lo, hi)) and q["error"] < 1e-3
    labels = np.array(d["label_ids"])[decode(d["arrays"]["labels"])]
    np.testing.assert_array_equal(labels, res.labels)
    assert [(e["step"], e["action"]) for e in d["events"]] == [(e["step"], e["action"]) for e in res.events]
    assert d["dim"] == 2 and d["altitude"] == 10.0  # HES Appendix A, Figure A1


def test_quantise_is_within_half_a_step_on_every_axis():
    rng = np.random.default_rng(0)
    lo, hi = np.array([-14.0, -13.0, 0.0]), np.array([76.0, 13.0, 6.0])
    x = rng.uniform(lo, hi, size=(1000, 3))
    x[0], x[1] = lo, hi  # the ends land exactly on codes 0 and LEVELS
    back = lo + quantise(x, lo, hi) * (hi - lo) / LEVELS
    assert np.all(np.abs(back - x) <= (hi - lo) / LEVELS / 2 + 1e-12)
    assert np.array_equal(quantise(x[:2], lo, hi), [[0, 0, 0], [LEVELS] * 3])


def test_run_view_writes_the_viewer_after_the_run(tmp_path, capsys):
    out = tmp_path / "r"
    assert main(["run", "--method", "apf", "--scenario", "default_corridor", "--steps", "20", "--out", str(out),
                 "--view", "--quiet"]) == 0
    assert f"viewer: {out / 'viewer.html'}" in capsys.readouterr().out
    assert page_data(out / "viewer.html")["K"] == 20


def _one_line_exit_2(args, capsys, fragment):
    assert main(args) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err and fragment in err, err


def test_bad_input_is_one_line_and_exit_2(hes_dir, tmp_path, capsys):
    _one_line_exit_2(["view", str(tmp_path)], capsys, "not a run directory (missing config.json)")
    _one_line_exit_2(["view", str(tmp_path / "nowhere")], capsys, "not a run directory")
    bad = tmp_path / "truncated"
    bad.mkdir()
    for name in ("config.json", "metrics.json", "events.jsonl"):
        (bad / name).write_bytes((hes_dir / name).read_bytes())
    whole = (hes_dir / "trajectory.npz").read_bytes()
    for cut in (len(whole) // 2, len(whole) - 100):  # cut in the data, and in the zip directory
        (bad / "trajectory.npz").write_bytes(whole[:cut])
        _one_line_exit_2(["view", str(bad)], capsys, "unreadable run directory")
    _one_line_exit_2(["plot", str(hes_dir), "--perspective", "--step", "401"], capsys, "--step must be between 0")


def test_roles_are_kept_when_a_method_reports_them_and_absent_otherwise(hes_dir, tmp_path):
    """HES reports roles (eq. 1): the run keeps them as a ``roles`` array and the page carries
    them; a method without roles (APF) keeps exactly its former four arrays."""
    from swarmnav.sim import RunResult

    res = RunResult.load(hes_dir)
    assert res.roles is not None and res.roles.shape == res.labels.shape
    assert np.all((res.roles == 2).sum(axis=1) == 1)  # one leader at every step
    for k in range(0, len(res.labels), 25):  # every sub-swarm is headed by its subleader (or the leader)
        for s in np.unique(res.labels[k]):
            assert res.roles[k][res.labels[k] == s].max() >= 1, (k, s)
    assert res.n_subswarms.max() >= 2 and np.any((res.roles >= 1).sum(axis=1) >= 2)  # the split made one more
    assert main(["view", str(hes_dir)]) == 0
    data = page_data(hes_dir / "viewer.html")
    assert data["roles"] == ["follower", "subleader", "leader"]
    np.testing.assert_array_equal(decode(data["arrays"]["roles"]), res.roles)
    d = tmp_path / "apf"
    run("apf", "default_corridor", seed=1, steps=10).save(d)
    with np.load(d / "trajectory.npz") as z:
        assert sorted(z.files) == ["clearance", "labels", "positions", "velocities"]
    assert RunResult.load(d).roles is None


def test_plot_perspective_draws_the_step_as_hes_figure_a1(hes_dir, tmp_path):
    """The PNG shows the slabs, the goal star and the arrows, and moves with --step."""
    from PIL import Image

    from swarmnav.viz.style import GOAL_FACE

    shots = {}
    for step in (50, 300):
        out = tmp_path / f"p{step}.png"
        assert main(["plot", str(hes_dir), "--perspective", "--step", str(step), "--out", str(out)]) == 0
        shots[step] = np.asarray(Image.open(out).convert("RGB"), dtype=np.int16)
    img = shots[300]
    yellow = np.all(np.abs(img - np.array([0xff, 0xd4, 0x00])) < 30, axis=2)
    assert GOAL_FACE == "#ffd400" and yellow.sum() > 50  # the goal star
    grey = np.all(np.abs(img - 0.5 * (np.array([0xc5, 0xca, 0xd3]) + 255)) < 40, axis=2)
    assert grey.mean() > 0.05  # the slabs: light grey, translucent
    blue = np.all(np.abs(img - np.array([0x1f, 0x77, 0xb4])) < 40, axis=2)
    assert blue.sum() > 20  # arrows of sub-swarm 0 (tab:blue)
    assert np.any(shots[50] != shots[300], axis=2).mean() > 0.001  # another step, another picture


def test_view_open_hands_the_page_to_the_browser(hes_dir, tmp_path, monkeypatch):
    import webbrowser

    opened = []
    monkeypatch.setattr(webbrowser, "open", lambda url: opened.append(url) or True)
    out = tmp_path / "o.html"
    assert main(["view", str(hes_dir), "--out", str(out), "--open"]) == 0
    assert opened == [out.resolve().as_uri()]


def test_llm_calls_and_fallbacks_are_timeline_marks(hes_dir, tmp_path, capsys):
    """An LLM run's transcript (docs/llm.md) gives one mark per call, a fallback its own kind."""
    import json
    import shutil

    d = tmp_path / "llm"
    shutil.copytree(hes_dir, d)
    calls = [{"step": 50, "backend": "ollama", "model": "qwen2.5:3b", "parsed": "split", "executed": "split",
              "rule_action": "split", "fallback": None},
             {"step": 100, "backend": "ollama", "model": "qwen2.5:3b", "parsed": None, "executed": "keep",
              "rule_action": "keep", "fallback": "timeout after 120 s"}]
    (d / "llm_transcript.jsonl").write_text("".join(json.dumps(c) + "\n" for c in calls))
    assert main(["view", str(d)]) == 0
    events = page_data(d / "viewer.html")["events"]
    marks = [(e["step"], e["action"]) for e in events if e["action"].startswith("llm")]
    assert marks == [(50, "llm"), (100, "llm fallback")]
    assert "timeout after 120 s" in events[[e["step"] for e in events].index(100)]["reason"]
    assert [e["step"] for e in events] == sorted(e["step"] for e in events)  # in time order with the splits
    (d / "llm_transcript.jsonl").write_text('{"backend": "ollama"}\n')
    _one_line_exit_2(["view", str(d)], capsys, "line 1 is not a transcript record")


def test_a_scene_path_travels_with_the_page(tmp_path):
    from swarmnav.world.catalog import load_scenario

    d = tmp_path / "hw"
    run("hwvem", "hwvem_mission", seed=1, steps=5).save(d)
    assert main(["view", str(d)]) == 0
    assert page_data(d / "viewer.html")["path"] == [list(map(float, p)) for p in load_scenario("hwvem_mission").path]


def test_committed_plans_travel_in_the_page_within_the_stated_error(tmp_path):
    """A planner's plans (EGO-Swarm) are in the page: their steps, robots and offsets exactly,
    points within the page's stated position error, times to 1 ms; a run without plans (HES)
    carries none."""
    from swarmnav.sim import RunResult

    d = tmp_path / "ego"
    run("ego-swarm", "random_forest:density=0.25,seed=1,length=12,r_min=1.0,r_max=2.0,min_passage=1.0",
        seed=1, steps=150).save(d)
    assert main(["view", str(d)]) == 0
    data, res = page_data(d / "viewer.html"), RunResult.load(d)
    pl, a, q = res.plans, data["arrays"], data["quant"]
    assert data["plans"] == {"count": len(pl), "points": len(pl.points)}
    for key in ("step", "robot", "offsets"):
        np.testing.assert_array_equal(decode(a[f"plan_{key}"]), getattr(pl, key))
    lo, hi = np.array(q["lo"]), np.array(q["hi"])
    pts = lo + decode(a["plan_points"]) * (hi - lo) / LEVELS
    assert np.linalg.norm(pts - pl.points, axis=1).max() <= q["error"] + 1e-5  # float32 points
    t = decode(a["plan_tau"]) + np.repeat(pl.step * res.config["dt"], np.diff(pl.offsets))
    assert np.abs(t - pl.times).max() <= 5e-4 + 1e-5
    hes = tmp_path / "hes"
    run("hes", "default_corridor", seed=1, steps=5).save(hes)
    main(["view", str(hes)])
    data = page_data(hes / "viewer.html")
    assert data["plans"] is None and not [k for k in data["arrays"] if k.startswith("plan_")]


@pytest.fixture(scope="module")
def quad_dir(tmp_path_factory):
    """APF flown on quadrotors (issue 38): a run with thrust axes."""
    d = tmp_path_factory.mktemp("quad")
    run("apf", "default_corridor", seed=1, steps=150, vehicle="quadrotor").save(d)
    return d


def test_a_quadrotor_runs_thrust_axes_travel_in_the_page_within_the_stated_error(quad_dir):
    from swarmnav.sim import RunResult
    from swarmnav.viz.viewer import AXIS_LEVELS, axis_error

    assert main(["view", str(quad_dir)]) == 0
    d = page_data(quad_dir / "viewer.html")
    res = RunResult.load(quad_dir)
    th = d["thrust"]
    assert th["levels"] == AXIS_LEVELS and th["error"] == pytest.approx(axis_error())
    A = -1.0 + decode(d["arrays"]["thrust_axis"]) * 2.0 / AXIS_LEVELS
    assert A.shape == res.thrust_axis.shape
    assert np.linalg.norm(A - res.thrust_axis, axis=2).max() <= th["error"] + 1e-7
    assert np.degrees(th["error"]) < 0.1  # [deg] the direction, to a tenth of a degree
    # the largest tilt of the run, where it happened, as the page's header states it
    tilt = np.degrees(np.arccos(res.thrust_axis[..., 2].astype(float)))
    assert th["tilt_max"] == pytest.approx(tilt.max()) and tilt[th["step"], th["agent"]] == pytest.approx(tilt.max())
    assert 2.0 < th["tilt_max"] <= res.metrics["vehicle_tilt_max"] + 1e-3  # APF's swarm leans to accelerate
    # what the axes add to the page: about 2 bytes per agent and step (base64 of the gzip of
    # delta-coded 10-bit codes); docs/viewer.md gives the figure for 20 agents x 1000 steps
    added = len(d["arrays"]["thrust_axis"]["data"])
    assert added <= 3.0 * res.thrust_axis.shape[0] * res.thrust_axis.shape[1], added


def test_a_point_mass_runs_page_has_no_thrust_axes(hes_dir):
    assert main(["view", str(hes_dir)]) == 0
    d = page_data(hes_dir / "viewer.html")
    assert "thrust" not in d and "thrust_axis" not in d["arrays"]
