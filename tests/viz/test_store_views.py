"""``swarmnav report`` links every stored run to a replay viewer rebuilt from the store."""

from __future__ import annotations

import re

import numpy as np
import pytest

from swarmnav.cli import main
from swarmnav.viz.headless import Browser, find_chromium
from swarmnav.viz.store_views import derived_events, write_store_viewers
from swarmnav.viz.viewer import LEVELS

from _helpers.viewer import decode, page_data


@pytest.fixture(scope="module")
def store(tmp_path_factory):
    d = tmp_path_factory.mktemp("store")
    assert main(["experiment", "apf-scenes", "--seeds", "1-2", "--set", "steps=30", "--out", str(d), "--quiet"]) == 0
    return d


def test_report_links_each_run_to_its_viewer(store, capsys):
    assert main(["report", str(store)]) == 0
    assert "replay viewers under" in capsys.readouterr().out
    page = (store / "report.html").read_text()
    links = re.findall(r'<a href="(report_files/viewers/[0-9a-f]{64}\.html)">seed (\d)</a>', page)
    import sqlite3

    with sqlite3.connect(store / "results.sqlite") as db:
        rows = db.execute("SELECT key, seed, trajectory FROM runs WHERE status = 'done'").fetchall()
    assert sorted(p.split("/")[-1][:-5] for p, _ in links) == sorted(k for k, _, _ in rows)  # one link per run
    assert "## Replays" in (store / "report.md").read_text()
    key, seed, traj = rows[0]
    data = page_data(store / "report_files" / "viewers" / f"{key}.html")
    with np.load(store / traj) as z:
        stored = z["positions"].astype(float)
    q = data["quant"]
    lo, hi = np.array(q["lo"]), np.array(q["hi"])
    P = lo + decode(data["arrays"]["positions"]) * (hi - lo) / LEVELS
    assert data["K"] == 30 and data["seed"] == seed
    assert np.linalg.norm(P - stored, axis=2).max() <= q["error"] + 1e-12
    assert "from the results store" in data["note"]


def test_existing_pages_are_kept_and_no_viewers_writes_none(store):
    links, problems = write_store_viewers(store)
    assert problems == [] and len(links) == 8  # apf-scenes: four scenes x two seeds
    page = store / next(iter(links.values()))
    before = page.stat().st_mtime_ns
    assert write_store_viewers(store)[0] == links
    assert page.stat().st_mtime_ns == before  # a key names one run: its page is not rewritten
    assert main(["report", str(store), "--no-viewers"]) == 0
    assert "Replays" not in (store / "report.html").read_text()


def test_split_and_merge_marks_come_from_the_labels():
    labels = np.zeros((6, 4), dtype=int)
    labels[2:4, 2:] = 1  # a split between steps 1 and 2, a merge between 3 and 4
    assert [(e["step"], e["action"]) for e in derived_events(labels)] == [(1, "split"), (3, "merge")]


@pytest.mark.skipif(find_chromium() is None, reason="Debian's chromium is not installed (CI installs it)")
def test_a_store_viewer_opens_with_its_shared_scripts(store):
    links, _ = write_store_viewers(store)
    page = store / next(iter(links.values()))
    with Browser(900, 600) as b:
        b.open(page)
        assert b.eval("swarmnav.ready") is True
        assert b.eval("swarmnav.view('persp')") == "persp" and b.eval("swarmnav.renderer()") == "three.js r185"
        assert b.errors == []
        local = [u for u in b.requests if u.startswith("file://")]
        assert [u.rsplit("/", 1)[1] for u in local[1:]] == ["viewer-lib.js", "viewer.js"]  # beside the page


def test_a_stored_llm_transcript_gives_call_marks(store):
    import json

    from swarmnav.experiments.store import Store

    s = Store(store)
    row = s.rows()[0]
    rel = f"trajectories/{row['key'][:2]}/{row['key']}/llm_transcript.jsonl"
    (store / rel).parent.mkdir(parents=True, exist_ok=True)
    (store / rel).write_text(json.dumps({"step": 7, "model": "m", "parsed": "keep", "executed": "keep",
                                         "fallback": None}) + "\n")
    s.put({**row, "artifacts": [rel]})
    (store / "report_files" / "viewers" / f"{row['key']}.html").unlink(missing_ok=True)
    links, problems = write_store_viewers(store)
    assert problems == []
    events = page_data(store / links[row["key"]])["events"]
    assert [(e["step"], e["action"]) for e in events if e["action"] == "llm"] == [(7, "llm")]


def test_a_run_stored_by_an_older_version_still_gets_its_viewer(store):
    """The resolved parameters of an older version may name a parameter since renamed: the
    viewer needs only the step, which they carry."""
    from swarmnav.experiments.store import Store

    s = Store(store)
    row = s.rows()[1]
    config = {**row["config"], "params": {**row["config"]["params"], "renamed_since": 1.0}}
    s.put({**row, "config": config})
    (store / "report_files" / "viewers" / f"{row['key']}.html").unlink(missing_ok=True)
    links, problems = write_store_viewers(store)
    assert problems == [] and row["key"] in links
    assert page_data(store / links[row["key"]])["dt"] == row["config"]["params"]["dt"]
