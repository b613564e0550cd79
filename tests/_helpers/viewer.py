"""Reading a replay viewer page's embedded data (its public format) in tests."""

from __future__ import annotations

import base64
import gzip
import json
import re

import numpy as np


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
