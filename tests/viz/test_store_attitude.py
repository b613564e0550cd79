"""A quadrotor run's attitude survives the results store: the store keeps each run's thrust axes
beside its positions, ``swarmnav report`` rebuilds its replay viewer with them (drawn in a real
headless Chromium as the run's own axes), a point-mass run stores none, and a store written
before the axes were kept still reports, its quadrotor viewers without attitude."""

from __future__ import annotations

import io

import numpy as np
import pytest

from swarmnav.cli import main
from swarmnav.experiments.store import Store
from swarmnav.sim import run
from swarmnav.viz.headless import find_chromium
from swarmnav.viz.viewer import AXIS_LEVELS

from _helpers.viewer import decode, page_data

SPEC = """
name = "attitude"
description = "APF on quadrotors and on its point mass"
method = "apf"
scenario = "default_corridor"
steps = 40
seeds = "1"

[[variants]]
name = "quad"
params = { vehicle = "quadrotor" }

[[variants]]
name = "point"
"""

#: The axes are read back from float32 vertices and canvas coordinates (tests/viz/test_viewer_attitude_browser.py).
READBACK = 1e-3


@pytest.fixture(scope="module")
def store(tmp_path_factory):
    d = tmp_path_factory.mktemp("store")
    spec = d / "attitude.toml"
    spec.write_text(SPEC)
    out = d / "results"
    assert main(["experiment", "--spec", str(spec), "--out", str(out), "--quiet"]) == 0
    assert main(["report", str(out)]) == 0
    rows = {r["variant"]: r for r in Store(out).rows() if r["status"] == "done"}
    assert sorted(rows) == ["point", "quad"]
    return out, rows


def _axes(page) -> np.ndarray:
    return -1.0 + decode(page_data(page)["arrays"]["thrust_axis"]) * 2.0 / AXIS_LEVELS


def test_the_store_keeps_the_thrust_axes_the_run_recorded(store):
    root, rows = store
    direct = run("apf", "default_corridor", seed=1, steps=40, vehicle="quadrotor")
    with np.load(root / rows["quad"]["trajectory"]) as z:
        assert z["thrust_axis"].dtype == np.float32
        assert np.array_equal(z["thrust_axis"], direct.thrust_axis)  # the run's own float32 axes, bit for bit
        assert np.array_equal(z["positions"], direct.positions.astype(np.float32))
    with np.load(root / rows["point"]["trajectory"]) as z:
        assert "thrust_axis" not in z.files  # a point-mass run's file is as before
    assert direct.metrics["vehicle_tilt_max"] > 2.0  # the axes tilt: the data below is not a level constant


def test_the_report_viewer_carries_the_stored_axes(store):
    root, rows = store
    page = root / "report_files" / "viewers" / f"{rows['quad']['key']}.html"
    data = page_data(page)
    with np.load(root / rows["quad"]["trajectory"]) as z:
        stored = z["thrust_axis"].astype(float)
    A = _axes(page)
    assert A.shape == stored.shape
    assert np.linalg.norm(A - stored, axis=2).max() <= data["thrust"]["error"] + 1e-7
    tilt = np.degrees(np.arccos(stored[..., 2]))
    assert data["thrust"]["tilt_max"] == pytest.approx(tilt.max(), abs=1e-3)
    assert "thrust axes as flown" in data["note"]
    point = page_data(root / "report_files" / "viewers" / f"{rows['point']['key']}.html")
    assert "thrust" not in point and "thrust_axis" not in point["arrays"]


def test_a_store_written_before_the_axes_were_kept_still_reports(store, tmp_path):
    import shutil

    root, rows = store
    old = tmp_path / "old"
    shutil.copytree(root, old, ignore=shutil.ignore_patterns("report*"))
    path = old / rows["quad"]["trajectory"]
    with np.load(path) as z:  # the file as the store wrote it before: no thrust_axis
        kept = {k: z[k] for k in z.files if k != "thrust_axis"}
    buf = io.BytesIO()
    np.savez_compressed(buf, **kept)
    path.write_bytes(buf.getvalue())
    assert main(["report", str(old)]) == 0
    data = page_data(old / "report_files" / "viewers" / f"{rows['quad']['key']}.html")
    assert "thrust" not in data and "thrust_axis" not in data["arrays"]
    assert data["K"] == 40


@pytest.mark.skipif(find_chromium() is None, reason="Debian's chromium is not installed (CI installs it)")
@pytest.mark.parametrize("view", ["top", "persp"])
def test_the_report_viewer_draws_the_stored_axes(store, browser, view):
    root, rows = store
    page = root / "report_files" / "viewers" / f"{rows['quad']['key']}.html"
    with np.load(root / rows["quad"]["trajectory"]) as z:
        stored = z["thrust_axis"].astype(float)
    browser.errors.clear()
    browser.open(page)
    assert browser.eval("window.swarmnav.ready") is True
    data = browser.eval("swarmnav.data")
    assert browser.eval(f"swarmnav.view('{view}')") == view
    for k in (0, data["thrust"]["step"], data["K"]):
        assert browser.eval(f"swarmnav.seek({k})") == k
        drawn = np.array(browser.eval("swarmnav.thrustAxes()"))
        want = stored[k] if view == "persp" else stored[k, :, :2]  # from above: x, y
        assert drawn.shape == want.shape
        assert np.linalg.norm(drawn - want, axis=1).max() <= data["thrust"]["error"] + READBACK, (view, k)
    assert browser.errors == []
