"""The replay viewer in a real browser: Debian's headless Chromium, driven through the DevTools
protocol (swarmnav.viz.headless). The page loads with no console error and fetches nothing;
the agents it draws at step k are the stored ones within the quantisation error, top-down and
in perspective; event marks, keys and the agent read-out work; screenshots of a planar run,
the same run in perspective and a 3-D run are drawn and differ; adaptive resolution lowers the
perspective view's drawing buffer only while playing, and can be switched off."""

from __future__ import annotations

import time

import numpy as np
import pytest
from PIL import Image

from swarmnav.sim import RunResult
from swarmnav.viz.headless import Browser, find_chromium
from _helpers.viewer import viewer_runs

pytestmark = pytest.mark.skipif(find_chromium() is None, reason="Debian's chromium is not installed (CI installs it)")

#: Drawn positions are read back as float32 screen or instance coordinates: 1e-4 m covers
#: their rounding on top of the quantisation error the page states.
READBACK = 1e-4


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """A planar HES run with a split and a merge, and a 3-D APF run, each with its viewer."""
    return viewer_runs(tmp_path_factory, (("planar", "hes", "default_corridor", 400),
                                          ("solid", "apf", "sph_cluttered_3d", 60)))


def _open(b: Browser, d) -> dict:
    b.errors.clear()
    b.open(d / "viewer.html")
    assert b.eval("window.swarmnav.ready") is True
    return b.eval("({K: swarmnav.data.K, error: swarmnav.data.quant.error, events: swarmnav.data.events})")


def test_page_loads_without_errors_and_fetches_nothing(runs, browser):
    b = browser
    b.requests.clear()
    _open(b, runs["planar"])
    assert b.eval("swarmnav.view('persp')") == "persp"
    assert b.eval("swarmnav.renderer()") == "three.js r185"
    assert b.errors == []
    # the page itself and the blob: URLs it makes for three.js; nothing from a network or disk
    assert b.requests and all(u.startswith(("file://", "blob:", "data:")) for u in b.requests), b.requests
    assert sum(u.startswith("file://") for u in b.requests) == 1


@pytest.mark.parametrize("view", ["top", "persp"])
def test_drawn_positions_equal_the_stored_trajectory(runs, browser, view):
    res = RunResult.load(runs["planar"])
    info = _open(browser, runs["planar"])
    assert browser.eval(f"swarmnav.view('{view}')") == view
    for k in (0, 137, info["K"]):
        assert browser.eval(f"swarmnav.seek({k})") == k
        drawn = np.array(browser.eval("swarmnav.positions()"))
        err = np.linalg.norm(drawn[:, :2] - res.positions[k], axis=1)
        assert err.max() <= info["error"] + READBACK, (view, k, err.max())
        if view == "persp":  # planar runs fly at the fixed altitude of HES Figure A1, arrows along their heading
            np.testing.assert_allclose(drawn[:, 2], 10.0)
            v = res.velocities[k]
            moving = np.linalg.norm(v, axis=1) > 0.05  # [m/s]: a direction well defined at 16 bits
            h = np.array(browser.eval("swarmnav.headings()"))
            if k > 0:
                assert moving.sum() >= 10
                np.testing.assert_allclose(h[moving, :2], v[moving] / np.linalg.norm(v[moving], axis=1)[:, None],
                                           atol=1e-3)
                assert np.all(h[:, 2] == 0)
    assert browser.errors == []


def test_a_3d_run_is_drawn_in_3d(runs, browser):
    res = RunResult.load(runs["solid"])
    info = _open(browser, runs["solid"])
    assert browser.eval("swarmnav.view()") == "persp"  # a 3-D run opens in perspective
    assert browser.eval("swarmnav.seek(40)") == 40
    drawn = np.array(browser.eval("swarmnav.positions()"))
    assert np.linalg.norm(drawn - res.positions[40], axis=1).max() <= info["error"] + READBACK
    assert browser.errors == []


def test_event_marks_keys_and_agent_readout(runs, browser):
    res = RunResult.load(runs["planar"])
    info = _open(browser, runs["planar"])
    assert [e["action"] for e in info["events"]][:2] == ["split", "merge"]  # the run this test needs
    # a mark on the timeline jumps to the first state after its event
    browser.eval("document.querySelectorAll('#marks button')[1].click()")
    assert browser.eval("swarmnav.step()") == info["events"][1]["step"] + 1
    # step keys: one step, ten with shift, Home
    browser.eval("swarmnav.seek(100)")
    for key, shift, want in (("ArrowRight", False, 101), ("ArrowRight", True, 111), ("ArrowLeft", False, 110),
                             ("Home", False, 0)):
        browser.eval(f"document.dispatchEvent(new KeyboardEvent('keydown', {{key: '{key}', shiftKey: {str(shift).lower()}}}))")
        assert browser.eval("swarmnav.step()") == want
    # what hovering an agent shows: its speed and clearance, within their quantisation
    k, i = 250, 7
    browser.eval(f"swarmnav.seek({k})")
    a = browser.eval(f"swarmnav.agent({i})")
    vmax, (c_lo, c_hi) = browser.eval("[swarmnav.data.quant.vmax, swarmnav.data.quant.clearance]")
    assert a["speed"] == pytest.approx(np.linalg.norm(res.velocities[k, i]), abs=vmax / 65535 * 2)
    assert a["clearance"] == pytest.approx(res.clearance[k, i], abs=(c_hi - c_lo) / 65534)
    assert a["subswarm"] == res.labels[k, i]
    # a real mouse over that agent: the tooltip names it, with its role, speed and clearance
    x, y = browser.eval(f"swarmnav.screenOf({i})")
    browser.send("Input.dispatchMouseEvent", session=True, type="mouseMoved", x=x, y=y)
    tip = browser.eval("new Promise(r => requestAnimationFrame(() => r(document.getElementById('tip').textContent)))")
    assert tip.startswith(f"agent {i}\n") and f"speed: {a['speed']:.2f} m/s" in tip and f"role: {a['role']}" in tip
    assert a["role"] == ["follower", "subleader", "leader"][res.roles[k, i]]
    assert f"clearance: {a['clearance']:.2f} m" in tip
    # the same in perspective, late in the run, far from where the swarm started
    browser.send("Input.dispatchMouseEvent", session=True, type="mouseMoved", x=2, y=60)
    browser.eval("swarmnav.seek(0)")
    browser.eval("swarmnav.view('persp')")
    for step in (0, info["K"]):  # at the start, then at the end, tens of metres on
        browser.eval(f"swarmnav.seek({step})")
        x, y = browser.eval(f"swarmnav.screenOf({i})")
        browser.send("Input.dispatchMouseEvent", session=True, type="mouseMoved", x=x, y=y)
        tip = browser.eval("new Promise(r => requestAnimationFrame(() => r(document.getElementById('tip').textContent)))")
        assert tip.startswith(f"agent {i}\n"), (step, tip)
        browser.send("Input.dispatchMouseEvent", session=True, type="mouseMoved", x=2, y=60)
    assert browser.errors == []


def _shot(b: Browser, path) -> np.ndarray:
    img = np.asarray(Image.open(b.screenshot(path)).convert("RGB"), dtype=np.int16)
    assert len(np.unique(img.reshape(-1, 3), axis=0)) > 50  # not blank: scene, agents, chart, text
    return img


def test_screenshots_of_planar_perspective_and_3d_runs_differ(runs, browser, tmp_path):
    _open(browser, runs["planar"])
    browser.eval("swarmnav.seek(300)")
    top = _shot(browser, tmp_path / "top.png")
    browser.eval("swarmnav.view('persp')")
    browser.eval("swarmnav.seek(300)")
    persp = _shot(browser, tmp_path / "persp.png")
    _open(browser, runs["solid"])
    browser.eval("swarmnav.seek(40)")
    solid = _shot(browser, tmp_path / "solid.png")
    stage = (slice(40, 560), slice(None))  # the view, above the controls and the strip chart
    # share of the view's pixels that differ: top-down against perspective, nearly all (white
    # canvas against three.js's grey); the two perspective scenes share their background, and
    # still differ in a fifth of it (corridor slabs against a 3-D field of solids)
    for a, b, least in ((top, persp, 0.5), (top, solid, 0.5), (persp, solid, 0.1)):
        changed = np.any(a[stage] != b[stage], axis=2).mean()
        assert changed > least, changed
    # the perspective view is three.js drawing, not the top-down canvas: its background is grey
    assert tuple(persp[300, 20]) == (0xf4, 0xf6, 0xf8) and tuple(top[300, 5]) == (255, 255, 255)


def test_recorded_roles_are_marked_and_read_out(runs, browser):
    res = RunResult.load(runs["planar"])  # HES records its roles
    _open(browser, runs["planar"])
    k = 300
    browser.eval(f"swarmnav.seek({k})")
    shown = [browser.eval(f"swarmnav.agent({i}).role") for i in range(res.roles.shape[1])]
    assert shown == [["follower", "subleader", "leader"][r] for r in res.roles[k]]
    assert "leader" in browser.eval("document.getElementById('legend').textContent")
    assert browser.errors == []
    # a run without roles says so instead of guessing
    _open(browser, runs["solid"])
    assert browser.eval("swarmnav.agent(3).role") == "not recorded"


def _wait_for(browser: Browser, expression: str, seconds: float = 20.0):
    """Poll a JavaScript expression until it is truthy (or the time is up); returns its value."""
    deadline = time.monotonic() + seconds
    while not (value := browser.eval(expression)) and time.monotonic() < deadline:
        time.sleep(0.1)
    return value


def test_adaptive_resolution_lowers_the_drawing_buffer_while_playing_and_restores_it_on_pause(runs, browser):
    res = RunResult.load(runs["planar"])
    info = _open(browser, runs["planar"])
    browser.eval("swarmnav.view('persp')")
    width = "document.querySelector('#persp canvas').width"
    full = browser.eval(width)
    assert full == browser.eval("document.getElementById('stage').clientWidth")
    assert browser.eval("swarmnav.resolution()") == {"mode": "adaptive", "budget": pytest.approx(1000 / 30), "scale": 1}
    # a frame budget of 1 ms, which no frame meets: while playing, the scale steps down to half
    browser.eval("swarmnav.resolution('adaptive', 1)")
    browser.eval("swarmnav.seek(0)")
    browser.eval("swarmnav.play(2)")
    assert _wait_for(browser, "swarmnav.resolution().scale === 0.5"), browser.eval("swarmnav.resolution()")
    assert browser.eval(width) == full // 2  # three.js floors the buffer size
    # a seek pauses and draws at full resolution, where the stored trajectory is
    assert browser.eval("swarmnav.seek(137)") == 137
    assert browser.eval("swarmnav.resolution().scale") == 1 and browser.eval(width) == full
    drawn = np.array(browser.eval("swarmnav.positions()"))
    assert np.linalg.norm(drawn[:, :2] - res.positions[137], axis=1).max() <= info["error"] + READBACK
    # switched off (the page's check box): full resolution whatever the frames take
    browser.eval("document.getElementById('adaptive').click()")
    assert browser.eval("swarmnav.resolution().mode") == "full"
    browser.eval("swarmnav.play(2)")
    drawn_before = browser.eval("swarmnav.stats().draws")
    assert _wait_for(browser, f"swarmnav.stats().draws > {drawn_before} + 20")
    assert browser.eval("swarmnav.resolution().scale") == 1 and browser.eval(width) == full
    browser.eval("swarmnav.pause()")
    assert browser.errors == []
