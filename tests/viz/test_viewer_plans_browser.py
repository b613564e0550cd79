"""Committed plans in the replay viewer, in a real browser (Debian's headless Chromium, as
test_viewer_browser.py): a run with plans (EGO-Swarm) shows the *plans* toggle, on; the lines
it draws are each robot's latest plan committed at or before the shown step, from the current
time to its end; the pixels that change when plans are switched on lie on those lines, top-down
and in perspective, and the page's check box hides them again; a run without plans has no toggle."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image
from scipy.spatial import cKDTree

from swarmnav.sim import RunResult
from swarmnav.viz.headless import Browser, find_chromium
from _helpers.viewer import viewer_runs

pytestmark = pytest.mark.skipif(find_chromium() is None, reason="Debian's chromium is not installed (CI installs it)")

FOREST = "random_forest:density=0.25,seed=1,length=12,r_min=1.0,r_max=2.0,min_passage=1.0"  # a Table II forest
STEP = 240  # [steps] of 0.02 s: robots on their way, most on a plan committed after the first
#: Anti-aliased lines of 1.5 px (3 px dashes in perspective, sub-pixel placement): every pixel
#: they change lies within this distance of the line's centre [css px].
ON_LINE = 3.0


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    return viewer_runs(tmp_path_factory, (("ego", "ego-swarm", FOREST, 300), ("apf", "apf", "default_corridor", 30),
                                          ("ego3d", "ego-swarm", "sph_cluttered_3d", 80)))


def _open(b: Browser, d) -> None:
    b.errors.clear()
    b.open(d / "viewer.html")
    assert b.eval("window.swarmnav.ready") is True


def _shot(b: Browser, path) -> np.ndarray:
    b.eval("new Promise(r => requestAnimationFrame(() => requestAnimationFrame(() => r(true))))")  # drawn
    return np.asarray(Image.open(b.screenshot(path)).convert("RGB"), dtype=np.int16)


def _on_lines(b: Browser) -> cKDTree:
    """The drawn plans projected to the page [px], sampled every 0.25 px along each segment."""
    lines = b.eval("swarmnav.plans().map(l => l && l.map(p => swarmnav.project(p)))")
    pts = []
    for line in lines:
        if not line:
            continue
        line = np.array(line)
        for a, c in zip(line[:-1], line[1:]):
            n = max(2, int(np.ceil(np.linalg.norm(c - a) / 0.25)) + 1)
            pts.append(a + np.linspace(0.0, 1.0, n)[:, None] * (c - a))
    return cKDTree(np.vstack(pts))


def test_the_drawn_plans_are_each_robots_latest_plan_ahead(runs, browser):
    res = RunResult.load(runs["ego"])
    pl, dt = res.plans, res.config["dt"]
    _open(browser, runs["ego"])
    assert browser.eval("document.getElementById('plans').checked") is True  # on: the run has plans
    err = browser.eval("swarmnav.data.quant.error")
    for k in (0, STEP, 300):
        browser.eval(f"swarmnav.seek({k})")
        drawn = browser.eval("swarmnav.plans()")
        latest = pl.latest(k, res.positions.shape[1])
        assert np.all(latest >= 0)
        for r, j in enumerate(latest):
            pts, t = pl.trajectory(j)
            ahead = int(np.sum(t >= k * dt))
            if ahead == 0:  # the plan ended before this step: nothing ahead to draw
                assert drawn[r] is None, (k, r)
                continue
            assert drawn[r] is not None and len(drawn[r]) in (ahead, ahead + 1), (k, r)
            line = np.array(drawn[r])
            now = [np.interp(k * dt, t, pts[:, c]) for c in range(2)]
            # starts at the plan's point of the current time (times to 1 ms: 1 mm at 1 m/s) ...
            assert np.linalg.norm(line[0] - now) <= err + 2e-3, (k, r)
            # ... and runs through the plan's later samples to its end
            np.testing.assert_allclose(line[-ahead:], pts[-ahead:], atol=err + 1e-5)
    # the plan shown at a step is the robot's latest: by STEP some robots have replanned
    assert np.any(pl.step[pl.latest(STEP, res.positions.shape[1])] > 0)
    assert browser.errors == []


@pytest.mark.parametrize("view", ["top", "persp"])
def test_plans_pixels_lie_on_the_lines_when_on_and_vanish_when_off(runs, browser, view, tmp_path):
    _open(browser, runs["ego"])
    assert browser.eval(f"swarmnav.view('{view}')") == view
    browser.eval("document.getElementById('trails').click()")  # trails off: only the plans change
    browser.eval(f"swarmnav.seek({STEP})")
    browser.eval("swarmnav.plans(true)")
    on = _shot(browser, tmp_path / "on.png")
    near = _on_lines(browser)
    browser.eval("document.getElementById('plans').click()")  # the page's own check box
    assert browser.eval("swarmnav.plans().every(l => l === null)")
    off = _shot(browser, tmp_path / "off.png")
    # the pixels of the view (not the controls, where the check box itself changes) [css px]
    x0, y0, x1, y1 = browser.eval("(r => [r.left, r.top, r.right, r.bottom])(document.getElementById('stage').getBoundingClientRect())")
    changed = np.argwhere(np.any(on != off, axis=2))[:, ::-1] / browser.eval("window.devicePixelRatio")  # (x, y)
    changed = changed[(changed[:, 0] >= x0) & (changed[:, 0] < x1) & (changed[:, 1] >= y0) & (changed[:, 1] < y1)]
    assert len(changed) > 500, len(changed)  # fifteen plans of metres each
    dist, _ = near.query(changed)
    assert np.quantile(dist, 0.99) <= ON_LINE and dist.max() <= 2 * ON_LINE, (np.quantile(dist, 0.99), dist.max())
    # switched on again: the same picture as before
    browser.eval("document.getElementById('plans').click()")
    again = _shot(browser, tmp_path / "again.png")
    assert np.array_equal(again, on)
    assert browser.errors == []


def test_a_3d_runs_plans_are_drawn_in_3d(runs, browser):
    res = RunResult.load(runs["ego3d"])
    _open(browser, runs["ego3d"])
    assert browser.eval("swarmnav.view()") == "persp"
    k, err = 60, browser.eval("swarmnav.data.quant.error")
    browser.eval(f"swarmnav.seek({k})")
    drawn = browser.eval("swarmnav.plans()")
    for r, j in enumerate(res.plans.latest(k, res.positions.shape[1])):
        pts, _ = res.plans.trajectory(j)
        assert len(drawn[r][-1]) == 3 and np.linalg.norm(np.array(drawn[r][-1]) - pts[-1]) <= err + 1e-5
    assert np.ptp(res.plans.points[:, 2]) > 0.1  # the plans do climb and sink: z is drawn, not assumed
    assert browser.errors == []


def test_a_run_without_plans_has_no_toggle(runs, browser):
    _open(browser, runs["apf"])
    assert browser.eval("document.getElementById('plans') === null")
    assert browser.eval("document.getElementById('trails') !== null")
    assert browser.eval("swarmnav.plans()") is None
    assert "plan" not in browser.eval("document.getElementById('legend').textContent")
    browser.eval("swarmnav.seek(20)")
    assert browser.eval("swarmnav.view('persp')") == "persp"  # draws without plans in both views
    assert browser.errors == []
