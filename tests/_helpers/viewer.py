"""Reading a replay viewer page's embedded data (its public format) in tests, and stored runs with
their viewer pages for the browser tests."""

from __future__ import annotations

import base64
import gzip
import json
import re

import numpy as np

from swarmnav.cli import main
from swarmnav.sim import run


def page_data(html_path) -> dict:
    """The JSON a viewer page embeds."""
    m = re.search(r'<script type="application/json" id="swarmnav-data">(.*?)</script>', html_path.read_text(), re.S)
    assert m, "no embedded data"
    return json.loads(m.group(1))


def decode(blob) -> np.ndarray:
    """One of the page's arrays: base64, gunzip, and the delta coding undone."""
    a = np.frombuffer(gzip.decompress(base64.b64decode(blob["data"])), dtype=np.dtype(blob["dtype"]).newbyteorder("<"))
    a = a.reshape(blob["shape"])
    return np.cumsum(a, axis=0, dtype=np.uint16) if blob["delta"] else a  # uint16 sums wrap as the page's do


def viewer_runs(tmp_path_factory, cases) -> dict:
    """``{name: run directory}`` for ``cases`` of (name, method, scene, steps): each run (seed 1)
    saved and its ``viewer.html`` written by ``swarmnav view``."""
    out = {}
    for name, method, scene, steps in cases:
        d = tmp_path_factory.mktemp(name)
        run(method, scene, seed=1, steps=steps).save(d)
        assert main(["view", str(d)]) == 0
        out[name] = d
    return out
