"""A quadrotor run's attitude in the replay viewer, in a real browser (Debian's headless Chromium):
each agent's thrust axis is drawn, top-down and in perspective, as the stored axis within the
stated error, at several steps; the header gives the run's largest tilt and the tooltip each
agent's; a point-mass run of the same method and scene draws no axes."""

from __future__ import annotations

import numpy as np
import pytest

from swarmnav.cli import main
from swarmnav.sim import RunResult, run
from swarmnav.viz.headless import find_chromium

pytestmark = pytest.mark.skipif(find_chromium() is None, reason="Debian's chromium is not installed (CI installs it)")

#: The axes are read back from float32 vertices and canvas coordinates: 1e-3 covers that rounding
#: (a canvas pixel over the 40 px top-down stick is 0.025, but the page keeps its float coordinates).
READBACK = 1e-3


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """APF on default_corridor for 12 s, on quadrotors and on its point mass, each with its viewer."""
    out = {}
    for name, options in (("quad", {"vehicle": "quadrotor"}), ("point", {})):
        d = tmp_path_factory.mktemp(name)
        run("apf", "default_corridor", seed=1, steps=120, **options).save(d)
        assert main(["view", str(d)]) == 0
        out[name] = d
    return out


def _open(b, d) -> dict:
    b.errors.clear()
    b.open(d / "viewer.html")
    assert b.eval("window.swarmnav.ready") is True
    return b.eval("swarmnav.data")


@pytest.mark.parametrize("view", ["top", "persp"])
def test_the_thrust_axes_drawn_are_the_stored_ones(runs, browser, view):
    res = RunResult.load(runs["quad"])
    data = _open(browser, runs["quad"])
    err = data["thrust"]["error"]
    assert browser.eval(f"swarmnav.view('{view}')") == view
    steps = (0, data["thrust"]["step"], data["K"])
    for k in steps:
        assert browser.eval(f"swarmnav.seek({k})") == k
        drawn = np.array(browser.eval("swarmnav.thrustAxes()"))
        want = res.thrust_axis[k] if view == "persp" else res.thrust_axis[k, :, :2]  # from above: x, y
        assert drawn.shape == want.shape
        assert np.linalg.norm(drawn - want, axis=1).max() <= err + READBACK, (view, k)
    # the agent read-out (the tooltip's) at the step of the run's largest tilt gives that tilt
    i, tilt = data["thrust"]["agent"], data["thrust"]["tilt_max"]
    browser.eval(f"swarmnav.seek({data['thrust']['step']})")
    a = browser.eval(f"swarmnav.agent({i})")
    assert a["tilt"] == pytest.approx(tilt, abs=np.degrees(err) + 0.01)
    assert browser.errors == []


def test_the_header_and_tooltip_give_the_tilt(runs, browser):
    data = _open(browser, runs["quad"])
    th = data["thrust"]
    header = browser.eval("document.getElementById('summary').textContent")
    assert f"largest tilt {th['tilt_max']:.1f} deg (agent {th['agent']}, t = {th['step'] * data['dt']:.2f} s)" in header
    assert 2.0 < th["tilt_max"] < 90.0
    browser.eval(f"swarmnav.seek({th['step']})")
    x, y = browser.eval(f"swarmnav.screenOf({th['agent']})")
    browser.send("Input.dispatchMouseEvent", session=True, type="mouseMoved", x=x, y=y)
    tip = browser.eval("new Promise(r => requestAnimationFrame(() => r(document.getElementById('tip').textContent)))")
    hovered = int(tip.split("\n")[0].removeprefix("agent "))  # the swarm is packed: a neighbour may be nearer
    assert f"tilt: {browser.eval(f'swarmnav.agent({hovered}).tilt'):.1f} deg" in tip
    browser.send("Input.dispatchMouseEvent", session=True, type="mouseMoved", x=2, y=60)
    assert browser.errors == []


def test_a_point_mass_run_draws_no_axes(runs, browser):
    quad = (_open(browser, runs["quad"]), browser.eval("swarmnav.view('persp')"), browser.eval("swarmnav.sceneObjects()"))[2]
    data = _open(browser, runs["point"])
    assert "thrust" not in data and browser.eval("swarmnav.thrustAxes()") is None
    assert browser.eval("swarmnav.agent(0).tilt") is None
    assert "tilt" not in browser.eval("document.getElementById('summary').textContent")
    assert browser.eval("swarmnav.view('persp')") == "persp"
    point = browser.eval("swarmnav.sceneObjects()")
    # the same scene and method: the quadrotor run's scene has exactly one more set of line segments
    assert quad["LineSegments"] == point["LineSegments"] + 1 and {**quad, "LineSegments": 0} == {**point, "LineSegments": 0}
    assert browser.errors == []
